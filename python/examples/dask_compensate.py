"""Compensate a Parquet survey partitioned across Dask workers.

Each partition is compensated on its own with ``level="model"``: the level subtracted is the
calibration's, stored in the model, so a row's result does not depend on which partition it
is in. Only the first and last two rows of a partition differ from the whole-file result,
because the eddy-current terms' time derivative is one-sided at a partition's ends.

    python examples/dask_compensate.py survey.parquet model.json out.parquet
"""

import sys

import dask.dataframe as dd

import tolles


def compensate_dataset(path, model, partition_rows=None):
    """The survey at ``path`` (a Parquet file or directory) compensated lazily, one task per
    partition; ``partition_rows`` re-partitions to about that many rows each."""
    survey = dd.read_parquet(path)
    if partition_rows:
        survey = survey.repartition(npartitions=max(1, len(survey) // partition_rows))
    model = model if isinstance(model, tolles.Model) else tolles.load_model(model)
    # The empty result tells Dask the output's columns and types without computing anything.
    meta = tolles.compensate(survey.head(0), model, level="model")
    return survey.map_partitions(tolles.compensate, model, level="model", meta=meta)


if __name__ == "__main__":
    survey, model, out = sys.argv[1:4]
    compensate_dataset(survey, model).to_parquet(out)

"""Scale-out on Dask: a Parquet dataset partitioned across workers, compensated partition by
partition with the model's level, equals the whole-file result away from partition edges.
The same code is the README's recipe (python/examples/dask_compensate.py)."""

import sys
from pathlib import Path

import numpy as np
import pytest

import tolles

dd = pytest.importorskip("dask.dataframe")
pytest.importorskip("pyarrow")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))
import dask_compensate  # noqa: E402


def test_partitioned_compensation_equals_the_whole_file_away_from_edges(tmp_path):
    survey = tolles.simulate(plan="survey", seed=7, lines=3)
    cal = tolles.simulate(plan="box", seed=6)
    model = tolles.fit(cal)
    dataset = tmp_path / "survey.parquet"
    survey.to_parquet(dataset, row_group_size=500)  # several partitions
    parts = dask_compensate.compensate_dataset(dataset, model, partition_rows=997)
    assert parts.npartitions > 3
    got = parts.compute()
    whole = tolles.compensate(survey, model, level="model")
    assert list(got.columns) == list(whole.columns)
    edges = np.zeros(len(whole), dtype=bool)
    offset = 0
    for n in parts.map_partitions(len).compute():
        edges[max(offset - 2, 0) : offset + 2] = True  # one-sided derivatives at each cut
        offset += n
    a = got["mag_1_c"].to_numpy()
    b = whole["mag_1_c"].to_numpy()
    assert np.max(np.abs(a[~edges] - b[~edges])) <= 1e-9
    assert np.max(np.abs(a - b)) > 0, "the cuts are real: the check above is not vacuous"


def test_dask_infers_the_output_columns_without_meta(tmp_path):
    survey = tolles.simulate(plan="survey", seed=8, lines=2)
    model = tolles.fit(tolles.simulate(plan="box", seed=9))
    survey.to_parquet(tmp_path / "s.parquet", row_group_size=400)
    parts = dd.read_parquet(tmp_path / "s.parquet").repartition(npartitions=4)
    lazy = parts.map_partitions(tolles.compensate, model, level="model")
    assert list(lazy.columns) == list(survey.columns) + ["mag_1_c"]
    got = lazy.compute()["mag_1_c"].to_numpy()
    assert np.isfinite(got).all()
    whole = tolles.compensate(survey, model, level="model")["mag_1_c"].to_numpy()
    assert np.median(np.abs(got - whole)) <= 1e-9


def test_a_real_two_row_frame_is_compensated_not_taken_for_a_placeholder():
    survey = tolles.simulate(plan="survey", seed=8, lines=2).iloc[:2]
    model = tolles.fit(tolles.simulate(plan="box", seed=9))
    out = tolles.compensate(survey, model)
    assert out["mag_1_c"].notna().all()

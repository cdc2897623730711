"""Shared fixtures: the `tolles` command (to compare with) and flights it simulated."""

import json
import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def _binary() -> Path:
    given = os.environ.get("TOLLES_BIN")
    path = Path(given) if given else REPO / "target" / "release" / "tolles"
    if not path.exists():
        subprocess.run(
            ["cargo", "build", "--release", "--locked", "-p", "tolles-cli"], cwd=REPO, check=True
        )
    return path


@pytest.fixture(scope="session")
def tolles_bin():
    """The path of the `tolles` command the tests compare with (TOLLES_BIN, else release)."""
    return _binary()


@pytest.fixture(scope="session")
def cli():
    """Runs `tolles ARGS…` and returns its standard output; fails on a non-zero exit."""
    binary = _binary()

    def run(*args, check=True):
        done = subprocess.run([str(binary), *map(str, args)], capture_output=True, text=True)
        if check and done.returncode != 0:
            raise AssertionError(f"tolles {' '.join(map(str, args))}: {done.stderr}")
        return done

    return run


@pytest.fixture(scope="session")
def flights(tmp_path_factory, cli):
    """A calibration box and a survey simulated by the CLI (cabin installation), their
    HDF5 and Parquet copies, and a model the CLI fitted on the box."""
    d = tmp_path_factory.mktemp("flights")
    cli("simulate", "--plan", "box", "--seed", "3", "--out", d / "cal.csv")
    cli("simulate", "--plan", "survey", "--seed", "4", "--lines", "3", "--out", d / "survey.csv")
    cli("fit", d / "cal.csv", "--scalar", "mag_1_uc", "--vector", "flux_a", "--out", d / "model.json")
    # The CLI writes any table it reads as HDF5 or Parquet (with the compensated column added).
    cli("compensate", d / "survey.csv", "--model", d / "model.json", "--out", d / "survey.h5")
    cli("compensate", d / "survey.csv", "--model", d / "model.json", "--out", d / "survey.parquet")
    return d


def read_csv_columns(path):
    """A CSV the CLI wrote, as {column: list of float} (empty cells NaN)."""
    import pandas as pd

    return pd.read_csv(path)


def fom_json(cli, *args):
    return json.loads(cli("fom", *args, "--json").stdout)

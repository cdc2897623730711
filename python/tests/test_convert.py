"""`tolles convert` of MATLAB v5 files: every 1-D numeric variable and struct field equals what
scipy's `loadmat` reads, exactly (skipped when scipy is not installed); and `tolles.convert`,
the Python face of the same library function."""

import csv
import math
from pathlib import Path

import numpy as np
import pytest

import tolles

FIXTURES = Path(__file__).resolve().parents[2] / "crates" / "tolles-io" / "tests" / "fixtures"
MAT_FILES = [
    "magnav_test_data_TL.mat",
    "magnav_test_data_params.mat",
    "matlab_v5.mat",
    "matlab_v5_plain.mat",
]


def leaves(prefix, value, out):
    """Every leaf of a `loadmat(..., simplify_cells=True)` value, by its dotted path."""
    if isinstance(value, dict):
        for name, inner in value.items():
            leaves(f"{prefix}.{name}" if prefix else name, inner, out)
    else:
        out[prefix] = value
    return out


def numeric_1d(value):
    """The leaf as a 1-D float64 array when it is a scalar or 1-D numeric array, else None."""
    array = np.asarray(value)
    if array.dtype.kind not in "fiub" or array.ndim > 1 or array.size == 0:
        return None
    return array.astype(np.float64).ravel()


def column_names(paths):
    """The reader's naming: a leaf by its own name where no other leaf has it, else by path."""
    last = [p.rsplit(".", 1)[-1] for p in paths]
    return {
        p: (name if "." not in p or last.count(name) == 1 else p) for p, name in zip(paths, last)
    }


def read_csv_columns(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    return {name: [row[k] for row in body] for k, name in enumerate(header)}


@pytest.mark.parametrize("name", MAT_FILES)
def test_converted_mat_columns_equal_loadmat(name, cli, tmp_path):
    sio = pytest.importorskip("scipy.io")
    source = FIXTURES / name
    out = tmp_path / "out.csv"
    cli("convert", source, out)
    loaded = sio.loadmat(source, simplify_cells=True)
    found = leaves("", {k: v for k, v in loaded.items() if not k.startswith("__")}, {})
    names = column_names(list(found))
    columns = read_csv_columns(out)
    checked = 0
    for path, value in found.items():
        want = numeric_1d(value)
        if want is None:
            continue
        cells = columns[names[path]]
        # The column's own values, then padding (empty cells) to the file's rows.
        assert all(c == "" for c in cells[len(want):]), f"{name}: {path}"
        got = [math.nan if c == "" else float(c) for c in cells[: len(want)]]
        assert len(got) == len(want), f"{name}: {path}"
        for k, (g, w) in enumerate(zip(got, want)):
            assert g == w or (math.isnan(g) and math.isnan(w)), f"{name}: {path}[{k}]: {g} != {w}"
        checked += 1
    assert checked >= 3, f"{name}: only {checked} fields compared"


def test_python_convert_writes_what_the_cli_writes(cli, tmp_path):
    source = FIXTURES / "magnav_test_data_TL.mat"
    cli("convert", source, tmp_path / "cli.csv")
    with pytest.warns(tolles.TollesWarning, match="padded to 1000 rows"):
        done = tolles.convert(source, tmp_path / "py.csv")
    assert done["rows"] == 1000 and done["columns"] == 11
    assert done["padded"] == {"TL_a_1": 18, "mag_1_uc_f_t": 960, "fs": 1}
    assert (tmp_path / "py.csv").read_text() == (tmp_path / "cli.csv").read_text()
    df = tolles.read(tmp_path / "py.csv")
    assert df["mag_1_uc_f_t"].notna().sum() == 960


def test_python_convert_selects_renames_and_refuses_unknown_extensions(tmp_path):
    source = tmp_path / "in.csv"
    source.write_text("tt,line,MAGUC\n0,1,5\n0.1,1,6\n0.2,2,7\n")
    done = tolles.convert(source, tmp_path / "out.parquet", lines=2, renames={"MAGUC": "mag_1_uc"})
    assert done["rows"] == 1
    df = tolles.read(tmp_path / "out.parquet")
    assert list(df.columns) == ["tt", "line", "mag_1_uc"] and df["mag_1_uc"].tolist() == [7.0]
    with pytest.raises(tolles.TollesError, match=r"\.csv, \.h5/\.hdf5 or \.parquet/\.pq"):
        tolles.convert(source, tmp_path / "out.xlsx")
    assert not (tmp_path / "out.xlsx").exists()

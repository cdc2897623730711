"""bench/magnav_protocol (issue 48): MagNav's comparison on line 1006.08, run on small simulated
flights with the SGL file and channel names, so the protocol keeps working without the data."""

import importlib.util
import subprocess
import sys

import pytest
from conftest import REPO

SCRIPT = REPO / "bench" / "magnav_protocol.py"


def protocol(tolles_bin, work, *args):
    return subprocess.run(
        [sys.executable, str(SCRIPT), "--tolles", str(tolles_bin), "--work", str(work), *args],
        capture_output=True,
        text=True,
    )


def test_the_protocol_runs_on_simulated_sgl_flights_and_the_network_beats_linear(
    tolles_bin, tmp_path
):
    done = protocol(tolles_bin, tmp_path, "--selftest")
    assert done.returncode == 0, done.stdout + done.stderr
    assert "selftest passed" in done.stdout
    assert "| learned (`--network" in done.stdout
    assert "134 (Tolles-Lawson alone)" in done.stdout


def test_missing_flight_files_are_a_one_line_error(tolles_bin, tmp_path):
    done = protocol(tolles_bin, tmp_path / "work", tmp_path)
    assert done.returncode != 0
    assert done.stderr.strip().count("\n") == 0, done.stderr
    assert "lacks Flt1003_train.h5" in done.stderr


def test_the_selftest_check_refuses_a_table_without_numbers():
    spec = importlib.util.spec_from_file_location("magnav_protocol", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    table = (
        "| uncompensated mag_4_uc | 5.67 | |\n"
        "| Tolles-Lawson, linear (`fit`) | nan | 134 |\n"
        "| learned (`--network`; network kept) | 0.32 | 39 |"
    )
    with pytest.raises(SystemExit):
        module.check_table(table)
    with pytest.raises(SystemExit):
        module.check_table(table.replace("nan", "0.30"))  # learned no better than linear
    assert module.check_table(table.replace("nan", "3.14"))["learned"] == 0.32

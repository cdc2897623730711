"""The Python API as a new user meets it: DataFrames wherever the CLI takes files, the same
argument names, a model's own scalar, errors that name Python's arguments, a light import."""

import subprocess
import sys

import pytest

import tolles


def test_importing_tolles_leaves_scikit_learn_and_helpers_out():
    code = (
        "import sys, tolles; print('sklearn' in sys.modules, 'pandas' in sys.modules, "
        "sorted(set(dir(tolles)) & {'np', 'pd', 'os', 'json'}))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    # scikit-learn and pandas load when first used (0.4 s of pandas alone; import tolles 0.14 s).
    assert done.stdout.split("\n")[0] == "False False []", done.stdout
    assert tolles.TollesLawson.__name__ == "TollesLawson"  # loaded on first use


def test_fom_takes_the_scalar_of_a_one_fit_model(flights):
    cal = tolles.read(flights / "cal.csv", renames={"mag_1_uc": "mag_4_uc"})
    assert "mag_4_uc" in cal.columns and "mag_1_uc" not in cal.columns
    model = tolles.fit(cal, scalar="mag_4_uc", vector="flux_a", lambda_=0.01)
    fom = tolles.fom(cal, model=model)
    assert fom["compensated"]["fom_nT"] < fom["fom_nT"]


def test_a_report_takes_a_data_frame(flights, tmp_path):
    survey = tolles.read(flights / "survey.csv")
    index = tolles.report(survey, tmp_path / "r", model=flights / "model.json")
    assert index.exists()
    assert "survey" in index.read_text()
    with pytest.raises(tolles.TollesError, match="heading_tolerance"):
        tolles.report(
            survey, tmp_path / "r2", model=flights / "model.json", heading_tolerance=95
        )


def test_convert_and_read_name_the_lines_alike(flights, tmp_path):
    kept = tolles.convert(flights / "survey.csv", tmp_path / "a.csv", line=1001)
    also = tolles.convert(flights / "survey.csv", tmp_path / "b.csv", lines=1001)
    assert kept == also
    assert kept["rows"] == len(tolles.read(flights / "survey.csv", line=1001))
    with pytest.raises(tolles.TollesError):
        tolles.convert(flights / "survey.csv", tmp_path / "c.csv", line=1001, lines=1002)


def test_a_missing_rate_names_the_argument_that_gives_it(flights):
    cal = tolles.read(flights / "cal.csv").drop(columns=["tt"])
    cal.attrs.pop("dt", None)
    with pytest.raises(tolles.TollesError, match="fs="):
        tolles.fit(cal, scalar="mag_1_uc", vector="flux_a")
    assert tolles.fit(cal, scalar="mag_1_uc", vector="flux_a", fs=10.0).columns


@pytest.mark.parametrize("order, trim", [(-1, 20), (2**70, 20), (4, -5), (2.5, 20)])
def test_a_count_out_of_range_names_its_parameter(flights, order, trim):
    cal = tolles.read(flights / "cal.csv")
    name = "order" if (order, trim)[1] == 20 else "trim"
    with pytest.raises(tolles.TollesError, match=f"^{name} must be a whole number"):
        tolles.fit(cal, scalar="mag_1_uc", vector="flux_a", order=order, trim=trim)


def test_duplicate_columns_are_refused_as_the_cli_refuses_them(flights):
    cal = tolles.read(flights / "cal.csv")
    doubled = cal.rename(columns={"truth_earth": "mag_1_uc"})
    with pytest.raises(tolles.TollesError, match="column 'mag_1_uc' appears more than once"):
        tolles.fit(doubled, scalar="mag_1_uc", vector="flux_a")


def test_text_in_a_numeric_column_names_the_column_and_row(flights):
    cal = tolles.read(flights / "cal.csv")
    cal["flux_a_y"] = cal["flux_a_y"].astype(object)
    cal.loc[7, "flux_a_y"] = "n/a"
    with pytest.raises(tolles.TollesError, match=r"row 7, column 'flux_a_y': 'n/a' is not a number"):
        tolles.fit(cal, scalar="mag_1_uc", vector="flux_a")


def test_the_fluxgate_offset_is_taken_out_unless_turned_off():
    # The realistic preset's fluxgate reads thousands of nT of the aircraft.
    cal = tolles.simulate("box", preset="realistic", seed=1)
    survey = tolles.simulate("survey", preset="realistic", seed=2)
    on = tolles.fit(cal, extra="cur_1")
    off = tolles.fit(cal, extra="cur_1", fluxgate_offset=False)
    offset = on.fits[0]["flux_offset_nt"]
    assert max(abs(o) for o in offset) > 1000.0
    assert "flux_offset_nt" not in off.fits[0]

    def error(model):
        out = tolles.compensate(survey, model)
        d = out["mag_1_c"] - survey["truth_earth"]
        return float((d - d.mean()).std())

    print(f"survey error: offset taken out {error(on):.3f} nT, left in {error(off):.3f} nT")
    assert error(on) < error(off)


def test_compensate_says_where_time_steps_back_in_rows_out_of_order(flights):
    """Hostile round 4: rows sorted by something other than time are filtered stretch by
    stretch, and the warning says where, as the CLI does; every row still comes back."""
    survey = tolles.read(flights / "survey.csv")
    shuffled = _pd_concat_halves_swapped(survey)
    with pytest.warns(tolles.TollesWarning, match="time steps back or repeats at 1 place"):
        out = tolles.compensate(shuffled, model=flights / "model.json")
    assert len(out) == len(survey)
    assert list(out.index) == list(shuffled.index)


def _pd_concat_halves_swapped(df):
    import pandas as pd

    half = len(df) // 2
    return pd.concat([df.iloc[half:], df.iloc[:half]])

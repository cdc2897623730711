"""Python and the `tolles` command compute the same things on the same files: read, fit,
compensate, FOM, and models passed both ways."""

import inspect
import json
import re

import numpy as np
import pandas as pd
import pytest

import tolles
from conftest import fom_json, read_csv_columns

TOL = 1e-9  # nT


def max_diff(a, b):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape
    assert np.array_equal(np.isnan(a), np.isnan(b)), "missing values differ"
    ok = ~np.isnan(a)
    return float(np.max(np.abs(a[ok] - b[ok]))) if ok.any() else 0.0


def test_read_gives_the_file_columns_as_numbers(flights):
    df = tolles.read(flights / "cal.csv")
    raw = pd.read_csv(flights / "cal.csv")
    assert list(df.columns) == list(raw.columns)
    for c in raw.columns:
        assert max_diff(df[c], raw[c]) == 0.0, c
    assert df.attrs["source"].endswith("cal.csv")


@pytest.mark.parametrize("ext", ["h5", "parquet"])
def test_every_format_reads_the_same_numbers(flights, ext):
    csv = tolles.read(flights / "survey.csv")
    other = tolles.read(flights / f"survey.{ext}")
    for c in csv.columns:
        assert max_diff(other[c], csv[c]) == 0.0, c


def test_geosoft_xyz_reads_as_the_cli_reads_it(flights, cli, tmp_path):
    raw = pd.read_csv(flights / "cal.csv")
    body = ["/ exported for the test", "/ " + " ".join(c for c in raw.columns if c != "line")]
    for line, rows in raw.groupby("line", sort=False):
        body.append(f"Line {line:g}")
        body += [" ".join(repr(v) for v in row) for row in rows.drop(columns="line").itertuples(index=False)]
    (tmp_path / "cal.xyz").write_text("\n".join(body) + "\n")
    df = tolles.read(tmp_path / "cal.xyz")
    for c in raw.columns:
        assert max_diff(df[c], raw[c]) == 0.0, c
    model = tolles.fit(df, lambda_=0.01)
    cli("fit", tmp_path / "cal.xyz", "--scalar", "mag_1_uc", "--vector", "flux_a", "--lambda", "0.01", "--out", tmp_path / "m.json")
    assert model == tolles.load_model(tmp_path / "m.json")


def test_a_fit_equals_the_cli_fit(flights):
    model = tolles.fit(tolles.read(flights / "cal.csv"), scalar="mag_1_uc", vector="flux_a")
    cli_model = tolles.load_model(flights / "model.json")
    assert model.columns == cli_model.columns
    assert max_diff(model.coefficients, cli_model.coefficients) <= 1e-9 * np.max(np.abs(cli_model.coefficients))
    assert model.diagnostics["samples_used"] == cli_model.diagnostics["samples_used"]


def test_saved_models_are_byte_identical_to_the_cli_s(flights, tmp_path):
    model = tolles.fit(tolles.read(flights / "cal.csv"))
    model.save(tmp_path / "py.json")
    assert (tmp_path / "py.json").read_bytes() == (flights / "model.json").read_bytes()


def test_compensate_equals_the_cli_output(flights, cli, tmp_path):
    survey = tolles.read(flights / "survey.csv")
    ours = tolles.compensate(survey, tolles.load_model(flights / "model.json"))
    cli("compensate", flights / "survey.csv", "--model", flights / "model.json", "--out", tmp_path / "c.csv")
    theirs = read_csv_columns(tmp_path / "c.csv")
    assert list(ours.columns) == list(theirs.columns)
    assert max_diff(ours["mag_1_c"], theirs["mag_1_c"]) <= TOL
    assert survey.shape[1] + 1 == ours.shape[1]
    assert "mag_1_c" not in survey.columns, "the input frame is left alone"


def test_models_pass_from_python_to_the_cli(flights, cli, tmp_path):
    cal = tolles.read(flights / "cal.csv")
    model = tolles.fit(cal, terms="permanent,induced,eddy", lambda_=0.001)
    model.save(tmp_path / "m.json")
    cli("compensate", flights / "survey.csv", "--model", tmp_path / "m.json", "--out", tmp_path / "c.csv")
    theirs = read_csv_columns(tmp_path / "c.csv")["mag_1_c"]
    ours = tolles.compensate(tolles.read(flights / "survey.csv"), model)["mag_1_c"]
    assert max_diff(ours, theirs) <= TOL


def test_models_pass_from_the_cli_to_python_with_their_terms(flights):
    model = tolles.load_model(flights / "model.json")
    data = json.loads((flights / "model.json").read_text())["fits"][0]
    assert model.scalars == ["mag_1_uc"]
    assert model.patent == data["patent"]
    assert set(model.patent) >= {"perm_nT", "induced", "eddy_s"}
    assert model.level_nt == data["level_nt"] and abs(model.fs_hz - 10.0) < 1e-9
    assert len(model.coefficients) == len(model.columns) == 16


def test_the_model_level_does_not_depend_on_the_split(flights, cli, tmp_path):
    survey = tolles.read(flights / "survey.csv")
    model = tolles.load_model(flights / "model.json")
    whole = tolles.compensate(survey, model, level="model")["mag_1_c"].to_numpy()
    half = len(survey) // 2
    first = tolles.compensate(survey.iloc[:half], model, level="model")["mag_1_c"].to_numpy()
    # Away from the cut (the derivative there is one-sided), the halves equal the whole.
    assert max_diff(first[: half - 2], whole[: half - 2]) <= TOL
    cli("compensate", flights / "survey.csv", "--model", flights / "model.json", "--level", "model", "--out", tmp_path / "c.csv")
    assert max_diff(whole, read_csv_columns(tmp_path / "c.csv")["mag_1_c"]) <= TOL


def test_fom_equals_the_cli_json(flights, cli):
    cal = tolles.read(flights / "cal.csv")
    model = tolles.load_model(flights / "model.json")
    assert tolles.fom(cal, scalar="mag_1_uc", model=model) == fom_json(
        cli, flights / "cal.csv", "--scalar", "mag_1_uc", "--model", flights / "model.json"
    )
    assert tolles.fom(cal, "mag_1_uc", band=(0.1, 0.9)) == fom_json(
        cli, flights / "cal.csv", "--scalar", "mag_1_uc", "--band", "0.1,0.9"
    )


def test_fom_heading_settings_match_the_cli_flags(flights, cli):
    cal = tolles.read(flights / "cal.csv")
    ours = tolles.fom(
        cal, "mag_1_uc", headings=[0, 180], heading_tolerance=2, level_tolerance=0.5
    )
    assert [level["heading_deg"] for level in ours["heading_error"]["levels"]] == [0, 180]
    assert ours == fom_json(
        cli, flights / "cal.csv", "--scalar", "mag_1_uc", "--headings", "0,180",
        "--heading-tolerance", "2", "--level-tolerance", "0.5",
    )
    assert ours != tolles.fom(cal, "mag_1_uc", headings="0,180")
    with pytest.raises(tolles.TollesError, match="heading_tolerance"):
        tolles.fom(cal, "mag_1_uc", heading_tolerance=95)
    with pytest.raises(tolles.TollesError, match="cardinal_tolerance"):
        tolles.fom(cal, "mag_1_uc", cardinal_tolerance="wide")


def test_selected_lines_fit_as_the_cli_selects_them(flights, cli, tmp_path):
    survey = tolles.read(flights / "survey.csv", line=[1001, 1002], time=(None, 1e9))
    assert set(survey["line"].unique()) == {1001.0, 1002.0}
    model = tolles.fit(survey, lambda_=0.01)
    cli("fit", flights / "survey.csv", "--scalar", "mag_1_uc", "--vector", "flux_a", "--line", "1001,1002", "--lambda", "0.01", "--out", tmp_path / "m.json")
    theirs = tolles.load_model(tmp_path / "m.json")
    assert max_diff(model.coefficients, theirs.coefficients) <= 1e-9 * np.max(np.abs(theirs.coefficients))


def test_several_scalars_give_one_model_and_a_column_each(flights):
    cal = tolles.read(flights / "cal.csv")
    cal["mag_2_uc"] = cal["mag_1_uc"] + 1.0
    model = tolles.fit(cal, scalar=["mag_1_uc", "mag_2_uc"], vector="flux_a")
    assert model.scalars == ["mag_1_uc", "mag_2_uc"]
    out = tolles.compensate(cal, model)
    assert max_diff(out["mag_2_c"] - 1.0, out["mag_1_c"]) < 1e-6
    with pytest.raises(AttributeError):
        model.coefficients


def test_errors_name_the_column_and_warnings_are_warnings(flights):
    cal = tolles.read(flights / "cal.csv")
    with pytest.raises(tolles.TollesError, match="flux_b_x"):
        tolles.fit(cal, vector="flux_b")
    holed = cal.copy()
    holed.loc[100:104, "flux_a_x"] = np.nan
    with pytest.warns(tolles.TollesWarning, match="5 of"):
        out = tolles.compensate(holed, tolles.load_model(flights / "model.json"))
    assert out["mag_1_c"].isna().sum() == 5
    with pytest.raises(tolles.TollesError, match="no such file|cannot open|No such"):
        tolles.read(flights / "missing.csv")


def test_a_frame_without_time_needs_a_sample_rate(flights):
    cal = tolles.read(flights / "cal.csv").drop(columns=["tt"])
    with pytest.raises(tolles.TollesError, match="sample rate"):
        tolles.fit(cal)
    assert tolles.fit(cal, fs=10.0).fs_hz == 10.0


def test_an_existing_output_column_is_not_overwritten(flights):
    survey = tolles.read(flights / "survey.csv")
    survey["mag_1_c"] = 0.0
    with pytest.warns(tolles.TollesWarning, match="mag_1_c_tolles"):
        out = tolles.compensate(survey, tolles.load_model(flights / "model.json"))
    assert (out["mag_1_c"] == 0.0).all() and out["mag_1_c_tolles"].notna().all()


def test_simulate_equals_the_cli_flight(flights):
    df = tolles.simulate(plan="box", seed=3)
    raw = pd.read_csv(flights / "cal.csv")
    for c in raw.columns:
        assert max_diff(df[c], raw[c]) == 0.0, c
    sidecar = json.loads((flights / "cal.json").read_text())
    assert df.attrs["truth"] == sidecar
    assert df.attrs["truth"]["plan_name"] == "box"


def test_simulate_effects_equal_the_cli_flight(cli, tmp_path):
    cli("simulate", "--plan", "box", "--cycles", "1", "--effects", "load,temp", "--out", tmp_path / "e.csv")
    df = tolles.simulate(plan="box", cycles=1, effects=["temp", "load"])
    raw = pd.read_csv(tmp_path / "e.csv")
    assert list(df.columns) == list(raw.columns)
    assert list(raw.columns[-4:]) == ["mag_ref", "cur_load", "temp", "truth_effects"]
    for c in raw.columns:
        assert max_diff(df[c], raw[c]) == 0.0, c
    assert df.attrs["truth"] == json.loads((tmp_path / "e.json").read_text())
    with pytest.raises(tolles.TollesError, match="load, flap, temp"):
        tolles.simulate(effects="wind")


def test_an_exact_magnitude_model_passes_both_ways_and_compensates_alike(flights, cli, tmp_path):
    cal = tolles.read(flights / "cal.csv")
    model = tolles.fit(cal, magnitude="exact", levels=False)
    assert model.magnitude == "exact"
    assert model.diagnostics["exact_iterations"] >= 1
    cli("fit", flights / "cal.csv", "--scalar", "mag_1_uc", "--vector", "flux_a",
        "--magnitude", "exact", "--levels", "off", "--out", tmp_path / "cli.json")
    model.save(tmp_path / "py.json")
    assert (tmp_path / "py.json").read_bytes() == (tmp_path / "cli.json").read_bytes()
    cli("compensate", flights / "survey.csv", "--model", tmp_path / "py.json", "--out", tmp_path / "c.csv")
    theirs = read_csv_columns(tmp_path / "c.csv")["mag_1_c"]
    ours = tolles.compensate(tolles.read(flights / "survey.csv"), model)["mag_1_c"]
    assert max_diff(ours, theirs) <= TOL
    with pytest.raises(tolles.TollesError, match="magnitude"):
        tolles.fit(cal, magnitude="quadratic")


def test_an_extra_channel_fits_and_compensates_as_the_cli_does(cli, tmp_path):
    cli("simulate", "--preset", "uav", "--out", tmp_path / "box.csv")
    cli("fit", tmp_path / "box.csv", "--scalar", "mag_1_uc", "--vector", "flux_a", "--extra", "cur_1",
        "--out", tmp_path / "cli.json")
    box = tolles.read(tmp_path / "box.csv")
    model = tolles.fit(box, extra="cur_1")
    model.save(tmp_path / "py.json")
    assert (tmp_path / "py.json").read_bytes() == (tmp_path / "cli.json").read_bytes()
    assert model.columns[-3:] == ["cur_1_x", "cur_1_y", "cur_1_z"]
    out = tolles.compensate(box, model)
    error = out["mag_1_c"] - box["truth_earth"]
    assert float(np.std(error)) < 0.05


def test_a_reference_fit_and_a_lag_match_the_cli(cli, tmp_path):
    cli("simulate", "--preset", "cabin", "--flux-lag", "0.05", "--out", tmp_path / "box.csv")
    cli("fit", tmp_path / "box.csv", "--scalar", "mag_1_uc", "--vector", "flux_a",
        "--reference", "truth_earth", "--lag", "0.05", "--out", tmp_path / "cli.json")
    box = tolles.read(tmp_path / "box.csv")
    model = tolles.fit(box, reference="truth_earth", lag=0.05)
    model.save(tmp_path / "py.json")
    assert (tmp_path / "py.json").read_bytes() == (tmp_path / "cli.json").read_bytes()
    fitted = model.fits[0]
    assert fitted["reference"] == "truth_earth"
    assert fitted["settings"]["target"] == "interference"
    assert fitted["lag_s"] == pytest.approx(0.05)
    with pytest.raises(tolles.TollesError, match="also a scalar"):
        tolles.fit(box, reference="mag_1_uc")
    with pytest.raises(tolles.TollesError, match="lag"):
        tolles.fit(box, lag="soon")


def test_an_extra_channel_with_options_fits_and_compensates_as_the_cli_does(cli, tmp_path):
    cli("simulate", "--preset", "uav", "--out", tmp_path / "box.csv")
    spec = "cur_1:lowpass=2:lag=0.1"
    cli("fit", tmp_path / "box.csv", "--scalar", "mag_1_uc", "--vector", "flux_a", "--extra", spec,
        "--lambda", "0.001", "--out", tmp_path / "cli.json")
    box = tolles.read(tmp_path / "box.csv")
    model = tolles.fit(box, extra=[spec], lambda_=0.001)
    model.save(tmp_path / "py.json")
    assert (tmp_path / "py.json").read_bytes() == (tmp_path / "cli.json").read_bytes()
    cli("compensate", tmp_path / "box.csv", "--model", tmp_path / "py.json", "--out", tmp_path / "c.csv")
    theirs = read_csv_columns(tmp_path / "c.csv")["mag_1_c"]
    ours = tolles.compensate(box, model)["mag_1_c"]
    assert max_diff(ours, theirs) <= TOL
    with pytest.raises(tolles.TollesError, match="lowpass"):
        tolles.fit(box, extra="cur_1:lowpass=0")


def test_uncertainty_columns_and_the_verdict_match_the_cli(flights, cli, tmp_path):
    model = tolles.load_model(flights / "model.json")
    stored = json.loads((flights / "model.json").read_text())["fits"][0]["verdict"]
    assert model.verdict["grade"] == stored["grade"] in ("good", "doubtful")
    survey = tolles.read(flights / "survey.csv")
    ours = tolles.compensate(survey, model, uncertainty=True)
    cli("compensate", flights / "survey.csv", "--model", flights / "model.json", "--uncertainty", "--out", tmp_path / "c.csv")
    theirs = read_csv_columns(tmp_path / "c.csv")
    assert list(ours.columns) == list(theirs.columns)
    for c in ("mag_1_c", "mag_1_c_sigma", "mag_1_c_extrapolated"):
        assert max_diff(ours[c], theirs[c]) <= TOL, c
    sigma = ours["mag_1_c_sigma"].to_numpy()
    assert np.all(sigma[np.isfinite(sigma)] >= 0.0) and np.nanmax(sigma) > 0.0
    assert set(np.unique(ours["mag_1_c_extrapolated"].dropna())) <= {0.0, 1.0}
    fom = tolles.fom(tolles.read(flights / "cal.csv"), scalar="mag_1_uc", model=model)
    assert fom["verdict"]["grade"] == stored["grade"]


def test_a_network_fits_and_compensates_as_the_cli_does(cli, tmp_path):
    """``fit(..., network=True)`` writes the CLI's model bytes; both directions of the model
    file compensate alike; ``Model.network`` exposes what was kept."""
    cli("simulate", "--plan", "box", "--preset", "tail-stinger", "--seed", "3", "--out", tmp_path / "raw.csv")
    box = pd.read_csv(tmp_path / "raw.csv")
    cos_x = box["flux_a_x"] / np.sqrt(box["flux_a_x"] ** 2 + box["flux_a_y"] ** 2 + box["flux_a_z"] ** 2)
    box["mag_1_uc"] = box["mag_1_uc"] + 3.0 * np.tanh(4.0 * cos_x)
    box["mag_ref"] = box["truth_earth"] + box["truth_anomaly"] + box["truth_diurnal"]
    box.to_csv(tmp_path / "box.csv", index=False, float_format="%.17g")
    cli("fit", tmp_path / "box.csv", "--scalar", "mag_1_uc", "--vector", "flux_a", "--reference", "mag_ref",
        "--network", "--inputs", "ins_roll", "--network-seed", "5", "--out", tmp_path / "cli.json")
    box = tolles.read(tmp_path / "box.csv")
    model = tolles.fit(box, reference="mag_ref", network=True, inputs="ins_roll", network_seed=5)
    model.save(tmp_path / "py.json")
    assert (tmp_path / "py.json").read_bytes() == (tmp_path / "cli.json").read_bytes()
    kept = model.network
    assert kept is not None and kept["channels"] == ["ins_roll"]
    assert kept["judged_network_rms_nt"] < 0.95 * kept["judged_linear_rms_nt"]
    cli("compensate", tmp_path / "box.csv", "--model", tmp_path / "py.json", "--out", tmp_path / "out.csv")
    by_cli = read_csv_columns(tmp_path / "out.csv")["mag_1_c"]
    by_python = tolles.compensate(box, tolles.load_model(tmp_path / "cli.json"))["mag_1_c"]
    assert max_diff(by_python.to_numpy(), np.array(by_cli)) < 1e-9
    with pytest.raises(tolles.TollesError, match="network layers"):
        tolles.fit(box, reference="mag_ref", network=True, network_layers=(300,))


def test_several_flights_fit_as_the_cli_fits_several_files(cli, tmp_path):
    for seed in ("1", "2"):
        cli("simulate", "--plan", "box", "--seed", seed, "--effects", "load", "--out", tmp_path / f"b{seed}.csv")
    paths = [tmp_path / "b1.csv", tmp_path / "b2.csv"]
    cli("fit", *paths, "--scalar", "mag_1_uc", "--vector", "flux_a", "--reference", "mag_ref",
        "--extra", "cur_load", "--network", "--network-held-out", "lines", "--out", tmp_path / "cli.json")
    model = tolles.fit([tolles.read(p) for p in paths], reference="mag_ref", extra="cur_load",
                       network=True, network_held_out="lines")
    model.save(tmp_path / "py.json")
    assert (tmp_path / "py.json").read_bytes() == (tmp_path / "cli.json").read_bytes()
    assert model.fits[0]["calibration_flight"] == f"{paths[0]} + {paths[1]}"
    assert model.network is not None and model.network["held_out"] == "lines"
    with pytest.raises(tolles.TollesError, match="at least one"):
        tolles.fit([])


# Every request option of the command line has its Python keyword and the same default, and
# the other way round: a flag added to one and not the other fails here. What only one of them
# has is listed with the reason.
CLI_ONLY = {
    "help": "clap's",
    "out": "Python returns the value (report: its out is a keyword)",
    "json": "Python returns a dict",
    "line": "Python selects rows when it reads (tolles.read(line=…))",
    "time": "Python selects rows when it reads (tolles.read(time=…))",
    "rename": "Python renames when it reads (tolles.read(renames=…))",
}
# The commands whose Python function reads a file itself (and so takes line, time, renames).
READS_ITSELF = {"report"}
# (command, flag) → Python keyword, where the names differ.
PYTHON_NAME = {
    ("fit", "lambda"): "lambda_",
    ("plan", "inclination"): "dip",
    ("plan", "plan"): "maneuvers",
    ("procedure", "inclination"): "dip",
    ("report", "rename"): "renames",
}
# Keywords that are the data itself, not an option.
DATA = {"df", "flight", "path", "input", "output"}


def _cli_options(cli, command):
    text = cli(command, "--help").stdout
    options = {}
    for flag, rest in re.findall(r"^\s+(?:-\w, )?--([a-z0-9-]+)(.*(?:\n(?!\s+-).*)*)", text, re.M):
        default = re.search(r"\[default: ([^\]]*)\]", rest)
        options[flag] = default.group(1) if default else None
    return options


def _same_default(cli_default, python_default):
    if cli_default is None or python_default is None or python_default is inspect.Parameter.empty:
        return True  # one of them leaves it to the library's own default
    if isinstance(python_default, tuple):
        return tuple(float(v) for v in cli_default.split(",")) == tuple(map(float, python_default))
    if isinstance(python_default, bool):
        return cli_default in ("true", "false") and (cli_default == "true") == python_default
    if isinstance(python_default, (int, float)):
        return float(cli_default) == float(python_default)
    return str(cli_default) == str(python_default)


@pytest.mark.parametrize("command", ["fit", "compensate", "fom", "report", "plan", "procedure"])
def test_every_cli_option_is_a_python_keyword_with_its_default(cli, command):
    options = _cli_options(cli, command)
    parameters = inspect.signature(getattr(tolles, command)).parameters
    reads = command in READS_ITSELF
    missing, differing = [], []
    expected = set()
    for flag, default in options.items():
        name = PYTHON_NAME.get((command, flag), flag.replace("-", "_"))
        if flag in CLI_ONLY and not (reads and flag in ("line", "time", "rename", "out")):
            continue
        if flag == "maneuvers" and command == "plan":
            name = "maneuvers"
        expected.add(name)
        if name not in parameters:
            missing.append(f"--{flag} (as {name})")
        elif not _same_default(default, parameters[name].default):
            differing.append(f"--{flag}: {default} against {name}={parameters[name].default!r}")
    extra = [p for p in parameters if p not in expected and p not in DATA and not (reads and p == "out")]
    assert not missing, f"tolles {command}: no Python keyword for {missing}"
    assert not differing, f"tolles {command}: defaults differ: {differing}"
    assert not extra, f"tolles.{command}: keywords the command line has no flag for: {extra}"

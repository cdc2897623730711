"""tolles.report: the HTML report of a flight file, the same page `tolles report` writes."""

import warnings

import pytest

import tolles


@pytest.fixture(scope="module")
def box(tmp_path_factory, cli):
    """A simulated box and a model the CLI fitted on it."""
    dir = tmp_path_factory.mktemp("report")
    flight = dir / "box.csv"
    model = dir / "m.json"
    cli("simulate", "--out", flight)
    cli("fit", flight, "--scalar", "mag_1_uc", "--vector", "flux_a", "--out", model)
    return flight, model


def test_report_writes_the_page_the_cli_writes(box, cli, tmp_path, monkeypatch):
    flight, model = box
    # Both pages say when they were written: the same time, as reproducible builds fix it.
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1795862700")
    index = tolles.report(flight, tmp_path / "py", model=model, scalar="mag_1_uc", time="..600")
    assert index == tmp_path / "py" / "index.html"
    page = index.read_bytes()
    assert b"Scalar mag_1_uc at" in page
    cli("report", flight, "--model", model, "--scalar", "mag_1_uc", "--time", "..600",
        "--out", tmp_path / "cli")
    assert page == (tmp_path / "cli" / "index.html").read_bytes()
    plots = sorted(p.name for p in (tmp_path / "py" / "plots").iterdir())
    assert plots == sorted(p.name for p in (tmp_path / "cli" / "plots").iterdir())


def test_a_model_object_and_no_scalar_take_the_fit(box, tmp_path):
    flight, model = box
    index = tolles.report(flight, tmp_path, model=tolles.load_model(model))
    assert "Scalar mag_1_uc at" in index.read_text()


def test_warnings_are_tolles_warnings(box, tmp_path):
    flight, _ = box
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        tolles.report(flight, tmp_path, scalar=["mag_1_uc"], fs=5.0)
    assert caught and all(issubclass(w.category, tolles.TollesWarning) for w in caught)


def test_an_unknown_scalar_is_a_tolles_error(box, tmp_path):
    flight, _ = box
    with pytest.raises(tolles.TollesError, match="mag_9_uc"):
        tolles.report(flight, tmp_path, scalar="mag_1_uc,mag_9_uc")


def test_a_reference_column_is_judged_against_as_the_cli_does(box, cli, tmp_path, monkeypatch):
    flight, model = box
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1795862700")
    # The truth itself as a reference column: the page names it where it said "truth".
    index = tolles.report(flight, tmp_path / "py", model=model, reference="truth_earth")
    page = index.read_text()
    assert "error vs truth_earth after" in page and "error vs truth after" not in page
    cli("report", flight, "--model", model, "--reference", "truth_earth", "--out", tmp_path / "cli")
    assert index.read_bytes() == (tmp_path / "cli" / "index.html").read_bytes()
    with pytest.raises(tolles.TollesError, match="mag_1_c"):
        tolles.report(flight, tmp_path / "none", model=model, reference="mag_1_c")

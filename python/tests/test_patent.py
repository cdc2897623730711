"""The patent's procedure and the plan analysis from Python equal `tolles procedure --json`
and `tolles plan --json`."""

import json

import pytest

import tolles


@pytest.fixture(scope="module")
def patent_flight(tmp_path_factory, cli):
    d = tmp_path_factory.mktemp("patent")
    cli("simulate", "--plan", "patent", "--seed", "2", "--out", d / "patent.csv")
    return d / "patent.csv"


def test_procedure_with_a_fluxgate_equals_the_cli(patent_flight, cli):
    ours = tolles.procedure(tolles.read(patent_flight), "mag_1_uc", "flux_a")
    theirs = json.loads(cli("procedure", patent_flight, "--scalar", "mag_1_uc", "--vector", "flux_a", "--json").stdout)
    assert ours == theirs


def test_procedure_from_the_attitude_and_a_dip_equals_the_cli(patent_flight, cli):
    flight = tolles.read(patent_flight)
    ours = tolles.procedure(flight, "mag_1_uc", vector=None, dip=68.0, ignore="roll on 045")
    theirs = json.loads(
        cli("procedure", patent_flight, "--scalar", "mag_1_uc", "--dip", "68", "--ignore", "roll on 045", "--json").stdout
    )
    assert ours == theirs
    with pytest.raises(tolles.TollesError, match="no maneuver"):
        tolles.procedure(flight, "mag_1_uc", ignore="roll on 123")


@pytest.mark.parametrize(
    "kwargs, flags",
    [
        ({}, []),
        ({"without": "yaw"}, ["--without", "yaw"]),
        ({"maneuvers": "roll@0,roll@90,pitch@0,wingup@90", "dip": 60.0}, ["--maneuvers", "roll@0,roll@90,pitch@0,wingup@90", "--inclination", "60"]),
    ],
)
def test_plans_equal_the_cli(cli, kwargs, flags):
    assert tolles.plan(**kwargs) == json.loads(cli("plan", *flags, "--json").stdout)


def test_a_flown_flight_s_plan_equals_the_cli(patent_flight, cli):
    ours = tolles.plan(flight=patent_flight, vector="flux_a")
    theirs = json.loads(cli("plan", patent_flight, "--vector", "flux_a", "--json").stdout)
    assert ours == theirs

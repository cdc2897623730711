"""``tolles.network``: the stored network evaluated in NumPy alone gives what Rust gives."""

import copy
import doctest
import json
import warnings

import numpy as np
import pytest

import tolles
import tolles.network

# The fits' verdicts ("doubtful": an induced term) and the missing cells are warned about.
pytestmark = pytest.mark.filterwarnings("ignore::tolles.TollesWarning")

FITS = [("swish", None), ("tanh", "ins_roll"), ("relu", "ins_pitch,ins_roll")]


@pytest.fixture(scope="module")
def box():
    """A cabin box with effects no linear term holds, and a few missing cells."""
    box = tolles.simulate(plan="box", preset="cabin", seed=1, effects="all")
    box.loc[100:105, "temp"] = np.nan
    box.loc[300, "flux_a_x"] = np.nan
    return box


@pytest.fixture(scope="module")
def fitted(box):
    """The model of ``box`` with a network of this activation and these ``--inputs``, fitted
    once (as ``tolles fit --reference mag_ref --extra cur_load,pos_flap,temp --network``)."""
    models = {}

    def fit(activation, inputs):
        if (activation, inputs) not in models:
            models[activation, inputs] = tolles.fit(
                box, scalar="mag_1_uc", vector="flux_a", reference="mag_ref",
                extra="cur_load,pos_flap,temp", network=True, inputs=inputs,
                network_activation=activation)
        model = models[activation, inputs]
        assert model.network is not None, "the network was not kept: nothing to compare"
        return model

    return fit


def with_fit(model, change):
    data = json.loads(model.to_json())
    change(data["fits"][0])
    return tolles.Model(json.dumps(data))


def rust_network_nt(box, model):
    """Rust's network output (nT) per row: the model compensated without its network, less
    with it, both at the model's level (so the network's mean share stays in the level)."""
    linear = with_fit(model, lambda fit: fit.pop("network"))
    full = tolles.compensate(box, model, level="model")["mag_1_c"].to_numpy()
    alone = tolles.compensate(box, linear, level="model")["mag_1_c"].to_numpy()
    return alone - full


@pytest.mark.parametrize("activation,inputs", FITS)
def test_numpy_gives_rusts_network_output_on_every_row(box, fitted, activation, inputs):
    model = fitted(activation, inputs)
    rust = rust_network_nt(box, model)
    ours = tolles.network.evaluate(model.network, tolles.network.features(model, box))
    assert np.array_equal(np.isnan(ours), np.isnan(rust))
    assert np.isnan(ours).sum() == 7  # six rows without temp, one without flux_a_x
    assert np.nanstd(ours) > 0.5  # a network that does something (nT)
    assert np.nanmax(np.abs(ours - rust)) <= 1e-9
    assert np.array_equal(tolles.network.correction(model.fits[0], box), ours, equal_nan=True)
    inner = tolles.network.evaluate(model.network["network"], tolles.network.features(model, box))
    assert np.array_equal(inner, ours, equal_nan=True)


def test_a_damaged_weight_changes_both_evaluations_alike(box, fitted):
    model = fitted(*FITS[0])

    def damage(fit):
        fit["network"]["network"]["layers"][0]["weights"][3] += 0.5

    damaged = with_fit(model, damage)
    before = tolles.network.correction(model, box)
    after = tolles.network.correction(damaged, box)
    assert np.nanmax(np.abs(after - before)) > 0.01
    assert np.nanmax(np.abs(after - rust_network_nt(box, damaged))) <= 1e-9


def test_inputs_beyond_the_training_range_are_held_at_its_end_alike(box, fitted):
    model = fitted(*FITS[0])
    top = model.network["network"]["input_range"][-1][1]  # temp, the last input (°C)
    hot, at_top = box.copy(), box.copy()
    hot["temp"] = box["temp"] + 100.0
    at_top["temp"] = np.where(box["temp"].isna(), np.nan, top)
    ours = tolles.network.correction(model, hot)
    assert np.nanmax(np.abs(ours - rust_network_nt(hot, model))) <= 1e-9
    assert np.allclose(ours, tolles.network.correction(model, at_top), equal_nan=True)
    assert not np.allclose(ours, tolles.network.correction(model, box), equal_nan=True)


def test_a_network_of_one_unit_evaluates_as_written_out_by_hand():
    swish = lambda v: v / (1.0 + np.exp(-v))  # noqa: E731
    network = {
        "inputs": ["a", "b"],
        "input_mean": [1.0, 0.0],
        "input_scale": [2.0, 1.0],
        "output_mean_nt": 0.5,
        "output_scale_nt": 3.0,
        "activation": "swish",
        "layers": [
            {"inputs": 2, "outputs": 2, "weights": [1.0, -1.0, 0.5, 0.25], "bias": [0.0, 0.1]},
            {"inputs": 2, "outputs": 1, "weights": [2.0, -1.0], "bias": [0.3]},
        ],
    }
    a, b = (3.0 - 1.0) / 2.0, 4.0
    h = [swish(a - b), swish(0.5 * a + 0.25 * b + 0.1)]
    expected = 0.5 + 3.0 * (2.0 * h[0] - h[1] + 0.3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # neither the inf row nor swish's overflow warns
        got = tolles.network.evaluate(network, [[3.0, 4.0], [np.inf, 1.0], [-1e6, 0.0]])
    assert abs(got[0] - expected) < 1e-12
    assert np.isnan(got[1]) and np.isfinite(got[2])
    with pytest.raises(ValueError, match="rows × 2 inputs"):
        tolles.network.evaluate(network, [1.0, 2.0])
    broken = copy.deepcopy(network)
    broken["layers"][1]["inputs"] = 3
    with pytest.raises(ValueError, match="layer 1"):
        tolles.network.evaluate(broken, [[3.0, 4.0]])


@pytest.mark.parametrize(
    "change,said",
    [
        (lambda fit: fit.__setitem__("lag_s", 0.2), "0.2 s late"),
        (lambda fit: fit["settings"]["design"]["extras"].__setitem__(
            0, {"name": "cur_load", "lowpass_hz": 0.5}), "cur_load:lowpass=0.5;"),
        (lambda fit: fit["settings"]["design"]["extras"].__setitem__(
            1, {"name": "pos_flap", "lag_s": 0.3}), "pos_flap:lag=0.3;"),
        (lambda fit: fit.pop("network"), "no network"),
        (lambda fit: fit["network"]["network"]["inputs"].__setitem__(4, "cur_loud"), "cur_loud"),
    ],
)
def test_inputs_it_cannot_build_as_compensate_would_are_refused(box, fitted, change, said):
    fit = copy.deepcopy(fitted(*FITS[0]).fits[0])
    change(fit)
    with pytest.raises(ValueError, match=said):
        tolles.network.features(fit, box)


def test_a_missing_column_is_named(box, fitted):
    model = fitted(*FITS[1])
    with pytest.raises(ValueError, match="ins_roll"):
        tolles.network.features(model, box.drop(columns="ins_roll"))


def test_the_modules_example_runs():
    result = doctest.testmod(tolles.network)
    assert result.attempted > 0 and result.failed == 0

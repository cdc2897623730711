"""The learned correction of ``fit(..., network=True)`` evaluated in NumPy alone.

A model file stores its network as plain numbers (see ``tolles_core::model::network``): the
input names, each input's mean and scale, the layers' weights (row-major, one row per unit) and
biases, the hidden layers' activation and the output's mean and scale (nT). This module is a
reference for reading them elsewhere, and agrees with the Rust evaluation to rounding (within
1e-9 nT, tested):

1. each input ``x`` is held within its training range ``input_range`` (``[lowest, highest]``,
   when the file has it) and becomes ``(x − input_mean) / input_scale``;
2. each hidden layer computes ``act(W·h + b)`` with ``act`` swish (``x·σ(x)``), tanh or relu;
3. the last layer is linear with one unit ``y``; the correction is
   ``output_mean_nt + output_scale_nt · y`` (nT);
4. a row with any input NaN or infinite gives NaN.

>>> import numpy as np, tolles, tolles.network
>>> box = tolles.simulate(plan="box", preset="cabin", seed=1, effects="all")
>>> model = tolles.fit(box, scalar="mag_1_uc", vector="flux_a", reference="mag_ref",
...                    extra="cur_load,pos_flap,temp", network=True)
>>> x = tolles.network.features(model, box)        # rows × inputs, in the network's order
>>> model.network["network"]["inputs"][3], x.shape[1]
('flux_a:magnitude', 7)
>>> nt = tolles.network.evaluate(model.network, x)  # the network's correction (nT) per row
>>> bool(np.isfinite(nt).all())
True

``compensate`` subtracts ``linear + network − level`` from the scalar; the model's ``level_nt``
already holds the network's mean share over the calibration flight.
"""

from __future__ import annotations

from typing import Any, List, Mapping, Tuple

import numpy as np

__all__ = ["correction", "evaluate", "features"]

# The fluxgate's inputs, as ``tolles_core::model::network::feature_names`` names them.
_PARTS = ("cos_x", "cos_y", "cos_z", "magnitude")

_ACTIVATIONS = {
    "swish": lambda v: v / (1.0 + np.exp(-v)),
    "tanh": np.tanh,
    "relu": lambda v: np.maximum(v, 0.0),
}


def evaluate(network: Mapping[str, Any], x: Any) -> np.ndarray:
    """The network's correction (nT) for each row of ``x``, as Rust's ``Network::evaluate``.

    Parameters
    ----------
    network : dict
        One fit's ``network`` as the model file holds it (``Model.network``, or
        ``fit["network"]`` of ``Model.fits``), its inner ``network`` dict of weights, or the
        fit itself.
    x : array_like, rows × inputs
        Inputs in the order of ``network["inputs"]``, each in its own unit (direction cosines
        dimensionless, the fluxgate's magnitude in nT, currents in A, …); see :func:`features`.

    Returns
    -------
    numpy.ndarray
        One float64 per row (nT); NaN where any input of the row is NaN or infinite.

    Raises
    ------
    ValueError
        When ``x`` is not 2-D with one column per input, or the network's numbers do not fit
        together (the checks a model file passes on loading).
    """
    weights = _weights(network)
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != len(weights["inputs"]):
        raise ValueError(
            f"network: expected rows × {len(weights['inputs'])} inputs "
            f"({', '.join(weights['inputs'])}), got an array of shape {x.shape}"
        )
    mean, scale, out_mean, out_scale = _normalisation(weights)
    usable = np.isfinite(x).all(axis=1)
    # Unusable rows are zeroed so that their NaN and inf raise no floating-point warnings.
    held = _within_range(np.where(usable[:, None], x, 0.0), weights)
    normalised = (held - mean) / scale
    out = out_mean + out_scale * _forward(normalised, _layers(weights), _activation(weights))
    out[~usable] = np.nan
    return out


def features(fit: Any, columns: Any) -> np.ndarray:
    """The network's inputs (rows × inputs) from a flight's raw columns, as ``compensate``
    builds them, for a fit whose inputs need no conditioning.

    The columns are, in order: the first fluxgate's direction cosines ``B̂x, B̂y, B̂z``
    (dimensionless) and magnitude ``|B|`` (nT), each extra channel of the fit (its unit), then
    the network's own ``channels`` (``fit --inputs``; their units).

    Parameters
    ----------
    fit : Model or dict
        A one-fit :class:`tolles.Model`, or one fit of ``Model.fits`` (a dict).
    columns : pandas.DataFrame or mapping of name → 1-D array
        The flight's columns by name: the fluxgate's three components (nT; ``flux_a`` reads
        ``flux_a_x``, ``flux_a_y``, ``flux_a_z``, and ``BX:BY:BZ`` those three), the extra
        channels and the network's channels, all equally long.

    Raises
    ------
    ValueError
        When the fit holds no network; when its fluxgate is read late (``lag_s``, from
        ``fit --lag``) or an extra channel is low-passed or lagged (``cur_load:lowpass=…``),
        conditioning this reference does not reproduce (``compensate`` does); when the
        network's inputs are not those of the fit; when a column is missing.
    """
    fit = _one_fit(fit)
    learned = _learned(fit)
    _refuse_conditioning(fit)
    vector = fit["vectors"][0]
    names = [_extra_name(e) for e in _extras(fit)] + list(learned["channels"])
    _check_inputs(fit, [f"{vector}:{part}" for part in _PARTS] + names)
    bx, by, bz = (_column(columns, name) for name in _vector_columns(vector))
    magnitude = _norm(bx, by, bz)
    with np.errstate(invalid="ignore", divide="ignore"):
        cosines = [bx / magnitude, by / magnitude, bz / magnitude]
    others = [_column(columns, name) for name in names]
    return np.column_stack(cosines + [magnitude] + others)


def correction(fit: Any, columns: Any) -> np.ndarray:
    """The network's correction (nT) of each row of a flight: :func:`evaluate` of
    :func:`features`, with the same arguments and errors as :func:`features`."""
    fit = _one_fit(fit)
    return evaluate(_learned(fit), features(fit, columns))


def _one_fit(fit: Any) -> Mapping[str, Any]:
    """A fit's dict from a fit or a one-fit Model."""
    fits = getattr(fit, "fits", None)
    if fits is None:
        return fit
    if len(fits) != 1:
        scalars = ", ".join(f["scalar"] for f in fits)
        raise ValueError(f"the model holds fits of {scalars}: pass model.fit_for(scalar)")
    return fits[0]


def _learned(fit: Mapping[str, Any]) -> Mapping[str, Any]:
    learned = fit.get("network")
    if learned is None:
        raise ValueError(f"the fit of {fit.get('scalar')} holds no network (fit --network)")
    return learned


def _weights(network: Mapping[str, Any]) -> Mapping[str, Any]:
    """The dict of weights, whether given it, the model file's wrapper around it or a fit."""
    while "layers" not in network and isinstance(network.get("network"), Mapping):
        network = network["network"]
    return network


def _normalisation(weights: Mapping[str, Any]) -> Tuple[np.ndarray, np.ndarray, float, float]:
    """Each input's mean and scale, and the output's mean and scale (nT), checked."""
    n = len(weights["inputs"])
    mean = np.asarray(weights["input_mean"], dtype=np.float64)
    scale = np.asarray(weights["input_scale"], dtype=np.float64)
    if mean.shape != (n,) or scale.shape != (n,):
        raise ValueError(f"network: {n} inputs but {mean.size} means and {scale.size} scales")
    if not (np.isfinite(mean).all() and np.isfinite(scale).all() and (scale > 0).all()):
        raise ValueError("network: an input has no finite mean and positive scale")
    out_mean, out_scale = float(weights["output_mean_nt"]), float(weights["output_scale_nt"])
    if not (np.isfinite(out_mean) and np.isfinite(out_scale) and out_scale > 0):
        raise ValueError("network: the output has no finite mean and positive scale")
    return mean, scale, out_mean, out_scale


def _within_range(x: np.ndarray, weights: Mapping[str, Any]) -> np.ndarray:
    """``x`` with each input held within its training range, when the network has ranges."""
    ranges = weights.get("input_range")
    if not ranges:
        return x
    ranges = np.asarray(ranges, dtype=np.float64)
    n = len(weights["inputs"])
    ordered = np.isfinite(ranges).all() and (ranges[:, 0] <= ranges[:, 1]).all()
    if ranges.shape != (n, 2) or not ordered:
        raise ValueError(
            f"network: {n} inputs but {len(ranges)} ranges, or a range that is not two finite "
            "numbers in order"
        )
    return np.clip(x, ranges[:, 0], ranges[:, 1])


def _forward(h: np.ndarray, layers: list, activation) -> np.ndarray:
    """The last layer's one output per row of normalised inputs ``h``."""
    with np.errstate(over="ignore"):  # swish of a very negative value: x / inf = −0
        for k, (w, b) in enumerate(layers):
            h = h @ w.T + b
            if k < len(layers) - 1:
                h = activation(h)
    return h[:, 0]


def _layers(weights: Mapping[str, Any]) -> List[Tuple[np.ndarray, np.ndarray]]:
    """Each layer's ``outputs × inputs`` weights and its biases, checked to chain."""
    width = len(weights["inputs"])
    layers = []
    for k, layer in enumerate(weights["layers"]):
        rows, cols = int(layer["outputs"]), int(layer["inputs"])
        w = np.asarray(layer["weights"], dtype=np.float64)
        b = np.asarray(layer["bias"], dtype=np.float64)
        if cols != width or w.size != rows * cols or b.shape != (rows,):
            raise ValueError(
                f"network: layer {k} is {rows}×{cols} with {w.size} weights and {b.size} biases "
                f"after a layer giving {width}"
            )
        if not (np.isfinite(w).all() and np.isfinite(b).all()):
            raise ValueError(f"network: layer {k} holds a weight that is not a finite number")
        layers.append((w.reshape(rows, cols), b))
        width = rows
    if not layers or width != 1:
        raise ValueError(f"network: the last layer gives {width} outputs, not 1")
    return layers


def _activation(weights: Mapping[str, Any]):
    name = str(weights.get("activation", "swish"))
    if name not in _ACTIVATIONS:
        raise ValueError(f"network: unknown activation {name!r} (swish, tanh or relu)")
    return _ACTIVATIONS[name]


def _extras(fit: Mapping[str, Any]) -> list:
    return fit["settings"]["design"].get("extras", [])


def _extra_name(extra: Any) -> str:
    """A stored extra channel's column: a plain name, or an object with its conditioning."""
    return extra if isinstance(extra, str) else extra["name"]


def _refuse_conditioning(fit: Mapping[str, Any]) -> None:
    """A ValueError for inputs ``compensate`` shifts or filters before the network sees them."""
    scalar = fit.get("scalar")
    lag_s = float(fit.get("lag_s", 0.0))
    if lag_s != 0.0:
        raise ValueError(
            f"the fit of {scalar} reads its fluxgate {lag_s} s late (lag_s); tolles.network "
            "does not reproduce that shift: use tolles.compensate, or fit without --lag"
        )
    for extra in _extras(fit):
        if isinstance(extra, str):
            continue
        spec = _extra_spec(extra)
        if spec != extra["name"]:
            raise ValueError(
                f"the fit of {scalar} conditions extra channel {spec}; tolles.network does not "
                "reproduce its low-pass or lag: use tolles.compensate, or fit with the channel plain"
            )


def _extra_spec(extra: Mapping[str, Any]) -> str:
    """A stored extra channel as ``--extra`` writes it: ``cur_load:lowpass=0.5:lag=0.2``."""
    spec = extra["name"]
    if extra.get("lowpass_hz") is not None:
        spec += f":lowpass={extra['lowpass_hz']}"
    if float(extra.get("lag_s", 0.0)) != 0.0:
        spec += f":lag={extra['lag_s']}"
    return spec


def _check_inputs(fit: Mapping[str, Any], expected: List[str]) -> None:
    """A ValueError unless the network reads the fit's fluxgate, extras and channels in order
    (as a model file must on loading)."""
    inputs = list(_weights(_learned(fit))["inputs"])
    if inputs != expected:
        raise ValueError(
            f"the fit of {fit.get('scalar')}: network inputs {inputs} are not those of its "
            f"fluxgate, extra channels and channels {expected}"
        )


def _vector_columns(spec: str) -> List[str]:
    """``flux_a`` → ``flux_a_x``, ``flux_a_y``, ``flux_a_z``; ``BX:BY:BZ`` → those three."""
    parts = [p.strip() for p in spec.split(":")]
    if len(parts) == 3 and all(parts):
        return parts
    return [f"{spec}{axis}" for axis in ("_x", "_y", "_z")]


def _column(columns: Any, name: str) -> np.ndarray:
    try:
        values = columns[name]
    except KeyError:
        raise ValueError(f"the network needs column {name!r}, which the flight lacks") from None
    if hasattr(values, "to_numpy"):
        return values.to_numpy(dtype=np.float64, na_value=np.nan)
    return np.asarray(values, dtype=np.float64)


def _norm(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """``|B|`` (nT) as Rust's ``norm3``: the plain sum of squares, rescaled by the largest
    component only where the squares would overflow or underflow."""
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        squares = x * x + y * y + z * z
        norm = np.sqrt(squares)
        odd = ~(np.isfinite(squares) & (squares > np.finfo(np.float64).tiny))
        if odd.any():
            norm[odd] = [_scaled_norm(v) for v in zip(x[odd], y[odd], z[odd])]
    return norm


def _scaled_norm(v: Tuple[float, float, float]) -> float:
    if any(np.isnan(c) for c in v):
        return np.nan
    scale = max(abs(c) for c in v)
    if scale == 0.0 or np.isinf(scale):
        return scale
    return scale * float(np.sqrt(sum((c / scale) ** 2 for c in v)))

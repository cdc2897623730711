"""tolles: remove an aircraft's own magnetic field from airborne magnetometer data.

Learn the aircraft's permanent, induced and eddy-current fields from a calibration flight (a
scalar magnetometer and a three-axis fluxgate) with the Tolles-Lawson model, and subtract them
from survey data. The same library as the ``tolles`` command line: a model written by one is
read by the other, and both compute the same numbers.

>>> import tolles
>>> cal = tolles.simulate(plan="box", seed=1)          # or tolles.read("Flt1003.h5")
>>> model = tolles.fit(cal, scalar="mag_1_uc", vector="flux_a")
>>> out = tolles.compensate(cal, model)                 # adds column mag_1_c (nT)
>>> tolles.fom(out, scalar="mag_1_uc", model=model)["improvement_ratio"] > 10
True

Units: nT for fields, s for time, Hz for rates, degrees for attitude (yaw clockwise from north,
pitch nose up, roll right wing down); fluxgates in the body frame FRD (x forward, y right,
z down). Column names follow the DAF-MIT/SGL flight files: ``tt`` (s), ``mag_1_uc`` (nT),
``flux_a_x/_y/_z`` (nT), ``ins_roll/_pitch/_yaw`` (deg), ``line``.
"""

from __future__ import annotations

import json as _json
import operator as _operator
import os as _os
import pathlib as _pathlib
import tempfile as _tempfile
import warnings as _warnings
from typing import TYPE_CHECKING, Any, Iterable, Mapping, Optional, Sequence, Tuple, Union

import numpy as _np


class _OnFirstUse:
    """A module imported when first used: pandas alone takes 0.4 s to import, which a script
    that only loads a model or streams should not pay."""

    def __init__(self, name: str):
        self._name = name
        self._module = None

    def __getattr__(self, attr: str) -> Any:
        if self._module is None:
            import importlib

            self._module = importlib.import_module(self._name)
        return getattr(self._module, attr)


if TYPE_CHECKING:
    import pandas as _pd
else:
    _pd = _OnFirstUse("pandas")

from . import _tolles, network
from ._tolles import TollesError, __version__

__all__ = [
    "Model",
    "TollesError",
    "TollesLawson",
    "TollesWarning",
    "compensate",
    "convert",
    "fit",
    "fom",
    "load_model",
    "network",
    "plan",
    "procedure",
    "read",
    "report",
    "simulate",
    "__version__",
]

Names = Union[str, Sequence[str]]
PathLike = Union[str, "_os.PathLike[str]"]


class TollesWarning(UserWarning):
    """Something tolles noticed and worked around (missing values, a renamed column, ...)."""


def _warn(messages: Iterable[str]) -> None:
    for message in messages:
        _warnings.warn(message, TollesWarning, stacklevel=3)


def _names(value: Names, what: str) -> list:
    """``"a,b"`` or ``["a", "b"]`` → ``["a", "b"]``."""
    if isinstance(value, str):
        names = [v.strip() for v in value.split(",") if v.strip()]
    else:
        names = [str(v).strip() for v in value]
    if not names:
        raise TollesError(f"{what} needs a column name, or several")
    return names


def _line_ids(line: Any) -> Optional[list]:
    if line is None:
        return None
    if isinstance(line, str):
        return [v.strip() for v in line.split(",")]
    if isinstance(line, (int, float, _np.number)):
        return [repr(float(line)) if isinstance(line, float) else str(line)]
    return [repr(float(v)) if isinstance(v, float) else str(v) for v in line]


def _band(band: Any) -> Tuple[float, float]:
    """``(0.1, 0.9)`` or ``"0.1,0.9"`` (Hz)."""
    if isinstance(band, str):
        band = [v for v in band.split(",")]
    low, high = band
    return (float(low), float(high))


def _count(value: Any, name: str, least: int) -> int:
    """A whole number ≥ ``least`` for the parameter ``name``, or a TollesError naming it."""
    try:
        whole = _operator.index(value)
    except TypeError:
        whole = None
    if whole is None or not least <= whole < 2**32:
        raise TollesError(f"{name} must be a whole number from {least} to 2**32 - 1, got {value!r}")
    return whole


def _angle(value: Any, name: str) -> float:
    """A number of degrees for the parameter ``name``, or a TollesError naming it."""
    try:
        return float(value)
    except (TypeError, ValueError):
        raise TollesError(f"{name} must be a number of degrees, got {value!r}") from None


def _legs(
    headings: Any, heading_tolerance: Any, level_tolerance: Any, cardinal_tolerance: Any
) -> Tuple[Optional[Sequence[float]], float, float, float]:
    """The straight legs and box headings of a FOM as the native module takes them (degrees);
    the ranges are checked there, as for ``tolles fom``."""
    if isinstance(headings, str):
        headings = [h for h in headings.split(",") if h.strip()]
    nominal = None if headings is None else [_angle(h, "headings") for h in headings]
    return (
        nominal,
        _angle(heading_tolerance, "heading_tolerance"),
        _angle(level_tolerance, "level_tolerance"),
        _angle(cardinal_tolerance, "cardinal_tolerance"),
    )


def _terms(terms: Any) -> str:
    """``"auto"``, ``"permanent,induced,eddy"`` or ``["permanent", "induced", "eddy"]``."""
    return terms if isinstance(terms, str) else ",".join(str(t) for t in terms)


def _time_range(time: Any) -> Optional[str]:
    if time is None or isinstance(time, str):
        return time
    start, end = time
    fmt = lambda t: "" if t is None else repr(float(t))  # noqa: E731
    return f"{fmt(start)}..{fmt(end)}"


def convert(
    input: PathLike,
    output: PathLike,
    line: Any = None,
    time: Any = None,
    renames: Optional[Mapping[str, str]] = None,
    *,
    lines: Any = None,
) -> dict:
    """Convert a flight file to CSV, HDF5 or Parquet, exactly as ``tolles convert`` does.

    Parameters
    ----------
    input : str or path
        Any file :func:`read` reads (CSV, XYZ, ASEG-GDF2, HDF5, MATLAB v5 or v7.3, Parquet).
    output : str or path
        ``.csv``, ``.h5``/``.hdf5`` or ``.parquet``/``.pq``; any other extension is an error.
        Written whole or not at all.
    line, time : optional
        Keep only these flight lines / this time range (s), as in :func:`read` (``lines`` is
        the same as ``line``, the name earlier releases used).
    renames : dict of old name → new name, optional
        Columns renamed right after reading.

    Returns
    -------
    dict
        ``rows`` and ``columns`` written, and ``padded``: ``{name: own length}`` of the columns
        shorter than ``rows`` (MATLAB or HDF5 arrays of another length, scalars), padded with
        missing cells in CSV and Parquet. What was left out is warned about.
    """
    if lines is not None:
        if line is not None:
            raise TollesError("give the lines to keep once: line=")
        line = lines
    rows, columns, padded, notes = _tolles.convert(
        _os.fspath(input),
        _os.fspath(output),
        _line_ids(line),
        _time_range(time),
        list((renames or {}).items()),
    )
    _warn(notes)
    return {"rows": rows, "columns": columns, "padded": dict(padded)}


def read(
    path: PathLike,
    line: Any = None,
    time: Any = None,
    renames: Optional[Mapping[str, str]] = None,
) -> _pd.DataFrame:
    """Read a flight file into a DataFrame, exactly as the ``tolles`` command reads it.

    Parameters
    ----------
    path : str or path
        CSV (header row), Geosoft XYZ (``.xyz``), ASEG-GDF2 (``.dfn``/``.dat``), HDF5 (``.h5``,
        ``.hdf5``, MATLAB v7.3 ``.mat``; every 1-D dataset at the root is a column, as in the
        DAF-MIT/SGL flight files) or Parquet (``.parquet``, ``.pq``), chosen by extension.
    line : id, list of ids or "id,id", optional
        Keep only rows of these flight lines (column ``line``); ids match as numbers
        (1002.02 matches 1002.020) or else as text.
    time : (start, end) in s, or "START..END", optional
        Keep only rows with ``tt`` in the range, both ends included; ``None`` leaves an end open.
    renames : dict of old name → new name, optional
        Columns renamed right after reading, before ``line`` and ``time`` select rows.

    Returns
    -------
    pandas.DataFrame
        One column per file column: float64 (missing values NaN) when its cells are numbers,
        else str. ``df.attrs`` holds ``source`` (the path) and the scalars the file carries
        besides its columns, such as HDF5's ``dt`` (s), which gives the sample rate.
    """
    names, columns, metadata, notes = _tolles.read(
        _os.fspath(path), _line_ids(line), _time_range(time), list((renames or {}).items())
    )
    _warn(notes)
    df = _pd.DataFrame(dict(zip(names, columns)), columns=names, copy=False)
    df.attrs["source"] = _os.fspath(path)
    df.attrs.update(dict(metadata))
    return df


class _Columns:
    """Hands a DataFrame's columns to the native code as float64 arrays, only when asked."""

    def __init__(self, df: _pd.DataFrame):
        if not isinstance(df, _pd.DataFrame):
            raise TypeError(f"expected a pandas DataFrame, got {type(df).__name__}")
        self.df = df
        self.names = [str(c) for c in df.columns]
        self.source = str(df.attrs.get("source", "<DataFrame>"))
        seen = set()
        for name in self.names:
            if name in seen:
                # As the CLI refuses such a file: which of the two would be meant is a guess.
                raise TollesError(f"{self.source}: column {name!r} appears more than once")
            seen.add(name)
        dt = df.attrs.get("dt")
        self.dt = float(dt) if dt is not None else None

    def get(self, i: int) -> _np.ndarray:
        column = self.df.iloc[:, i]
        try:
            values = column.to_numpy(dtype=_np.float64, na_value=_np.nan)
        except (TypeError, ValueError):
            values = self._numbers(i, column)
        return _np.ascontiguousarray(values)

    def _numbers(self, i: int, column: _pd.Series) -> _np.ndarray:
        """A text column's cells as numbers, or a TollesError naming the first that is not."""
        numbers = _pd.to_numeric(column, errors="coerce")
        bad = numbers.isna().to_numpy() & column.notna().to_numpy()
        if bad.any():
            row = int(bad.argmax())
            raise TollesError(
                f"{self.source}: row {row}, column {self.names[i]!r}: "
                f"{column.iloc[row]!r} is not a number"
            )
        return numbers.to_numpy(dtype=_np.float64, na_value=_np.nan)

    def args(self) -> tuple:
        return (self.source, self.names, self.get, self.dt)


class Model:
    """A fitted Tolles-Lawson model: one fit per scalar magnetometer.

    The same JSON model file as ``tolles fit --out`` writes (``Model.save``) and every other
    command reads (``tolles.load_model``). With one fit, the attributes below are that fit's;
    with several, use ``model.fits`` (a list of dicts) or ``model.fit_for("mag_4_uc")``.

    Attributes
    ----------
    scalars : list of str
        Uncompensated scalar columns, one per fit.
    columns : list of str
        Design column names, in coefficient order (MagNav.jl's A-matrix order).
    coefficients : numpy.ndarray
        Coefficients (nT per design column; the design's columns are nT-scaled by
        Bt_scale = 50000 nT, as MagNav.jl's).
    patent : dict
        The 16 terms in the patent's nomenclature: ``perm_nT`` (nT), ``induced``
        (dimensionless), ``eddy_s`` (s); axes L = x forward, T = y right, V = z down.
    physical : dict
        Permanent vector (nT), induced matrix (1) and eddy matrix (s).
    diagnostics : dict
        Samples used, residual (nT), improvement ratio, condition number, standard errors,
        the cross-validation and the term-set choice.
    level_nt : float
        The calibration flight's mean correction (nT), subtracted by ``level="model"``.
    magnitude : str
        ``"linear"`` (Tolles-Lawson's ``B̂·H``) or ``"exact"`` (``|B + H| − |B|``).
    fs_hz : float
        The calibration's sample rate (Hz).
    """

    def __init__(self, json_text: str):
        self._json = _tolles.check_model(json_text)
        self._data = _json.loads(self._json)

    @property
    def fits(self) -> list:
        return self._data["fits"]

    @property
    def scalars(self) -> list:
        return [f["scalar"] for f in self.fits]

    def fit_for(self, scalar: str) -> dict:
        """The fit of ``scalar`` as a dict (coefficients, settings, diagnostics, ...)."""
        for f in self.fits:
            if f["scalar"] == scalar:
                return f
        raise KeyError(f"no fit for scalar {scalar!r}; the model has fits for: {', '.join(self.scalars)}")

    def _only(self) -> dict:
        if len(self.fits) != 1:
            raise AttributeError(
                f"the model holds {len(self.fits)} fits ({', '.join(self.scalars)}); use model.fit_for(scalar)"
            )
        return self.fits[0]

    @property
    def columns(self) -> list:
        return list(self._only()["columns"])

    @property
    def coefficients(self) -> _np.ndarray:
        return _np.array(self._only()["coefficients"], dtype=_np.float64)

    @property
    def patent(self) -> dict:
        return self._only()["patent"]

    @property
    def physical(self) -> dict:
        return self._only()["physical"]

    @property
    def diagnostics(self) -> dict:
        return self._only()["diagnostics"]

    @property
    def level_nt(self) -> float:
        return float(self._only()["level_nt"])

    @property
    def network(self) -> Optional[dict]:
        """The network ``fit(..., network=True)`` kept (its ``channels``, ``network`` weights,
        input names and normalisation, and the judged RMS values in nT), or ``None``.
        :mod:`tolles.network` evaluates it with NumPy alone."""
        return self._only().get("network")

    @property
    def magnitude(self) -> str:
        return str(self._only().get("magnitude", "linear"))

    @property
    def fs_hz(self) -> float:
        return float(self._only()["fs_hz"])

    @property
    def verdict(self) -> Optional[dict]:
        """Whether to trust the model: ``{"grade": "good" | "doubtful", "reasons": [...],
        "notes": [...]}``, each reason or note a dict with its ``reason`` and numbers (a note
        does not lower the grade); ``None`` for a model file written before verdicts
        (version 3)."""
        verdict = self._only().get("verdict")
        if verdict is not None:
            verdict = {"grade": verdict["grade"], "reasons": verdict.get("reasons", []),
                       "notes": verdict.get("notes", [])}
        return verdict

    def to_json(self) -> str:
        """The model file's text."""
        return self._json

    def save(self, path: PathLike) -> None:
        """Write the model file, byte for byte what ``tolles fit --out`` writes."""
        _tolles.save_model(self._json, _os.fspath(path))

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Model) and other._data == self._data

    def __repr__(self) -> str:
        parts = [f"{f['scalar']} ~ {','.join(f['vectors'])} ({len(f['coefficients'])} terms)" for f in self.fits]
        return f"Model({'; '.join(parts)})"


def load_model(path: PathLike) -> Model:
    """Read a model file written by ``tolles fit`` or ``Model.save``."""
    return Model(_tolles.load_model(_os.fspath(path)))


def _model(model: Union[Model, PathLike]) -> Model:
    return model if isinstance(model, Model) else load_model(model)


def fit(
    df: Union[_pd.DataFrame, Sequence[_pd.DataFrame]],
    scalar: Names = "mag_1_uc",
    vector: Names = "flux_a",
    *,
    terms: str = "auto",
    lambda_: Union[str, float] = "auto",
    band: Tuple[float, float] = (0.1, 0.9),
    order: int = 4,
    trim: int = 20,
    fs: Optional[float] = None,
    magnitude: Optional[str] = None,
    levels: Optional[bool] = None,
    fluxgate_offset: Optional[bool] = None,
    extra: Names = (),
    lag: Union[str, float, None] = None,
    reference: Optional[str] = None,
    network: bool = False,
    inputs: Names = (),
    network_layers: Sequence[int] = (8,),
    network_activation: str = "swish",
    network_seed: int = 0,
    network_held_out: str = "stretches",
    network_joint: bool = False,
) -> Model:
    """Learn the aircraft's field from a calibration flight, as ``tolles fit`` does.

    Parameters
    ----------
    df : pandas.DataFrame, or a list of them
        The calibration flight (e.g. from :func:`read`), with the scalar, the fluxgate columns
        and, for the sample rate, ``tt`` (s) or ``df.attrs["dt"]`` (s) or ``fs``. Several
        flights (at one sample rate) are fitted together, each its own runs, as ``tolles fit
        a.csv b.csv`` does: nothing is filtered or differenced across two of them.
    scalar : str or list of str
        Uncompensated scalar column(s) (nT); several give one model with a fit per scalar.
    vector : str or list of str
        Fluxgate prefix(es): ``"flux_a"`` reads ``flux_a_x/_y/_z`` (nT, body frame FRD);
        several build one design in which each fluxgate adds its own block of terms.
    terms : str or list of str
        ``"auto"`` (the patent's 16 traceless terms, and over several fluxgates MagNav's 18
        when cross-validation finds them at least 2 % better), or a list such as ``"permanent,induced,eddy"`` (also
        ``patent``, ``p``, ``i``, ``it``, ``i5``, ``i3``, ``e``, ``et``, ``e8``, ``e3``, ``bias``).
    lambda_ : "auto" or float
        Ridge strength: ``"auto"`` chooses λ·diag(AᵀA) by 5-fold blocked cross-validation; a
        number adds that λ to AᵀA with unscaled columns, exactly as MagNav's ``linreg``.
    band : (low, high) in Hz
        Pass band of the zero-phase Butterworth filter (MagNav's 0.1–0.9 Hz).
    order : int
        Butterworth order per band edge.
    trim : int
        Samples dropped at each end of each run after filtering.
    fs : float, optional
        Sample rate (Hz) when the frame has no ``tt`` column and no ``dt``.
    magnitude : {"linear", "exact", "auto"}, optional
        How the field enters the scalar: Tolles-Lawson's ``B̂·H``, the exact ``|B + H| − |B|``,
        or the one cross-validation prefers. Default: ``"auto"`` with ``lambda_="auto"``, else
        ``"linear"`` (MagNav's procedure).
    levels : bool, optional
        Also fit the heading levels against the calibrated fluxgate's magnitude (one
        fluxgate). Default: off (measured in docs/fitting.md, ``--levels``).
    fluxgate_offset : bool, optional
        Calibrate a lone fluxgate's offset (the aircraft's field where it sits, nT) against its
        own magnitude and fit on its readings without it; compensation takes it out too.
        Default: with ``lambda_="auto"``, one fluxgate and no ``reference``.
    extra : str or list of str
        Extra channels as regressors, e.g. currents (``"cur_strb"``): each adds ``B̂x·c, B̂y·c,
        B̂z·c``; with ``lambda_="auto"`` they are kept only if they predict held-out data 2 %
        better. Per channel, ``":lowpass=HZ"`` (causal first-order low-pass) and ``":lag=S"``
        (the field follows the channel S seconds late), e.g. ``"cur_strb:lowpass=0.5:lag=0.2"``,
        as ``tolles fit --extra``. ``compensate`` reads them from the survey by name and
        conditions them the same way.
    lag : "auto", float (s) or None
        The fluxgate's lag behind the scalar: ``"auto"`` estimates it (sub-sample, within ±1 s,
        on held-out folds), a number gives it in seconds (negative: the fluxgate samples
        early), ``None`` takes the samples as they come. The model stores it; ``compensate``
        applies it.
    reference : str, optional
        A compensated reference magnetometer column (nT) on the same flight, e.g. the tail
        stinger's ``mag_1_c`` for a cabin sensor: the scalar minus it is the aircraft's field
        itself, fitted in the full band (``band``, ``order``, ``trim`` and ``levels`` do not
        apply).
    network : bool
        Also train a small network on what the linear model leaves of the scalar minus
        ``reference`` (MagNav's model 2b), as ``tolles fit --network``; kept only if it leaves
        at least 5 % less on held-out stretches of the flight. Its inputs: the fluxgate's
        direction cosines and magnitude (nT), the ``extra`` channels and ``inputs``.
    inputs : str or list of str
        Columns the network reads besides the fluxgate and the extra channels (their units).
    network_layers : sequence of int
        Units per hidden layer (1 to 4 layers of 1 to 256 units).
    network_activation : {"swish", "tanh", "relu"}
        The hidden layers' activation.
    network_seed : int
        Seed of the initial weights and the order of the rows: the same data and seed give
        the same model.
    network_held_out : {"stretches", "lines"}
        What training holds out to stop and to judge the network: 50 equal stretches of time
        (the default, the better model on the flights measured) or whole flight lines of the
        ``line`` column (the harder judge; stretches when there are fewer than 10 lines or one
        holds over a tenth of the rows), as ``tolles fit --network-held-out``.
    network_joint : bool
        Fit the linear model and the network in turn, each on what the other leaves (two
        rounds; MagNav's model 2c), instead of the network on the fixed linear model (2b), as
        ``tolles fit --network-joint``; kept only if the pair beats the linear model alone.
    """
    flights = [df] if isinstance(df, _pd.DataFrame) else list(df)
    if not flights:
        raise TollesError("fit needs at least one calibration flight")
    columns = [_Columns(flight) for flight in flights]
    lam = None if isinstance(lambda_, str) and lambda_.strip().lower() == "auto" else float(lambda_)
    settings = {
        "scalars": _names(scalar, "scalar"),
        "vectors": _names(vector, "vector"),
        "terms": _terms(terms),
        "lambda_": lam,
        "band": _band(band),
        "order": _count(order, "order", 1),
        "trim": _count(trim, "trim", 0),
        "fs": None if fs is None else float(fs),
        "magnitude": magnitude,
        "levels": None if levels is None else bool(levels),
        "fluxgate_offset": None if fluxgate_offset is None else bool(fluxgate_offset),
        "extras": [] if not extra else _names(extra, "extra"),
        "lag": None if lag is None else str(lag),
        "reference": reference,
        "network": bool(network),
        "inputs": [] if not inputs else _names(inputs, "inputs"),
        "network_layers": [_count(n, "network_layers", 1) for n in network_layers],
        "network_activation": str(network_activation),
        "network_seed": _count(network_seed, "network_seed", 0),
        "network_held_out": str(network_held_out),
        "network_joint": bool(network_joint),
    }
    text, notes = _tolles.fit([c.args() for c in columns], settings)
    _warn(notes)
    return Model(text)


def compensate(
    df: _pd.DataFrame,
    model: Union[Model, PathLike],
    level: str = "mean",
    fs: Optional[float] = None,
    uncertainty: bool = False,
) -> _pd.DataFrame:
    """Remove the aircraft's field from survey data, as ``tolles compensate`` does.

    Returns a new DataFrame with every column of ``df`` and one compensated column (nT) per
    fit, named after the scalar with ``_uc`` replaced by ``_c`` (``mag_1_uc`` → ``mag_1_c``;
    ``…_tolles`` if ``df`` already has that column). Rows that cannot be compensated
    (missing values) are NaN.

    Parameters
    ----------
    level : "mean" or "model"
        ``"mean"`` keeps the correction's mean over these rows in the data (MagNav's choice, and
        the CLI's default). ``"model"`` subtracts the calibration's stored mean (``level_nt``),
        so a row's result does not depend on how the data was split (use it on partitions).
    fs : float, optional
        The survey's sample rate (Hz); default from ``tt``, else the model's.
    uncertainty : bool
        Also add, after each compensated column ``NAME``, ``NAME_sigma``: the compensated
        value's standard error up to a constant level (nT): the correction's, from the
        coefficients' covariance, and what the model leaves of the calibration's scalar, in
        quadrature; and ``NAME_extrapolated``: 1.0 where the row's field direction in the
        aircraft, its rate of change or an extra channel lies outside what the calibration flew,
        else 0.0 (NaN where the row is not compensated). Rows outside are counted in a warning
        whether asked for or not.
    """
    columns = _Columns(df)
    model = _model(model)
    if len(df) == 0 or _is_placeholder(df):
        # Nothing to compute; the result names its columns, which is all Dask asks of it.
        names = _tolles.output_names(model.to_json(), columns.names, bool(uncertainty))
        added, notes = [(n, _np.full(len(df), _np.nan)) for n in names], []
    else:
        added, notes = _tolles.compensate(
            *columns.args(),
            model.to_json(),
            str(level),
            None if fs is None else float(fs),
            bool(uncertainty),
        )
    _warn(notes)
    out = df.copy(deep=False)
    for name, values in added:
        out[name] = _pd.Series(values, index=df.index, copy=False)
    return out


def _is_placeholder(df: _pd.DataFrame) -> bool:
    """Dask infers a function's output columns by calling it on two rows of ones; no flight
    looks like that (its fluxgate would read 1.7 nT), so such a frame gets NaN columns instead
    of an error, and ``map_partitions(tolles.compensate, model)`` works without ``meta``."""
    if len(df) != 2:
        return False
    numeric = df.select_dtypes(include="number")
    return numeric.shape[1] > 0 and bool((numeric.to_numpy() == 1.0).all())


def fom(
    df: _pd.DataFrame,
    scalar: Optional[str] = None,
    model: Union[Model, PathLike, None] = None,
    *,
    band: Tuple[float, float] = (0.05, 1.0),
    order: int = 4,
    fs: Optional[float] = None,
    headings: Optional[Sequence[float]] = None,
    heading_tolerance: float = 10.0,
    level_tolerance: float = 3.0,
    cardinal_tolerance: float = 20.0,
) -> dict:
    """Figure of merit of a compensation box: exactly ``tolles fom --json``, as a dict.

    The box's 12 maneuvers (roll, pitch, yaw on headings 0, 90, 180, 270°) are found in
    ``ins_roll``, ``ins_pitch``, ``ins_yaw`` (deg) and ``tt`` (s); the FOM (nT) is the sum of
    the peak-to-peaks of the band-passed scalar over them. ``"heading_error"`` holds the
    surveyors' heading error (nT): the scalar's mean level on the straight legs of each heading
    (``levels``), largest minus smallest, with its uncertainty. With ``model``, also after
    compensation (under ``"compensated"``, heading error on the same samples) and the
    improvement ratio.

    Straight legs and box headings (degrees), as ``tolles fom``'s flags: ``headings`` are the
    nominal headings whose straight legs give the heading error (default 0, 90, 180, 270);
    on a leg the yaw lies within ``heading_tolerance`` (0–90) of one and roll and pitch within
    ``level_tolerance`` (0–90); a box maneuver within ``cardinal_tolerance`` (0–45) of north,
    east, south or west counts as that heading's.
    """
    model = None if model is None else _model(model)
    columns = _Columns(df)
    text, notes = _tolles.fom(
        *columns.args(),
        _fom_scalar(scalar, model),
        None if model is None else model.to_json(),
        _band(band),
        _count(order, "order", 1),
        None if fs is None else float(fs),
        _legs(headings, heading_tolerance, level_tolerance, cardinal_tolerance),
    )
    _warn(notes)
    return _json.loads(text)


def _fom_scalar(scalar: Optional[str], model: Optional[Model]) -> str:
    """The scalar a FOM is of: the one given, else a one-fit model's, else ``mag_1_uc``; as
    ``tolles fom`` chooses it."""
    if scalar is not None:
        return str(scalar)
    if model is None:
        return "mag_1_uc"
    if len(model.scalars) == 1:
        return model.scalars[0]
    raise TollesError(
        f"the model has fits for {', '.join(model.scalars)}: give scalar= to say which"
    )


def report(
    flight: Union[PathLike, _pd.DataFrame],
    out: PathLike,
    model: Union[Model, PathLike, None] = None,
    scalar: Optional[Names] = None,
    line: Any = None,
    time: Any = None,
    renames: Optional[Mapping[str, str]] = None,
    *,
    band: Tuple[float, float] = (0.05, 1.0),
    order: int = 4,
    fs: Optional[float] = None,
    pdf: Optional[PathLike] = None,
    headings: Optional[Sequence[float]] = None,
    heading_tolerance: float = 10.0,
    level_tolerance: float = 3.0,
    cardinal_tolerance: float = 20.0,
    noise_tolerance: float = 0.1,
    reference: Optional[str] = None,
    fom_spec: float = 1.5,
    heading_error_spec: float = 1.0,
    paper: str = "a4",
) -> _pathlib.Path:
    """Write the HTML report of a flight into the directory ``out``, as ``tolles report``.

    ``flight``: a flight file, or a DataFrame (as :func:`read` gives it; its ``source`` attribute
    names the report).

    ``scalar``: a column (nT) or several (``"a,b"`` or a list), compared on one page; by
    default every fit of ``model``. ``model``: a :class:`Model` or a model file; without one,
    the uncompensated flight only. ``line``, ``time``, ``renames``: as in :func:`convert`.
    ``band`` (Hz), ``order``: the figure of merit's band-pass. ``pdf``: also print the page to
    this PDF with headless Chromium (``$TOLLES_CHROMIUM``, or chromium on ``PATH``).
    ``headings``, ``heading_tolerance``, ``level_tolerance``, ``cardinal_tolerance``: as in
    :func:`fom`. ``noise_tolerance`` (nT): the survey specification's fourth-difference
    tolerance, drawn under the fourth difference; each line passes when all of it lies within.
    ``reference``: a column (nT) to judge the compensated scalar against instead of the
    simulator's ``truth_earth``, e.g. SGL's ``mag_1_c``. ``fom_spec`` (nT): the largest
    compensated figure of merit of a box that passes; ``heading_error_spec`` (nT): the largest
    heading error after compensation that passes, judged against the truth or ``reference``;
    with ``noise_tolerance`` they make the specification the first screen passes or fails.
    ``paper``: ``"a4"`` or ``"letter"``, the size of the ``pdf``'s pages.
    Returns the path of ``index.html``; what was noticed is warned about.
    """
    scalars = [] if scalar is None else _names(scalar, "scalar")
    with _tempfile.TemporaryDirectory() as scratch:
        if isinstance(flight, _pd.DataFrame):
            flight = _frame_file(flight, scratch)
        if isinstance(model, Model):
            path = _os.path.join(scratch, "model.json")
            model.save(path)
            model = path
        index, notes = _tolles.report(
            _os.fspath(flight),
            _os.fspath(out),
            None if model is None else _os.fspath(model),
            scalars,
            _line_ids(line),
            _time_range(time),
            list((renames or {}).items()),
            _band(band),
            _count(order, "order", 1),
            None if fs is None else float(fs),
            None if pdf is None else _os.fspath(pdf),
            _legs(headings, heading_tolerance, level_tolerance, cardinal_tolerance),
            float(noise_tolerance),
            reference,
            float(fom_spec),
            float(heading_error_spec),
            str(paper),
        )
    _warn(notes)
    return _pathlib.Path(index)


def _frame_file(df: _pd.DataFrame, scratch: str) -> str:
    """``df`` as a CSV file in ``scratch``, named after the file it was read from (the report's
    title names it); every float written so that it reads back the same."""
    stem = _pathlib.Path(str(df.attrs.get("source", "flight"))).stem or "flight"
    path = _os.path.join(scratch, f"{stem}.csv")
    df.to_csv(path, index=False, float_format="%.17g")
    return path


def simulate(plan: str = "box", preset: str = "cabin", seed: int = 1, **options: Any) -> _pd.DataFrame:
    """A flight whose truth is known, as ``tolles simulate`` writes it.

    ``plan``: ``"box"``, ``"patent"`` or ``"survey"``; ``preset``: ``"tail-stinger"``,
    ``"cabin"``, ``"uav"`` or ``"realistic"``. Other options, named like the command's flags: ``fs`` (Hz),
    ``speed`` (m/s), ``lat``/``lon`` (deg), ``alt`` (m), ``date`` ("YYYY-MM-DD"),
    ``uniform`` ((inclination_deg, declination_deg, intensity_nT) instead of IGRF),
    ``period`` (s), ``cycles``, ``roll``/``pitch``/``yaw`` (deg), ``lines``,
    ``line_duration`` (s), ``turbulence`` (deg), ``geology`` (nT), ``diurnal`` (nT),
    ``scalar_noise`` (nT), ``flux_noise`` (nT), ``flux_lag`` (s), ``effects`` (cabin effects
    Tolles-Lawson cannot represent: ``"load"``, ``"flap"``, ``"temp"``, a list or
    comma-separated text of them, or ``"all"``; columns ``cur_load`` (A), ``pos_flap`` (deg),
    ``temp`` (°C), ``truth_effects`` (nT) and a reference ``mag_ref`` (nT)), ``reference``
    (``True``: ``mag_ref`` without effects), ``reference_noise`` (nT).

    The result's ``attrs["truth"]`` holds the JSON sidecar: every parameter and the true
    terms (physical and patent).
    """
    request = dict(options, plan=plan, preset=preset, seed=seed)
    if isinstance(request.get("effects"), (list, tuple)):
        request["effects"] = ",".join(str(e) for e in request["effects"])
    if "uniform" in request and request["uniform"] is not None:
        request["uniform"] = [float(v) for v in request["uniform"]]
    names, columns, sidecar = _tolles.simulate(_json.dumps(request))
    df = _pd.DataFrame(dict(zip(names, columns)), columns=names, copy=False)
    df.attrs["source"] = f"<simulated {plan}>"
    df.attrs["truth"] = _json.loads(sidecar)
    return df


def procedure(
    df: _pd.DataFrame,
    scalar: str = "mag_1_uc",
    vector: Optional[str] = "flux_a",
    *,
    dip: Optional[float] = None,
    declination: float = 0.0,
    ignore: Union[str, Sequence[str], None] = None,
) -> dict:
    """The Tolles patent's compensation procedure, step by step, beside a least-squares fit of
    the same 16 terms: exactly ``tolles procedure --json``, as a dict.

    The maneuvers (rolls, pitches, wing-ups, cloverleaf) are found in ``ins_roll``,
    ``ins_pitch``, ``ins_yaw`` (deg) and ``tt`` (s). The field's direction in the aircraft comes
    from the fluxgate ``vector`` (nT), or, with ``vector=None``, from the attitude and the
    field's ``dip`` (deg, down positive). ``declination`` (deg east) turns yaw into magnetic
    heading; ``ignore`` leaves maneuvers out by label (``"roll on 045"``). Terms are in nT
    (perm), dimensionless (induced) and s (eddy); axes L = x, T = y, V = z.
    """
    if dip is not None and vector == "flux_a":
        vector = None
    columns = _Columns(df)
    ignored = [] if ignore is None else _names(ignore, "ignore")
    text, notes = _tolles.procedure(
        *columns.args(),
        str(scalar),
        vector,
        None if dip is None else float(dip),
        float(declination),
        ignored,
    )
    _warn(notes)
    return _json.loads(text)


def plan(
    maneuvers: str = "box",
    *,
    without: Union[str, Sequence[str], None] = None,
    flight: Optional[PathLike] = None,
    vector: str = "flux_a",
    terms: str = "permanent,i5,e8",
    noise: float = 0.01,
    dip: float = 68.0,
    declination: float = 0.0,
    intensity: float = 52000.0,
    fs: Optional[float] = None,
) -> dict:
    """How well a calibration flight determines each term, before or after flying it: exactly
    ``tolles plan --json``, as a dict.

    ``maneuvers``: ``"box"``, ``"patent"`` or a list such as ``"roll@0,pitch@90,wingup@270"``
    (headings in deg); ``without`` leaves the box's or patent plan's ``roll``, ``pitch`` or
    ``yaw`` maneuvers out. ``flight``: the path of a flown flight instead, whose maneuvers are
    found in its attitude and weighed with its fluxgate ``vector`` (dip and intensity then come
    from the fluxgate). ``noise`` (nT) sets the standard errors' scale; ``dip`` (deg),
    ``declination`` (deg) and ``intensity`` (nT) the earth field of a plan. ``fs`` (Hz): the
    sample rate of a flight without a time column.
    """
    axes = [] if without is None else _names(without, "without")
    text, notes = _tolles.plan(
        str(maneuvers),
        axes,
        None if flight is None else _os.fspath(flight),
        str(vector),
        _terms(terms),
        float(noise),
        float(dip),
        float(declination),
        float(intensity),
        None if fs is None else float(fs),
    )
    _warn(notes)
    return _json.loads(text)


def __getattr__(name: str) -> Any:
    # The estimator imports scikit-learn, which takes longer than the rest of the package.
    if name == "TollesLawson":
        from ._estimator import TollesLawson

        return TollesLawson
    raise AttributeError(f"module 'tolles' has no attribute {name!r}")


def __dir__() -> list:
    return sorted(__all__)

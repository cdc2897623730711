"""Type stubs of the native module; use the functions of ``tolles`` instead."""

from typing import Any, Callable, List, Mapping, Optional, Sequence, Tuple

import numpy as np
import numpy.typing as npt

__version__: str

class TollesError(ValueError):
    """A flight, model or request tolles cannot use; the message names the file, row or column."""

Getter = Callable[[int], npt.NDArray[np.float64]]
# Nominal headings (None: the cardinal ones), heading, level and cardinal tolerances; degrees.
Legs = Tuple[Optional[Sequence[float]], float, float, float]

def read(
    path: str,
    lines: Optional[Sequence[str]] = ...,
    time: Optional[str] = ...,
    renames: Optional[Sequence[Tuple[str, str]]] = ...,
) -> Tuple[List[str], List[Any], List[Tuple[str, float]], List[str]]: ...
def fit(
    flights: Sequence[Tuple[str, Sequence[str], Getter, Optional[float]]],
    settings: Mapping[str, Any],
) -> Tuple[str, List[str]]: ...
def compensate(
    source: str,
    names: Sequence[str],
    get: Getter,
    dt: Optional[float],
    model: str,
    level: str,
    fs: Optional[float],
) -> Tuple[List[Tuple[str, npt.NDArray[np.float64]]], List[str]]: ...
def fom(
    source: str,
    names: Sequence[str],
    get: Getter,
    dt: Optional[float],
    scalar: str,
    model: Optional[str],
    band: Tuple[float, float],
    order: int,
    fs: Optional[float],
    legs: Legs,
) -> Tuple[str, List[str]]: ...
def procedure(
    source: str,
    names: Sequence[str],
    get: Getter,
    dt: Optional[float],
    scalar: str,
    vector: Optional[str],
    dip_deg: Optional[float],
    declination_deg: float,
    ignore: Sequence[str],
) -> Tuple[str, List[str]]: ...
def plan(
    maneuvers: str,
    without: Sequence[str],
    flight: Optional[str],
    vector: str,
    terms: str,
    noise_nt: float,
    dip_deg: float,
    declination_deg: float,
    intensity_nt: float,
    fs: Optional[float],
) -> Tuple[str, List[str]]: ...
def output_names(model: str, names: Sequence[str]) -> List[str]: ...
def convert(
    input: str,
    output: str,
    lines: Optional[Sequence[str]] = ...,
    time: Optional[str] = ...,
    renames: Optional[Sequence[Tuple[str, str]]] = ...,
) -> Tuple[int, int, List[Tuple[str, int]], List[str]]: ...
def report(
    flight: str,
    out: str,
    model: Optional[str],
    scalars: Sequence[str],
    lines: Optional[Sequence[str]],
    time: Optional[str],
    renames: Optional[Sequence[Tuple[str, str]]],
    band: Tuple[float, float],
    order: int,
    fs: Optional[float],
    pdf: Optional[str],
    legs: Legs,
    noise_tolerance: float,
    reference: Optional[str],
    fom_spec: float,
    heading_error_spec: float,
    paper: str,
) -> Tuple[str, List[str]]: ...
def load_model(path: str) -> str: ...
def check_model(json: str) -> str: ...
def save_model(json: str, path: str) -> None: ...
def simulate(options: str) -> Tuple[List[str], List[npt.NDArray[np.float64]], str]: ...

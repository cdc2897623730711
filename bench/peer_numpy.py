"""The benchmark's NumPy/SciPy peer: the same Tolles-Lawson procedure as `tolles fit` with
MagNav settings, written the way one would in NumPy.

    python peer_numpy.py fit FLIGHT.csv MODEL.json [--lambda 0.001] [--terms 18|16]
    python peer_numpy.py compensate FLIGHT.csv MODEL.json OUT.csv

fit: design matrix in MagNav's create_TL_A column order (B̂ = B/|B|, Bt_scale 50 000 nT,
central differences per sample, one-sided at the ends), zero-phase Butterworth band-pass
(scipy.signal.butter(..., output="sos") + sosfiltfilt) on every column and the scalar, trim,
ridge solve of the normal equations (AᵀA + λI)β = Aᵀy (MagNav's linreg).
compensate: mag_1_c = mag_1_uc − (Aβ − mean(Aβ)), written with every input column as CSV.
CSV is read with pandas.read_csv (C parser) and written with DataFrame.to_csv.
"""

import argparse
import json

import numpy as np
import pandas as pd
from scipy.signal import butter, sosfiltfilt

BT_SCALE = 50_000.0
PAIRS6 = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]
PAIRS9 = [(i, j) for i in range(3) for j in range(3)]


def design(bx, by, bz, terms):
    """The Tolles-Lawson design matrix (n × 18, or 16 without the zz induced and eddy columns)."""
    b = (bx, by, bz)
    norm = np.sqrt(bx * bx + by * by + bz * bz)
    unit = [c / norm for c in b]
    db = [np.gradient(c) for c in b]  # central differences, one-sided at the ends
    induced = PAIRS6 if terms == 18 else PAIRS6[:5]
    eddy = PAIRS9 if terms == 18 else PAIRS9[:8]
    a = np.empty((len(bx), 3 + len(induced) + len(eddy)), order="F")
    for k in range(3):
        a[:, k] = unit[k]
    col = 3
    for i, j in induced:
        np.multiply(unit[i], b[j], out=a[:, col])
        a[:, col] /= BT_SCALE
        col += 1
    for i, j in eddy:
        np.multiply(unit[i], db[j], out=a[:, col])
        a[:, col] /= BT_SCALE
        col += 1
    return a


def read(path):
    frame = pd.read_csv(path, engine="c")
    flux = [frame[f"flux_a_{c}"].to_numpy() for c in "xyz"]
    return frame, frame["mag_1_uc"].to_numpy(), flux


def fit_arrays(scalar, flux, fs, terms=18, lam=0.001, band=(0.1, 0.9), order=4, trim=20):
    """The coefficients of a fit of `scalar` (nT) on `flux` (three arrays, nT) sampled at `fs` Hz."""
    a = design(*flux, terms)
    sos = butter(order, [band[0], band[1]], btype="bandpass", fs=fs, output="sos")
    a = sosfiltfilt(sos, a, axis=0)
    y = sosfiltfilt(sos, scalar)
    a, y = a[trim:-trim], y[trim:-trim]
    gram = a.T @ a
    gram[np.diag_indices_from(gram)] += lam
    return np.linalg.solve(gram, a.T @ y)


def compensated(scalar, flux, beta):
    """`scalar` (nT) less the aircraft's field A·β about its mean."""
    correction = design(*flux, len(beta)) @ np.asarray(beta)
    return scalar - (correction - correction.mean())


def fit(args):
    frame, scalar, flux = read(args.flight)
    fs = 1.0 / np.median(np.diff(frame["tt"].to_numpy()))  # Hz, as tolles takes it from tt
    beta = fit_arrays(scalar, flux, fs, args.terms, args.lam, args.band, args.order, args.trim)
    with open(args.model, "w") as f:
        json.dump({"terms": args.terms, "coefficients": beta.tolist()}, f)


def compensate(args):
    frame, scalar, flux = read(args.flight)
    with open(args.model) as f:
        model = json.load(f)
    frame["mag_1_c"] = compensated(scalar, flux, model["coefficients"])
    frame.to_csv(args.out, index=False)


def main():
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers(dest="command", required=True)
    f = sub.add_parser("fit")
    f.add_argument("flight")
    f.add_argument("model")
    f.add_argument("--lambda", dest="lam", type=float, default=0.001)
    f.add_argument("--terms", type=int, choices=[16, 18], default=18)
    f.add_argument("--band", type=float, nargs=2, default=[0.1, 0.9])
    f.add_argument("--order", type=int, default=4)
    f.add_argument("--trim", type=int, default=20)
    c = sub.add_parser("compensate")
    c.add_argument("flight")
    c.add_argument("model")
    c.add_argument("out")
    args = parser.parse_args()
    fit(args) if args.command == "fit" else compensate(args)


if __name__ == "__main__":
    main()

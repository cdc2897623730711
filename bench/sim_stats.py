"""Statistics that tell a real calibration box from a simulated one (issue 56, item 2).

    python bench/sim_stats.py FLIGHT.csv --scalar S[,S…] --vector V[,V…] [--tolles BIN]

For each scalar × fluxgate pair of a flight (CSV with a `tt` column), it prints:

- *offset*: the fluxgate's offset (nT, the length of the vector `o`) in a fit of the scalar by
  `g·|B_f − o|` (a sphere fit: the offset and gain that make the fluxgate's magnitude the
  scalar's). A fluxgate in a cabin sees the aircraft: real ones carry hundreds to thousands of
  nT.
- *level misfit*: by how much the model `tolles fit` fits to the band misses the calibration's
  low frequencies (nT RMS; `diagnostics.untrusted_levels_nt`, or the heading levels' misfit
  when they were used). Geology under legs far apart and diurnal variation make it large.
- *band / noise*: the fit's in-band residual (nT) over the scalar's own noise, estimated from
  its fourth difference (1.4826·MAD(Δ⁴y)/√70, nT): how much of the band the model leaves beyond
  noise.
- *spread*: over several fluxgates, the standard deviation (nT) of the difference of two
  fluxgates' magnitudes (mean removed), the largest pair: how differently they see the
  aircraft.

Only NumPy, SciPy and pandas are needed (bench/real's environment). `docs/simulation.md`
holds the table for the real files and the simulator's presets.
"""

import argparse
import json
import math
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

ROOT = Path(__file__).resolve().parent.parent


def magnitude(frame, fluxgate):
    return np.sqrt(sum(frame[f"{fluxgate}_{c}"].to_numpy() ** 2 for c in "xyz"))


def offset_nt(frame, scalar, fluxgate):
    """|o| (nT) of the sphere fit y ≈ g·|B_f − o|."""
    b = np.column_stack([frame[f"{fluxgate}_{c}"].to_numpy() for c in "xyz"])
    y = frame[scalar].to_numpy()

    def residual(p):
        return p[3] * np.linalg.norm(b - p[:3], axis=1) - y

    fit = least_squares(residual, x0=[0.0, 0.0, 0.0, 1.0], x_scale=[1e3, 1e3, 1e3, 1e-3])
    return float(np.linalg.norm(fit.x[:3]))


def fourth_difference_noise_nt(y):
    """The scalar's white noise (nT) from its fourth difference, robustly (the median absolute
    deviation: a switched current's steps are not noise)."""
    d = np.diff(y, n=4)
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / math.sqrt(70.0))


def tolles_fit(tolles, path, scalar, fluxgate):
    with tempfile.TemporaryDirectory() as tmp:
        model = Path(tmp) / "m.json"
        subprocess.run([tolles, "fit", str(path), "--scalar", scalar, "--vector", fluxgate,
                        "--out", str(model)], check=True, capture_output=True)
        return json.loads(model.read_text())["fits"][0]["diagnostics"]


def level_misfit_nt(diagnostics):
    if diagnostics.get("untrusted_levels_nt") is not None:
        return diagnostics["untrusted_levels_nt"]
    levels = diagnostics.get("levels")
    return levels["residual_rms_nt"] if levels else float("nan")


def spread_nt(frame, fluxgates):
    if len(fluxgates) < 2:
        return float("nan")
    spreads = []
    for i, a in enumerate(fluxgates):
        for b in fluxgates[i + 1:]:
            d = magnitude(frame, a) - magnitude(frame, b)
            spreads.append(float(np.std(d - d.mean())))
    return max(spreads)


def rows(path, scalars, fluxgates, tolles):
    frame = pd.read_csv(path)
    spread = spread_nt(frame, fluxgates)
    for scalar in scalars:
        noise = fourth_difference_noise_nt(frame[scalar].to_numpy())
        for fluxgate in fluxgates:
            d = tolles_fit(tolles, path, scalar, fluxgate)
            yield {
                "scalar": scalar,
                "fluxgate": fluxgate,
                "offset_nt": offset_nt(frame, scalar, fluxgate),
                "level_misfit_nt": level_misfit_nt(d),
                "band_nt": d["residual_std_nt"],
                "noise_nt": noise,
                "band_over_noise": d["residual_std_nt"] / noise,
                "spread_nt": spread,
            }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("flight")
    parser.add_argument("--scalar", required=True)
    parser.add_argument("--vector", required=True)
    parser.add_argument("--tolles", default=str(ROOT / "target" / "release" / "tolles"))
    args = parser.parse_args()
    print("| scalar | fluxgate | offset (nT) | level misfit (nT) | band (nT) | noise (nT) | "
          "band / noise | spread (nT) |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows(args.flight, args.scalar.split(","), args.vector.split(","), args.tolles):
        print(f"| {r['scalar']} | {r['fluxgate']} | {r['offset_nt']:.0f} | "
              f"{r['level_misfit_nt']:.2f} | {r['band_nt']:.3f} | {r['noise_nt']:.4f} | "
              f"{r['band_over_noise']:.1f} | {r['spread_nt']:.0f} |")


if __name__ == "__main__":
    main()

"""Does `good` mean good, and is σ the size of the error? `bench/verdict` calls this.

A population of installations is drawn at random from the independent NumPy generator of
`bench/installations` (not tolles' simulator): a permanent field from 5 to 2 000 nT with induced
and eddy terms in proportion, and at random an induced trace, a fluxgate that sees the aircraft
(300–3 000 nT), a noisy fluxgate (2 nT), a switched current (0.5–5 nT/A, column `cur_1`, fitted
with `--extra cur_1`) and, for a fifth of them, a calibration without maneuvers (straight legs
with turbulence, as a transit). Each is fitted with tolles' defaults and scored on a survey
flown elsewhere, against the truth:

- *error*: the standard deviation of (compensated − truth) with its mean removed (nT);
- *oracle*: the same for the true model (the installation's own terms, the induced matrix
  without its trace, the current's field) fitted by nonlinear least squares to the
  calibration with the earth's field known;
- *fluxgate oracle*: the same true model with B read from the fluxgate (less its offset) and
  only the earth's magnitude known: what the data can tell at best (a noisy fluxgate's noise
  enters every term of any model);
- *fine*: error ≤ 3 × the fluxgate oracle's; otherwise *poor*. The summary also counts against
  the noise-free oracle;
- *σ coverage*: the share of survey rows with |error − mean error| ≤ σ (`--uncertainty`);
- *predicted*: the RMS of σ over the survey (nT), beside the error.

The summary is a confusion table of the verdict against fine/poor, the share of `good` that
is fine, the share of poor that is not `good`, and the spread of σ's coverage.

With `--real` it also fits the real calibrations of `bench/real` (each half of each flight,
the other half held out) and prints each verdict beside the held-out band residual, MagNav's
settings' and the oracle's (16 terms, λ chosen in hindsight on the held-out half).

    bench/verdict                 # 40 installations (about two minutes)
    bench/verdict --count 100     # a larger population
    bench/verdict --real          # and the real calibrations (two more minutes)
"""

import argparse
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
from installations import (  # noqa: E402
    Installation, Kind, box_attitude, survey_attitude, scores)

ROOT = Path(__file__).resolve().parent.parent
FINE_RATIO = 3.0


def draw_kind(rng):
    """One installation's kind and whether its calibration has maneuvers."""
    permanent = math.exp(rng.uniform(math.log(5.0), math.log(2000.0)))
    induced = permanent * 1e-5 * rng.uniform(0.5, 1.5)
    eddy = 0.0 if rng.random() < 0.15 else permanent * 1.2e-6 * rng.uniform(0.5, 1.5)
    trace = induced * rng.uniform(1, 3) * rng.choice([-1, 1]) if rng.random() < 0.25 else 0.0
    offset = rng.uniform(300, 3000) if rng.random() < 0.25 else 0.0
    noise = 2.0 if rng.random() < 0.15 else 0.5
    current = rng.uniform(0.5, 5.0) if rng.random() < 0.3 else 0.0
    maneuvers = rng.random() >= 0.2
    parts = [f"{permanent:.0f} nT"]
    parts += ["trace"] * bool(trace) + ["offset"] * bool(offset) + ["noisy fluxgate"] * (noise > 1)
    parts += ["current"] * bool(current) + ["no maneuvers"] * (not maneuvers)
    kind = Kind(", ".join(parts), permanent, induced, eddy, trace=trace, flux_offset_nt=offset,
                flux_noise_nt=noise, current_nt_per_a=current)
    return kind, maneuvers


def run_tolles(tolles, work, extra):
    model, out = work / "model.json", work / "out.csv"
    args = [tolles, "fit", str(work / "box.csv"), "--scalar", "mag_1_uc", "--vector", "flux_a",
            "--out", str(model)] + (["--extra", "cur_1"] if extra else [])
    fit = subprocess.run(args, capture_output=True, text=True)
    if fit.returncode != 0:
        return None
    subprocess.run([tolles, "compensate", str(work / "survey.csv"), "--model", str(model),
                    "--out", str(out), "--uncertainty"], check=True, capture_output=True,
                   text=True)
    spec = json.loads(model.read_text())["fits"][0]
    frame = pd.read_csv(out)
    verdict = spec.get("verdict") or {}
    reasons = [r.get("reason", "?") for r in verdict.get("reasons", [])]
    return frame["mag_1_c"].to_numpy(), frame["mag_1_c_sigma"].to_numpy(), \
        verdict.get("grade", "?"), reasons


def one(seed, tolles, work):
    rng = np.random.default_rng(5000 + seed)
    kind, maneuvers = draw_kind(rng)
    inst = Installation.draw(kind, 6000 + seed)
    attitude = box_attitude(rng) if maneuvers else survey_attitude(rng)
    box, _, box_earth = inst.fly(attitude, rng)
    survey, truth, survey_earth = inst.fly(survey_attitude(rng), rng)
    box.to_csv(work / "box.csv", index=False)
    survey.to_csv(work / "survey.csv", index=False)
    np.savetxt(work / "truth.txt", truth)
    y = survey["mag_1_uc"].to_numpy()
    currents = (box["cur_1"].to_numpy(), survey["cur_1"].to_numpy()) if "cur_1" in box else \
        (None, None)
    scalar = box["mag_1_uc"].to_numpy()
    oracle = scores(y - inst.exact_oracle(scalar, box_earth, survey_earth, currents=currents),
                    truth)["overall"]
    vector = lambda f: f[[f"flux_a_{c}" for c in "xyz"]].to_numpy() - inst.flux_offset  # noqa
    floor = scores(y - inst.exact_oracle(scalar, box_earth, survey_earth, vector(box),
                                         vector(survey), currents=currents), truth)["overall"]
    # What the data alone tell: the fluxgate oracle without the earth's magnitude.
    data_floor = scores(y - inst.exact_oracle(scalar, box_earth, survey_earth, vector(box),
                                              vector(survey), currents=currents,
                                              earth_known=False), truth)["overall"]
    row = {"seed": seed, "kind": kind.name, "oracle": oracle, "fluxgate oracle": floor,
           "data-only oracle": data_floor}
    outcome = run_tolles(tolles, work, "cur_1" in box)
    if outcome is None:
        row.update(grade="refused", reasons=[])
        return row
    compensated, sigma, grade, reasons = outcome
    error = compensated - truth
    error -= np.nanmean(error)
    row.update(grade=grade, reasons=reasons, error=float(np.nanstd(error)),
               coverage=float(np.nanmean(np.abs(error) <= sigma)),
               predicted=float(np.sqrt(np.nanmean(sigma ** 2))))
    row["fine"] = row["error"] <= FINE_RATIO * floor
    row["fine vs noise-free oracle"] = row["error"] <= FINE_RATIO * oracle
    return row


def confusion(rows, key, label):
    out = [f"| verdict | fine (≤ {FINE_RATIO:g}× {label}) | poor |", "|---|---|---|"]
    for g in ("good", "doubtful", "refused"):
        fine = sum(1 for r in rows if r["grade"] == g and r.get(key))
        poor = sum(1 for r in rows if r["grade"] == g and not r.get(key, False))
        out.append(f"| {g} | {fine} | {poor} |")
    good = [r for r in rows if r["grade"] == "good"]
    poor = [r for r in rows if not r.get(key, False)]
    out.append("")
    if good:
        share = sum(bool(r.get(key)) for r in good) / len(good)
        out.append(f"`good` that is fine against the {label}: {share:.0%} of {len(good)}")
    if poor:
        held = sum(r["grade"] != "good" for r in poor) / len(poor)
        out.append(f"poor against the {label} that is not `good`: {held:.0%} of {len(poor)}")
    return out


def summary(rows):
    out = confusion(rows, "fine", "fluxgate oracle") + [""]
    out += confusion(rows, "fine vs noise-free oracle", "noise-free oracle") + [""]
    covered = [r["coverage"] for r in rows if "coverage" in r]
    if covered:
        inside = sum(0.45 <= c <= 0.90 for c in covered)
        q = np.percentile(covered, [10, 50, 90])
        out.append(f"σ coverage: median {q[1]:.2f}, 10–90 % of installations {q[0]:.2f}–{q[2]:.2f}; "
                   f"45–90 % on {inside} of {len(covered)}")
    ratio = [r["predicted"] / r["error"] for r in rows if r.get("error")]
    if ratio:
        q = np.percentile(ratio, [10, 50, 90])
        out.append(f"predicted (RMS σ) / error: median {q[1]:.2f}, 10–90 % {q[0]:.2f}–{q[2]:.2f}")
    return "\n".join(out)


def real_verdicts(tolles):
    """`bench/real`'s fits: each verdict beside its held-out band residual (nT)."""
    import os
    import real
    shared = Path(os.environ.get("TOLLES_SHARED", str(ROOT.parent / "shared")))
    data = Path(os.environ.get("TOLLES_REAL_DATA", str(ROOT / ".data")))
    print("\n| flight | half fitted | scalar | fluxgates | verdict | reasons | held-out band | "
          "MagNav's settings | oracle | ×oracle |")
    print("|" + "---|" * 10)
    with tempfile.TemporaryDirectory(prefix="tolles-verdict-real-") as tmp:
        for ds in real.datasets(shared, data):
            frame = ds.load()
            if frame is None:
                print(f"skipping {ds.name}: not found ({ds.source})", file=sys.stderr)
                continue
            for row in real.run_dataset(ds, frame, tolles, Path(tmp)):
                band = {k: v["band"] for k, v in row["figures"].items()}
                cells = [band.get("tolles", math.nan), band["magnav"], band["floor16"]]
                cells.append(cells[0] / cells[2])
                reasons = ", ".join(r.get("reason", "?") for r in row["reasons"])
                print(f"| {row['dataset']} | {row['fold']} | {row['scalar']} | "
                      f"{row['fluxgates']} | {row['verdict']} | {reasons} | "
                      + " | ".join(f"{v:.3f}" for v in cells) + " |", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tolles", default=str(ROOT / "target" / "release" / "tolles"))
    parser.add_argument("--count", type=int, default=40, help="installations to draw")
    parser.add_argument("--json", help="write every row to this file")
    parser.add_argument("--only", type=int, action="append", help="one installation (its #)")
    parser.add_argument("--keep", help="keep each installation's box, survey and model in DIR/#")
    parser.add_argument("--real", action="store_true", help="also bench/real's calibrations")
    args = parser.parse_args()
    rows = []
    print("| # | installation | verdict | reasons | error | oracle | fluxgate oracle | "
          "×fluxgate oracle | predicted | σ coverage |")
    print("|" + "---|" * 10)
    with tempfile.TemporaryDirectory(prefix="tolles-verdict-") as tmp:
        for seed in range(1, args.count + 1):
            if args.only and seed not in args.only:
                continue
            work = Path(args.keep) / str(seed) if args.keep else Path(tmp)
            work.mkdir(parents=True, exist_ok=True)
            row = one(seed, args.tolles, work)
            rows.append(row)
            error = row.get("error", float("nan"))
            floor = row["fluxgate oracle"]
            cells = [error, row["oracle"], floor, error / floor, row.get("predicted", math.nan),
                     row.get("coverage", math.nan)]
            print(f"| {seed} | {row['kind']} | {row['grade']} | {', '.join(row['reasons'])} | "
                  + " | ".join(f"{v:.3g}" for v in cells) + " |", flush=True)
    print()
    print(summary(rows))
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1, default=float))
    if args.real:
        real_verdicts(args.tolles)
    return 0


if __name__ == "__main__":
    sys.exit(main())

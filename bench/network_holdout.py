"""How a network learned on some flights does on another: `bench/network_holdout` calls this.

Issue 48's check, on flights simulated here: three cabin calibration flights (a box, a survey
and a box flown with larger rolls and pitches) are fitted together (`tolles fit t1.csv t2.csv
t3.csv --reference mag_ref`), and a fourth flight, a box or a survey flown with another seed,
is compensated with each model. Each case is run with the simulated effects no linear term
holds (`tolles simulate --effects all`: a saturating load, a magnetised flap, temperature;
`--extra cur_load,pos_flap,temp`) and without them (`--reference` alone). The models:

- `linear`: the linear fit alone;
- `2b`: `--network` (the default, a network on the fixed linear model);
- `2c`: `--network --network-joint`;
- `lines`: `--network --network-held-out lines`.

The error is the standard deviation (nT) of the compensated scalar minus the simulator's
`truth_earth` over the held-out flight. It prints each case's errors and each model's error as
a fraction of the linear model's, and their geometric means; issue 48 asks for at most 0.5 with
the effects and at most 1.05 without them (geometric means). Only the Python standard library
is needed.
"""

import argparse
import csv
import math
import statistics
import subprocess
import sys
from pathlib import Path

MODELS = {"linear": None, "2b": [], "2c": ["--network-joint"],
          "lines": ["--network-held-out", "lines"]}
LIMITS = {True: 0.5, False: 1.05}


def tolles(args, *cli):
    done = subprocess.run([args.tolles, *map(str, cli)], capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"error: tolles {' '.join(map(str, cli))}: {done.stderr.strip()}")


def simulate(args, work, effects, plan, seed, name):
    cli = ["simulate", "--preset", "cabin", "--seed", seed, "--out", work / name]
    cli += ["--effects", "all"] if effects else ["--reference"]
    cli += {"box": ["--plan", "box"], "survey": ["--plan", "survey", "--lines", "4"],
            "steep": ["--plan", "box", "--roll", "15", "--pitch", "8"]}[plan]
    tolles(args, *cli)
    return work / name


def error_nt(path):
    """Standard deviation (nT) of mag_1_c − truth_earth where both are numbers."""
    with open(path, newline="") as f:
        rows = csv.DictReader(f)
        errors = []
        for row in rows:
            try:
                e = float(row["mag_1_c"]) - float(row["truth_earth"])
            except ValueError:
                continue
            if math.isfinite(e):
                errors.append(e)
    return statistics.pstdev(errors)


def case(args, effects, held_out_plan, base):
    work = Path(args.work) / f"{'effects' if effects else 'none'}-{held_out_plan}-{base}"
    work.mkdir(parents=True, exist_ok=True)
    train = [simulate(args, work, effects, plan, base + k + 1, f"t{k + 1}.csv")
             for k, plan in enumerate(("box", "survey", "steep"))]
    held = simulate(args, work, effects, held_out_plan, base + 4, "held_out.csv")
    fit = ["fit", *train, "--scalar", "mag_1_uc", "--vector", "flux_a", "--reference", "mag_ref"]
    if effects:
        fit += ["--extra", "cur_load,pos_flap,temp"]
    errors = {}
    for name, flags in MODELS.items():
        model = work / f"{name}.json"
        tolles(args, *fit, *([] if flags is None else ["--network", *flags]), "--out", model)
        out = work / f"{name}.csv"
        tolles(args, "compensate", held, "--model", model, "--out", out)
        errors[name] = error_nt(out)
    return errors


def table(results):
    lines = ["| effects | held out | seed | " + " | ".join(f"{m} (nT)" for m in MODELS) + " |",
             "|---|---|---:|" + "---:|" * len(MODELS)]
    for (effects, plan, base), errors in results.items():
        cells = [f"{errors[m]:.4f}" for m in MODELS]
        lines.append(f"| {'yes' if effects else 'no'} | {plan} | {base} | " + " | ".join(cells) + " |")
    lines += ["", "| effects | " + " | ".join(f"{m} ÷ linear" for m in MODELS if m != "linear")
              + " | limit |", "|---|" + "---:|" * len(MODELS)]
    for effects in (True, False):
        ratios = {m: [e[m] / e["linear"] for (fx, _, _), e in results.items() if fx == effects]
                  for m in MODELS if m != "linear"}
        means = [math.exp(statistics.fmean(map(math.log, r))) for r in ratios.values()]
        lines.append(f"| {'yes' if effects else 'no'} | "
                     + " | ".join(f"{g:.3f}" for g in means) + f" | ≤ {LIMITS[effects]} |")
    return "\n".join(lines)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tolles", required=True)
    parser.add_argument("--work", required=True)
    parser.add_argument("--seeds", default="0,10", help="seed bases, comma-separated")
    args = parser.parse_args()
    results = {}
    for effects in (True, False):
        for plan in ("box", "survey"):
            for base in (int(s) for s in args.seeds.split(",")):
                print(f"effects {effects}, held-out {plan}, seed base {base} ...", file=sys.stderr)
                results[effects, plan, base] = case(args, effects, plan, base)
    text = table(results)
    print(text)
    (Path(args.work) / "network_holdout.md").write_text(text + "\n")


if __name__ == "__main__":
    main()

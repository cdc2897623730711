"""Speed of `fit --network` on 10⁶ rows and of compensating with its model: `bench/network_speed`
calls this.

Issue 48 asks that training on 10⁶ rows (10 Hz, about 28 flight hours) take at most 60 s on
2 cores with the defaults, and that compensating with the network take at most twice as long as
with the linear model. This simulates a cabin survey of about 10⁶ rows with the effects no
linear term holds (`tolles simulate --plan survey --preset cabin --effects all`, a saturating
load, a magnetised flap, temperature; by default 560 lines at 10 Hz, 1 005 001 rows, 27.9 h),
then, round after round, each as its own process:

- `tolles fit … --reference mag_ref --extra cur_load,pos_flap,temp`, linear and `--network`
  (the defaults: one layer of 8, swish, seed 0);
- `tolles compensate` of the same file to CSV with each model;

keeps each one's fastest round (wall-clock s and peak resident memory from wait4, the figure
`/usr/bin/time -v` prints as "Maximum resident set size"), and prints a table with the limits.
It exits non-zero when a limit is missed.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

FIT_LIMIT_S = 60.0
COMPENSATE_RATIO_LIMIT = 2.0
FIT = ["--scalar", "mag_1_uc", "--vector", "flux_a", "--reference", "mag_ref",
       "--extra", "cur_load,pos_flap,temp"]


def run(cmd):
    """Wall-clock seconds and peak RSS (MiB) of `cmd`; exits with its message on an error."""
    with tempfile.TemporaryFile() as err:
        start = time.perf_counter()
        proc = subprocess.Popen([str(c) for c in cmd], stdout=subprocess.DEVNULL, stderr=err)
        _, status, usage = os.wait4(proc.pid, 0)
        seconds = time.perf_counter() - start
        if os.waitstatus_to_exitcode(status) != 0:
            err.seek(0)
            said = err.read().decode(errors="replace")
            sys.exit(f"error: {' '.join(map(str, cmd))} failed:\n{said}")
    return seconds, usage.ru_maxrss / 1024.0


def survey(args, work):
    path = work / f"survey_{args.lines}lines_{args.fs:g}hz_seed{args.seed}.csv"
    if not path.exists():
        print(f"simulating {path.name} ...", flush=True)
        run([args.tolles, "simulate", "--plan", "survey", "--preset", "cabin", "--effects", "all",
             "--seed", args.seed, "--lines", args.lines, "--fs", args.fs, "--out", path])
    return path


def row_count(path):
    with open(path, "rb") as f:
        return sum(1 for _ in f) - 1


def one_round(args, flight, work):
    linear, network = work / "linear.json", work / "network.json"
    out = work / "compensated.csv"
    fit = [args.tolles, "fit", flight, *FIT]
    times = {
        "fit, linear": run(fit + ["--out", linear]),
        "fit, --network": run(fit + ["--network", "--out", network]),
    }
    compensate = [args.tolles, "compensate", flight, "--out", out]
    times["compensate to CSV, linear model"] = run(compensate + ["--model", linear])
    times["compensate to CSV, network model"] = run(compensate + ["--model", network])
    out.unlink(missing_ok=True)
    return times


def network_summary(path):
    learned = json.loads(path.read_text())["fits"][0].get("network")
    if learned is None:
        return "network not kept"
    return (f"{learned['epochs']} epochs, kept epoch {learned['best_epoch']}; judged "
            f"{learned['judged_network_rms_nt']:.3f} nT vs linear "
            f"{learned['judged_linear_rms_nt']:.3f} nT")


def report(best, flight, rows, fs, work, rounds):
    fit_s = best["fit, --network"][0]
    ratio = best["compensate to CSV, network model"][0] / best["compensate to CSV, linear model"][0]
    hours = rows / fs / 3600.0
    lines = [f"{flight.name}: {rows:,} rows at {fs:g} Hz ({hours:.1f} flight hours), "
             f"{flight.stat().st_size / 1e6:.0f} MB; fastest of {rounds} rounds, each its own "
             "process:", "",
             "| run | wall s | peak RSS MiB |", "|---|---:|---:|"]
    lines += [f"| {name} | {s:.2f} | {mib:.0f} |" for name, (s, mib) in best.items()]
    fit_ok, ratio_ok = fit_s <= FIT_LIMIT_S, ratio <= COMPENSATE_RATIO_LIMIT
    lines += ["",
              f"- network: {network_summary(work / 'network.json')}",
              f"- `fit --network` of {rows:,} rows: {fit_s:.2f} s (limit {FIT_LIMIT_S:.0f} s): "
              f"{'met' if fit_ok else 'MISSED'}",
              f"- compensate with the network ÷ with the linear model: {ratio:.2f} (limit "
              f"{COMPENSATE_RATIO_LIMIT:.0f}): {'met' if ratio_ok else 'MISSED'}"]
    text = "\n".join(lines)
    print("\n" + text)
    (work / "network_speed.md").write_text(text + "\n")
    return fit_ok and ratio_ok


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tolles", required=True)
    parser.add_argument("--work", required=True)
    parser.add_argument("--lines", type=int, default=560, help="survey lines (120 s each)")
    parser.add_argument("--fs", type=float, default=10.0, help="sample rate (Hz)")
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    flight = survey(args, work)
    rows = row_count(flight)
    rounds = []
    for k in range(args.rounds):
        print(f"round {k + 1} of {args.rounds} ...", flush=True)
        rounds.append(one_round(args, flight, work))
    best = {name: min(r[name] for r in rounds) for name in rounds[0]}
    sys.exit(0 if report(best, flight, rows, args.fs, work, args.rounds) else 1)


if __name__ == "__main__":
    main()

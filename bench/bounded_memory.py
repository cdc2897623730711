"""Peak memory of `tolles compensate` whole and in bounded memory, for a plain model, a model
with an extra channel and a model with a lag (issue 47: bounded memory must hold for all three).

    python bench/bounded_memory.py --tolles target/release/tolles [--rows 2000000] [--work DIR]

Writes a 200 000-sample calibration and a ROWS-row survey (bench/gen_flight.py) with a current
channel `cur_1` (A) that adds 3 nT/A to the scalar, fits the three models, compensates the
survey whole and with TOLLES_MEMORY=bounded, checks the two outputs are the same bytes, and
prints each run's wall time (s) and peak resident memory (MiB, from wait4). With --bound MIB it
exits non-zero when a bounded run's peak exceeds MIB.
"""

import argparse
import filecmp
import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
MODELS = {"plain": [], "extra": ["--extra", "cur_1"], "lag": ["--lag", "0.05"]}


def with_current(plain, path, seed):
    """`plain` with a slowly varying current `cur_1` (A) whose 3 nT/A is in the scalar. Run in
    a process of its own (`--with-current`): a child forked from a process holding the flight
    would count its pages in the child's peak memory."""
    import numpy as np
    import pandas as pd

    df = pd.read_csv(plain)
    rng = np.random.default_rng(seed)
    t = df["tt"].to_numpy()
    walk = np.cumsum(rng.normal(0.0, 0.01, len(t)))
    df["cur_1"] = 5.0 + 2.0 * np.sin(2 * np.pi * 0.03 * t) + walk - walk.mean()
    df["mag_1_uc"] += 3.0 * df["cur_1"]
    df.to_csv(path, index=False, float_format="%.10g")


def flight(work, name, rows, seed):
    path = work / f"{name}_{rows}_cur.csv"
    if not path.exists():
        plain = work / f"{name}_{rows}.csv"
        subprocess.run([sys.executable, HERE / "gen_flight.py", str(rows), plain,
                        "--seed", str(seed)], check=True)
        subprocess.run([sys.executable, __file__, "--with-current", plain, path, str(seed)],
                       check=True)
        plain.unlink()
    return path


def run(cmd, env=None):
    """Wall-clock seconds and peak RSS (MiB) of `cmd`; fails loudly on an error."""
    start = time.perf_counter()
    proc = subprocess.Popen([str(c) for c in cmd], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, env={**os.environ, **(env or {})})
    _, status, usage = os.wait4(proc.pid, 0)
    seconds = time.perf_counter() - start
    err = proc.stderr.read().decode(errors="replace")
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit(f"error: {' '.join(map(str, cmd))} failed:\n{err}")
    return seconds, usage.ru_maxrss / 1024.0


def main():
    if sys.argv[1:2] == ["--with-current"]:
        plain, path, seed = sys.argv[2:5]
        return with_current(plain, path, int(seed))
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tolles", required=True, type=Path)
    ap.add_argument("--rows", type=int, default=2_000_000)
    ap.add_argument("--work", type=Path, default=Path("target/bench/bounded_memory"))
    ap.add_argument("--bound", type=float, help="largest bounded peak allowed (MiB)")
    args = ap.parse_args()
    args.work.mkdir(parents=True, exist_ok=True)
    cal = flight(args.work, "calibration", 200_000, 1)
    survey = flight(args.work, "survey", args.rows, 2)
    print(f"survey: {args.rows} rows, {survey.stat().st_size / 2**20:.0f} MiB")
    print(f"{'model':<8}{'whole s':>9}{'whole MiB':>11}{'bounded s':>11}{'bounded MiB':>13}")
    over = []
    for name, flags in MODELS.items():
        model = args.work / f"model_{name}.json"
        run([args.tolles, "fit", cal, "--scalar", "mag_1_uc", "--vector", "flux_a",
             "--out", model, *flags])
        outs = {}
        row = []
        for memory in ["whole", "bounded"]:
            outs[memory] = args.work / f"out_{name}_{memory}.csv"
            seconds, peak = run([args.tolles, "compensate", survey, "--model", model,
                                 "--out", outs[memory]], {"TOLLES_MEMORY": memory})
            row += [seconds, peak]
        if not filecmp.cmp(outs["whole"], outs["bounded"], shallow=False):
            sys.exit(f"error: {name}: whole and bounded compensation wrote different bytes")
        print(f"{name:<8}{row[0]:>9.2f}{row[1]:>11.0f}{row[2]:>11.2f}{row[3]:>13.0f}")
        if args.bound is not None and row[3] > args.bound:
            over.append(f"{name} ({row[3]:.0f} MiB)")
    if over:
        sys.exit(f"bounded memory exceeded {args.bound} MiB: {', '.join(over)}")


if __name__ == "__main__":
    main()

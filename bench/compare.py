"""Times tolles against its peers on the same generated flights; `bench/run` calls this.

For every size it writes a flight (CSV + HDF5, bench/gen_flight.py), then runs, each as its own
process on the same file, fit followed by compensate of that same file:
- tolles with MagNav settings, the NumPy/SciPy peer (same algorithm), deinterf with Ridge 0.001
  on 18 terms (its nearest to MagNav's procedure);
- tolles with its defaults (16 or 18 terms and λ by cross-validation), deinterf with its defaults.
It checks that the NumPy peer's compensated values equal tolles' and reports how far deinterf's
are from them and from the truth, then measures what compensate costs on HDF5 and Parquet
input next to only reading (and writing) the same file. Wall-clock, CPU time and peak
resident memory come from wait4 on each child process.
"""

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

HERE = Path(__file__).resolve().parent
MAGNAV = ["--terms", "permanent,induced,eddy", "--lambda", "0.001", "--band", "0.1,0.9",
          "--order", "4", "--trim", "20"]
FLIGHT_COLUMNS = "tt,mag_1_uc,flux_a_x,flux_a_y,flux_a_z"


def run(cmd, quiet=True):
    """Runs `cmd`; returns (wall s, cpu s, peak RSS MiB). Fails loudly on a non-zero exit."""
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL if quiet else None,
                            stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    err = proc.stderr.read().decode(errors="replace")
    proc.stderr.close()
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        sys.exit(f"error: {' '.join(map(str, cmd))} failed ({proc.returncode}):\n{err}")
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0


def best_of(repeat, cmd):
    """The fastest of `repeat` runs (wall), with its CPU time and the largest peak RSS."""
    runs = [run(cmd) for _ in range(repeat)]
    wall, cpu, _ = min(runs)
    return wall, cpu, max(r[2] for r in runs)


def pretty(n):
    exponent = int(round(np.log10(n)))
    return f"1e{exponent}" if 10**exponent == n else str(n)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tolles", required=True)
    parser.add_argument("--read-cost", required=True, help="the read_cost example binary")
    parser.add_argument("--work", required=True, help="directory for flights and outputs")
    parser.add_argument("--sizes", default="1e4,1e5,1e6,1e7")
    parser.add_argument("--repeat", type=int, default=0,
                        help="runs per command, fastest kept (default 3 up to 1e5 samples, else 1)")
    parser.add_argument("--keep", action="store_true", help="keep the generated files")
    args = parser.parse_args()
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    sizes = [int(float(s)) for s in args.sizes.split(",")]
    py = sys.executable
    results = []
    for n in sizes:
        results.append(bench_size(n, args, work, py))
        if not args.keep:
            for f in work.glob(f"*_{n}.*"):
                f.unlink()
    report(results, work)


def bench_size(n, args, work, py):
    repeat = args.repeat or (3 if n <= 100_000 else 1)
    csv, h5 = work / f"flight_{n}.csv", work / f"flight_{n}.h5"
    print(f"\n== {pretty(n)} samples: generating {csv.name} ...", flush=True)
    gen = run([py, HERE / "gen_flight.py", str(n), csv, "--h5", h5])
    print(f"   generated in {gen[0]:.1f} s ({csv.stat().st_size / 2**20:.0f} MiB CSV)", flush=True)
    tolles = args.tolles
    setups = [
        ("tolles", "MagNav settings",
         lambda m: [tolles, "fit", csv, "--scalar", "mag_1_uc", "--vector", "flux_a", "--out", m] + MAGNAV,
         "json"),
        ("numpy/scipy", "MagNav settings",
         lambda m: [py, HERE / "peer_numpy.py", "fit", csv, m], "json"),
        ("deinterf", "18 terms, Ridge 0.001",
         lambda m: [py, HERE / "peer_deinterf.py", "fit", csv, m, "--config", "magnav"], "pkl"),
        ("tolles", "defaults (auto terms, CV λ)",
         lambda m: [tolles, "fit", csv, "--scalar", "mag_1_uc", "--vector", "flux_a", "--out", m],
         "json"),
        ("deinterf", "defaults (16 terms, RidgeCV)",
         lambda m: [py, HERE / "peer_deinterf.py", "fit", csv, m, "--config", "default"], "pkl"),
    ]
    rows = []
    for k, (tool, config, fit_cmd, ext) in enumerate(setups):
        model = work / f"model{k}_{n}.{ext}"
        out = work / f"out{k}_{n}.csv"
        if tool == "tolles":
            comp_cmd = [tolles, "compensate", csv, "--model", model, "--out", out]
        else:
            script = "peer_numpy.py" if tool == "numpy/scipy" else "peer_deinterf.py"
            comp_cmd = [py, HERE / script, "compensate", csv, model, out]
        fit = best_of(repeat, fit_cmd(model))
        comp = best_of(repeat, comp_cmd)
        rows.append({"tool": tool, "config": config, "fit_s": fit[0], "compensate_s": comp[0],
                     "total_s": fit[0] + comp[0], "cpu_s": fit[1] + comp[1],
                     "peak_mib": max(fit[2], comp[2]), "out": out})
        print(f"   {tool:12} {config:30} fit {fit[0]:8.2f} s  compensate {comp[0]:8.2f} s",
              flush=True)
    rows[1]["vs"], rows[2]["vs"], rows[4]["vs"] = 0, 0, 3
    accuracy = agreement(csv, rows)
    io = read_costs(n, args, work, csv, h5, rows[0]["out"], work / "model0_{}.json".format(n))
    for r in rows:
        r["out"] = str(r["out"])
    return {"samples": n, "rows": rows, "accuracy": accuracy, "io": io}


def agreement(csv, rows):
    """Compensated values against tolles' and against the truth (nT)."""
    truth = pd.read_csv(csv, usecols=["truth_earth"])["truth_earth"].to_numpy()
    out = [pd.read_csv(r["out"], usecols=["mag_1_c"])["mag_1_c"].to_numpy() for r in rows]

    def vs_truth(c):
        d = c - truth
        return float(np.std(d - d.mean()))

    return {
        "numpy_vs_tolles_max_abs_nt": float(np.max(np.abs(out[1] - out[0]))),
        "deinterf_magnav_vs_tolles_std_nt": float(np.std(out[2] - out[0])),
        "deinterf_default_vs_tolles_default_std_nt": float(np.std(out[4] - out[3])),
        "error_vs_truth_std_nt": [vs_truth(c) for c in out],
    }


def read_costs(n, args, work, csv, h5, tolles_csv_out, model):
    """compensate on HDF5 / Parquet / CSV input next to reading and writing the same file."""
    parquet = work / f"flight_{n}.parquet"
    # A Parquet copy of the flight, written by tolles itself (it adds a mag_1_c column).
    run([args.tolles, "compensate", h5, "--model", model, "--out", parquet])
    costs = []
    for path in [h5, parquet, csv]:
        ext = path.suffix
        copy = work / f"copy_{n}{ext}"
        out = work / f"comp_{n}{ext}"
        read_only = json.loads(subprocess.run(
            [args.read_cost, path, "--columns", FLIGHT_COLUMNS],
            check=True, capture_output=True, text=True).stdout)
        read_write = best_of(1, [args.read_cost, path, "--columns", FLIGHT_COLUMNS, "--write", copy])
        comp = best_of(1, [args.tolles, "compensate", path, "--model", model, "--out", out])
        costs.append({"format": ext.lstrip("."), "read_s": read_only["read_s"] + read_only["columns_s"],
                      "read_write_process_s": read_write[0], "compensate_s": comp[0]})
        print(f"   {ext:9} read {costs[-1]['read_s']:.2f} s, read+write {read_write[0]:.2f} s, "
              f"compensate {comp[0]:.2f} s", flush=True)
    return costs


def machine():
    cpu = "unknown CPU"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
        mem = next(l for l in open("/proc/meminfo") if l.startswith("MemTotal"))
        mem_gib = int(mem.split()[1]) / 2**20
    except (OSError, StopIteration):
        mem_gib = float("nan")
    return f"{cpu}, {os.cpu_count()} logical CPUs, {mem_gib:.0f} GiB RAM, {platform.system()} {platform.release()}"


def report(results, work):
    lines = []
    lines.append(f"Machine: {machine()}; Python {platform.python_version()}, "
                 f"numpy {np.__version__}, pandas {pd.__version__}, {versions()}")
    lines.append("")
    lines.append("| samples | run | settings | fit s | compensate s | total s | CPU s | peak MiB "
                 "| peer / tolles (wall) | peer / tolles (CPU) |")
    lines.append("|---:|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for res in results:
        rows = res["rows"]
        for r in rows:
            ratio = cpu_ratio = ""
            if "vs" in r:
                ratio = f"{r['total_s'] / rows[r['vs']]['total_s']:.1f}×"
                cpu_ratio = f"{r['cpu_s'] / rows[r['vs']]['cpu_s']:.1f}×"
            lines.append(f"| {pretty(res['samples'])} | {r['tool']} | {r['config']} | {r['fit_s']:.2f} | "
                         f"{r['compensate_s']:.2f} | {r['total_s']:.2f} | {r['cpu_s']:.2f} | "
                         f"{r['peak_mib']:.0f} | {ratio} | {cpu_ratio} |")
    lines.append("")
    lines.append("Agreement (nT): numpy vs tolles = max |Δ| of the compensated values; deinterf vs tolles = std Δ; "
                 "error = std of (compensated − truth) after removing its mean, in the order tolles MagNav, "
                 "numpy, deinterf 18/0.001, tolles defaults, deinterf defaults.")
    lines.append("")
    lines.append("| samples | numpy vs tolles | deinterf vs tolles (MagNav) | deinterf vs tolles (defaults) | error vs truth |")
    lines.append("|---:|---:|---:|---:|---|")
    for res in results:
        a = res["accuracy"]
        errors = " / ".join(f"{e:.3f}" for e in a["error_vs_truth_std_nt"])
        lines.append(f"| {pretty(res['samples'])} | {a['numpy_vs_tolles_max_abs_nt']:.1e} | "
                     f"{a['deinterf_magnav_vs_tolles_std_nt']:.3f} | "
                     f"{a['deinterf_default_vs_tolles_default_std_nt']:.3f} | {errors} |")
    lines.append("")
    lines.append("Compensate (MagNav model) against only reading the columns it needs, and against a "
                 "process that reads and writes the same table (read_cost example), seconds:")
    lines.append("")
    lines.append("| samples | input | read | read + write | compensate | compensate / read + write |")
    lines.append("|---:|---|---:|---:|---:|---:|")
    for res in results:
        for c in res["io"]:
            lines.append(f"| {pretty(res['samples'])} | {c['format']} | {c['read_s']:.2f} | "
                         f"{c['read_write_process_s']:.2f} | {c['compensate_s']:.2f} | "
                         f"{c['compensate_s'] / c['read_write_process_s']:.2f} |")
    text = "\n".join(lines)
    print("\n" + text)
    (work / "results.md").write_text(text + "\n")
    (work / "results.json").write_text(json.dumps(results, indent=1))
    print(f"\n(also in {work / 'results.md'} and results.json)")


def versions():
    from importlib.metadata import version

    return ", ".join(f"{p} {version(p)}" for p in ["scipy", "deinterf", "scikit-learn"])


if __name__ == "__main__":
    main()

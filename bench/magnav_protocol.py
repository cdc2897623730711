"""MagNav's comparison on the DAF-MIT/SGL flights: `bench/magnav_protocol` calls this.

The protocol (issue 48): train on flights 1003–1006 without the test line, test on line
1006.08 (Flight 1006's compensation maneuvers in Eastern Ontario at 400 m), Mag 4 (`mag_4_uc`,
rear of the cabin, on the floor) with Flux D (`flux_d_x/y/z`), against the tail stinger's
compensated `mag_1_c` as the reference. It runs

- tolles' linear fit: `tolles fit TRAIN --scalar mag_4_uc --vector flux_d --reference mag_1_c`;
- the learned one: the same with `--network` (MagNav's model 2b: a network added to a fixed
  Tolles-Lawson model), reading a few INS and current channels as `--inputs` when every flight
  has them;

compensates the test line with each model (`tolles compensate FLT --line 1006.08`) and prints
their errors beside MagNav's published ones.

**Data.** MagNav.jl's `sgl_2020_train` artifact (doi:10.5281/zenodo.4271803): one HDF5 file a
flight, `Flt1003_train.h5` … `Flt1006_train.h5`, 10 Hz, one 1-D dataset a channel (`tt` in s
past midnight, `line`, `flight`, `mag_1_c`, `mag_4_uc`, `flux_d_x`, `ins_roll`, `cur_strb`, …).
It is not shipped here: give the directory that holds the files.

**Several flights in one fit.** Each training flight is converted (`tolles convert`) to a CSV
of the columns the fits need, without the test line's rows, and `tolles fit` is given all of
them: it keeps each file its own runs, and the test line leaves a time gap in flight 1006, so
no run is filtered or differentiated across two flights or across the test line.

**Error.** MagNav's `err_segs`: the error `compensated − mag_1_c` (nT) with its mean removed
per segment, a segment being one flight line, and its standard deviation (n − 1, as Julia's
`std`). The test is one line, so it is one segment: the standard deviation over line 1006.08.
The mean is removed because a scalar magnetometer's level is not compensated (tolles keeps the
correction's mean over the rows written, as MagNav does).

**Published numbers.** Issue 48 quotes MagNav's comparison on line 1006.08, Mag 4 with Flux D:
Tolles-Lawson alone 134 nT, model 2c 63 nT, model 2b 39 nT. Those are against the magnetic
anomaly map (plus IGRF and diurnal), not against `mag_1_c`; the stinger is itself compensated
and closer to the truth than the map, so the columns compare in size, not to the nT.

`--selftest` runs the protocol on small simulated flights with the same file and channel names
(`tolles simulate --effects all`, a cabin installation with a saturating load, a magnetised
flap and temperature) and checks that the printed table holds finite numbers and that the
learned model beats the linear one there. Only the Python standard library is needed.
"""

import argparse
import csv
import json
import math
import re
import shutil
import statistics
import subprocess
import sys
from pathlib import Path

TRAIN_FLIGHTS = ("1003", "1004", "1005", "1006")
TEST_LINE = "1006.08"
# Channels MagNav's own examples feed its networks (currents and attitude), taken as --inputs
# when every flight has them. ins_yaw is left out: a heading jumps 360° at north.
DEFAULT_INPUTS = ("ins_roll", "ins_pitch", "cur_strb", "cur_outpwr", "cur_ac_hi", "cur_ac_lo",
                  "cur_com_1", "cur_flap")
PUBLISHED_NT = {"linear": "134 (Tolles-Lawson alone)",
                "network": "39 (model 2b); 63 (model 2c)"}


def flight_file(data, flight):
    return Path(data) / f"Flt{flight}_train.h5"


def tolles(args, *cli):
    """Runs `tolles CLI…`; its standard error, or a one-line exit on failure."""
    done = subprocess.run([str(args.tolles), *map(str, cli)], capture_output=True, text=True)
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["(no message)"])[-1]
        sys.exit(f"error: tolles {' '.join(map(str, cli[:2]))} … failed: {last}")
    return done.stderr


def same_line(cell, line):
    try:
        return abs(float(cell) - float(line)) < 1e-6
    except ValueError:
        return cell.strip() == line


def base_channels(spec):
    """`cur_strb:lowpass=0.5,temp` → [cur_strb, temp]: the columns an --extra spec reads."""
    return [part.split(":")[0].strip() for part in spec.split(",") if part.strip()]


def header(path):
    with open(path, newline="") as f:
        return next(csv.reader(f))


def flights_as_csv(args, work):
    """Each training flight converted to CSV once (reused while the HDF5 file is older)."""
    paths = {}
    for flight in args.flights:
        source, target = flight_file(args.data, flight), work / f"Flt{flight}_train.csv"
        if not target.exists() or target.stat().st_mtime < source.stat().st_mtime:
            tolles(args, "convert", source, target)
        paths[flight] = target
    return paths


def chosen_inputs(args, headers, extras):
    if args.inputs != "auto":
        return [c for c in args.inputs.split(",") if c.strip()]
    everywhere = set.intersection(*(set(h) for h in headers.values()))
    return [c for c in DEFAULT_INPUTS if c in everywhere and c not in extras]


def check_columns(headers, needed):
    for flight, names in headers.items():
        missing = [c for c in needed if c not in names]
        if missing:
            sys.exit(f"error: Flt{flight}_train.h5 has no column {', '.join(missing)}")


def training_flights(csvs, columns, test_line, work):
    """Writes `columns` of each flight in `csvs` ({flight: path}) but the test line's rows into
    its own `work/train_FLIGHT.csv`. Returns (the paths, training rows, test rows left out)."""
    kept = left_out = 0
    paths = []
    for flight, path in csvs.items():
        out = work / f"train_{flight}.csv"
        with open(path, newline="") as f, open(out, "w", newline="") as o:
            reader, writer = csv.reader(f), csv.writer(o)
            names = next(reader)
            at = [names.index(c) for c in columns]
            tt, line = names.index("tt"), names.index("line")
            writer.writerow(columns)
            for row in reader:
                if len(row) <= max(at) or row[tt] == "":
                    continue  # a padded row of a shorter side array (dt, N)
                if same_line(row[line], test_line):
                    left_out += 1
                    continue
                writer.writerow([row[i] for i in at])
                kept += 1
        paths.append(out)
    return paths, kept, left_out


def fit(args, train, out, network, extras, inputs):
    cli = ["fit", *train, "--scalar", args.scalar, "--vector", args.vector,
           "--reference", args.reference, "--out", out]
    if extras:
        cli += ["--extra", args.extra]
    if network:
        cli += ["--network"] + (["--inputs", ",".join(inputs)] if inputs else [])
    said = tolles(args, *cli)
    return [line.strip() for line in said.splitlines() if "network" in line]


def line_error(args, model, out):
    """(error of the compensated scalar, error of the uncompensated one, rows) on the test line
    against the reference, nT: standard deviations about the line's mean."""
    tolles(args, "compensate", flight_file(args.data, args.test_flight), "--model", model,
           "--line", args.test_line, "--out", out)
    with open(out, newline="") as f:
        reader = csv.reader(f)
        names = next(reader)
        # compensate appends its column last: mag_4_c, or mag_4_c_tolles when the file already
        # has SGL's own mag_4_c.
        new, ref, raw = len(names) - 1, names.index(args.reference), names.index(args.scalar)
        if not names[new].startswith(args.scalar.replace("_uc", "_c")):
            sys.exit(f"error: compensate wrote {names[new]!r}, not the compensated scalar")
        compensated, uncompensated = [], []
        for row in reader:
            try:
                reference = float(row[ref])
                pair = (float(row[new]) - reference, float(row[raw]) - reference)
            except ValueError:
                continue  # an empty cell: a row compensate could not compensate
            if all(math.isfinite(x) for x in pair):
                compensated.append(pair[0])
                uncompensated.append(pair[1])
    if len(compensated) < 2:
        sys.exit(f"error: line {args.test_line} has fewer than 2 rows with {args.reference}")
    return statistics.stdev(compensated), statistics.stdev(uncompensated), len(compensated)


def training_set(args, work):
    """The training CSVs (one a flight), their row counts and the --extra and --inputs
    channels."""
    csvs = flights_as_csv(args, work)
    headers = {f: header(p) for f, p in csvs.items()}
    extras = base_channels(args.extra)
    inputs = chosen_inputs(args, headers, extras)
    columns = ["tt", "line", args.scalar, *(f"{args.vector}_{a}" for a in "xyz"),
               args.reference, *extras, *inputs]
    columns = list(dict.fromkeys(columns))
    check_columns(headers, columns)
    chosen = {f: csvs[f] for f in args.flights}
    train, kept, left_out = training_flights(chosen, columns, args.test_line, work)
    if left_out == 0:
        sys.exit(f"error: no rows of line {args.test_line} in the training flights")
    return train, (kept, left_out), extras, inputs


def network_kept(model):
    return json.loads(Path(model).read_text())["fits"][0].get("network") is not None


def run_protocol(args):
    missing = [flight_file(args.data, f).name for f in args.flights
               if not flight_file(args.data, f).exists()]
    if missing:
        sys.exit(f"error: {args.data} lacks {', '.join(missing)} "
                 "(MagNav.jl's sgl_2020_train files)")
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    train, counts, extras, inputs = training_set(args, work)
    linear, network = work / "linear.json", work / "network.json"
    fit(args, train, linear, False, extras, inputs)
    said = fit(args, train, network, True, extras, inputs)
    errors = {name: line_error(args, model, work / f"test_{name}.csv")
              for name, model in (("linear", linear), ("network", network))}
    table = render(args, errors, counts, inputs, network_kept(network), said)
    print(table)
    (work / "magnav_protocol.md").write_text(table + "\n")
    (work / "magnav_protocol.json").write_text(json.dumps(
        {"linear_nt": errors["linear"][0], "network_nt": errors["network"][0],
         "uncompensated_nt": errors["linear"][1], "test_rows": errors["linear"][2],
         "training_rows": counts[0], "inputs": inputs, "extra": extras}, indent=1) + "\n")
    return table


def render(args, errors, counts, inputs, kept, said):
    flights = f"Flt{args.flights[0]}–Flt{args.flights[-1]}"
    linear = f"fit --reference {args.reference}" + (f" --extra {args.extra}" if args.extra else "")
    learned = "`--network" + (f" --inputs {','.join(inputs)}" if inputs else "") + "`"
    learned += "; network kept" if kept else "; network not kept: the linear model alone"
    lines = [
        f"Trained on {flights} without line {args.test_line} ({counts[0]} rows; {counts[1]} "
        f"rows of the line left out), tested on line {args.test_line} ({errors['linear'][2]} "
        f"rows): {args.scalar} with {args.vector}. Error: standard deviation of "
        f"(compensated − {args.reference}) over the line, its mean removed (MagNav's err_segs, "
        "one segment a flight line), nT.",
        "",
        f"| model | tolles, against {args.reference} (nT) "
        "| MagNav published, against the map (nT) |",
        "|---|---:|---:|",
        f"| uncompensated {args.scalar} | {errors['linear'][1]:.2f} | |",
        f"| Tolles-Lawson, linear (`{linear}`) | {errors['linear'][0]:.2f} "
        f"| {PUBLISHED_NT['linear']} |",
        f"| learned ({learned}) | {errors['network'][0]:.2f} | {PUBLISHED_NT['network']} |",
        "",
        "The published numbers are issue 48's quotation of MagNav's comparison on this line; they "
        "are against the anomaly map, tolles' against the stinger's compensated "
        f"{args.reference}.",
    ]
    lines += [f"fit: {s}" for s in said]
    return "\n".join(lines)


# ---- the self-test: simulated flights under the SGL names --------------------------------

SGL_NAMES = {"mag_1_uc": "mag_4_uc", "flux_a_x": "flux_d_x", "flux_a_y": "flux_d_y",
             "flux_a_z": "flux_d_z", "mag_ref": "mag_1_c", "cur_load": "cur_strb"}
# (plan, seed) of each simulated flight; flight 1006's last survey line becomes 1006.08.
SELFTEST_PLANS = {"1003": ("box", 31), "1004": ("survey", 41), "1005": ("survey", 51),
                  "1006": ("survey", 61)}


def segment_ids(line_cells, flight, last):
    """The simulator's line and turn labels → SGL ids `flight.NN` in time order, numbered so
    that the last segment is `flight.last`."""
    runs = [0]
    for before, cell in zip(line_cells, line_cells[1:]):
        runs.append(runs[-1] + (cell != before))
    first = (last - runs[-1]) if last else 1
    return [f"{int(flight) + (first + r) / 100:.2f}" for r in runs]


def simulate_flight(args, flight, out_dir):
    plan, seed = SELFTEST_PLANS[flight]
    raw = out_dir / f"sim_{flight}.csv"
    cli = ["simulate", "--plan", plan, "--preset", "cabin", "--effects", "all", "--seed", seed,
           "--out", raw]
    if plan == "survey":
        cli += ["--lines", args.selftest_lines, "--line-duration", args.selftest_line_s]
    tolles(args, *cli)
    with open(raw, newline="") as f:
        rows = list(csv.reader(f))
    names, body = rows[0], rows[1:]
    tt, line, scalar = names.index("tt"), names.index("line"), names.index("mag_1_uc")
    ids = segment_ids([r[line] for r in body], flight, 8 if flight == "1006" else 0)
    # Seconds past midnight, as SGL's tt: every flight starts in the same hour of its day, so
    # the flights' times overlap, as they do in the real files.
    start_s = 46100.0 + 10.0 * int(flight[-1])
    named = out_dir / f"sgl_{flight}.csv"
    with open(named, "w", newline="") as f:
        writer = csv.writer(f)
        # SGL's own compensated Mag 4 too, so compensate must write its column beside it.
        writer.writerow([SGL_NAMES.get(n, n) for n in names] + ["flight", "mag_4_c"])
        for row, line_id in zip(body, ids):
            row[tt], row[line] = repr(float(row[tt]) + start_s), line_id
            writer.writerow(row + [flight, row[scalar]])
    tolles(args, "convert", named, flight_file(out_dir, flight))
    raw.unlink()
    named.unlink()
    Path(str(raw.with_suffix(".json"))).unlink(missing_ok=True)


TABLE_ROW = re.compile(r"^\| (uncompensated|Tolles-Lawson|learned)[^|]*\| ([^|]*) \|", re.M)


def check_table(table):
    """The three errors the table prints, after checking they are finite and the learned
    model beats the linear one on the simulated effects."""
    found = {name: value.strip() for name, value in TABLE_ROW.findall(table)}
    if set(found) != {"uncompensated", "Tolles-Lawson", "learned"}:
        sys.exit(f"selftest failed: the table lacks a row:\n{table}")
    values = {}
    for name, text in found.items():
        try:
            values[name] = float(text)
        except ValueError:
            sys.exit(f"selftest failed: {name} error is {text!r}:\n{table}")
        if not math.isfinite(values[name]):
            sys.exit(f"selftest failed: {name} error is {text}:\n{table}")
    if "network kept" not in table:
        sys.exit(f"selftest failed: the network was not kept:\n{table}")
    if not values["learned"] < 0.8 * values["Tolles-Lawson"] < values["uncompensated"]:
        sys.exit(f"selftest failed: the learned model does not beat the linear one:\n{table}")
    return values


def selftest(args):
    data = Path(args.work) / "selftest_flights"
    shutil.rmtree(data, ignore_errors=True)
    data.mkdir(parents=True)
    for flight in args.flights:
        simulate_flight(args, flight, data)
    args.data = str(data)
    args.extra = args.extra or "cur_strb,pos_flap,temp"
    values = check_table(run_protocol(args))
    print(f"selftest passed: learned {values['learned']:.3f} nT < linear "
          f"{values['Tolles-Lawson']:.3f} nT < uncompensated {values['uncompensated']:.3f} nT")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", nargs="?",
                        help="directory of Flt1003_train.h5 … Flt1006_train.h5")
    parser.add_argument("--tolles", required=True, help="the tolles binary")
    parser.add_argument("--work", required=True,
                        help="directory for the joined flights, models and outputs")
    parser.add_argument("--scalar", default="mag_4_uc")
    parser.add_argument("--vector", default="flux_d")
    parser.add_argument("--reference", default="mag_1_c")
    parser.add_argument("--flights", default=",".join(TRAIN_FLIGHTS),
                        help="training flights (numbers); the test flight is 1006")
    parser.add_argument("--test-line", default=TEST_LINE)
    parser.add_argument("--extra", default="",
                        help="--extra of both fits, e.g. cur_strb:lowpass=0.2")
    parser.add_argument("--inputs", default="auto",
                        help="the network's --inputs; `auto`: those of "
                             f"{','.join(DEFAULT_INPUTS)} every flight has (minus --extra); "
                             "'' none")
    parser.add_argument("--selftest", action="store_true",
                        help="run on simulated flights with the SGL names and check the table")
    parser.add_argument("--selftest-lines", type=int, default=3,
                        help="survey lines of a simulated flight")
    parser.add_argument("--selftest-line-s", type=float, default=120.0,
                        help="seconds of a simulated line")
    args = parser.parse_args()
    args.flights = [f.strip() for f in args.flights.split(",") if f.strip()]
    args.test_flight = args.test_line.split(".")[0]
    if args.test_flight not in args.flights:
        sys.exit(f"error: the test line's flight {args.test_flight} is not among --flights")
    if args.selftest:
        selftest(args)
    elif not args.data:
        sys.exit("error: give the directory of Flt1003_train.h5 … Flt1006_train.h5 "
                 "(or --selftest)")
    else:
        run_protocol(args)


if __name__ == "__main__":
    main()

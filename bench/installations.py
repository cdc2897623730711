"""Simulated installations against an oracle: `bench/installations` calls this.

Our own simulator is not the only world: this benchmark builds its flights with an independent
NumPy generator and draws fifteen installations, from a quiet tail stinger to a cabin of a few
thousand nT, with and without eddy currents, with the induced matrix's trace, and with a
fluxgate that sees the aircraft. Each installation flies

- a calibration box (10 Hz, headings 0/90/180/270°, rolls ±10°, pitches ±5°, yaws ±5° at a
  6 s period, 3 cycles each, a little turbulence), over geology and diurnal variation;
- a survey of straight lines on the four headings with 0.5–1° of turbulence, elsewhere.

The scalar reads |B_earth + B_aircraft| exactly (second-order effects included), with
B_aircraft = p + A·B_earth + E·dB_earth/dt in the body frame (FRD; nT, nT and s).

**Scored on the survey** against the true earth's field (nT):
- *overall*: the standard deviation of (compensated − truth) with its mean removed;
- *band*: the same band-passed 0.1–0.9 Hz (Butterworth order 4, zero phase, 20 samples
  trimmed).

**Columns.**
- raw;
- MagNav's settings (`peer_numpy.fit_arrays`: 18 terms, λ = 0.001, 0.1–0.9 Hz);
- tolles' defaults (`tolles fit BOX --scalar mag_1_uc --vector flux_a`, then `compensate`);
- the oracle: the true model itself, `|B + p + A·B + E·dB/dt| − |B|` with the installation's
  own terms (permanent, induced, eddy: those it has), the induced matrix without its trace
  (which a box cannot tell from the earth's own field), fitted by nonlinear least squares to
  the box with the earth's field known, then applied to the survey. It knows what the data can
  tell about the model, and the earth's field besides. (The same form linearised, `B̂·H`, is
  kept in `--json` as "linear oracle": over heavy cabins it is no floor, since second-order
  terms of a thousand nT reach tenths of a nT.)
- the fluxgate oracle: the same true model with B read from the fluxgate (less its offset), as
  any compensation must, and only the earth's magnitude known: its noise enters every term.
  It differentiates the fluxgate as it comes, so in band a fit that filters (tolles) can beat
  it; overall it is what the fluxgate lets a full-band fit reach.

    bench/installations            # the table and the geometric means
    bench/installations --only 7   # one installation
"""

import argparse
import json
import math
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.signal import butter, sosfiltfilt

sys.path.insert(0, str(Path(__file__).resolve().parent))
from peer_numpy import fit_arrays, compensated as peer_compensated  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
FS = 10.0
BAND_HZ = (0.1, 0.9)
TRIM = 20


@dataclass
class Kind:
    """How an installation is drawn: magnitudes of its terms (permanent nT, induced and eddy
    entries as fractions of the earth's field and seconds), and the fluxgate's offset (nT)."""

    name: str
    permanent_nt: float
    induced: float
    eddy_s: float
    trace: float = 0.0  # the induced matrix's own trace, on top of its random entries
    flux_offset_nt: float = 0.0
    flux_noise_nt: float = 0.5
    current_nt_per_a: float = 0.0  # a current's field (nT per A, each axis), column cur_1


# Fifteen installations, a declarative table: each kind drawn with its own seed.
KINDS = [
    Kind("tail", 5.0, 2e-5, 1e-5),
    Kind("tail", 10.0, 5e-5, 2e-5),
    Kind("tail, no eddy", 8.0, 4e-5, 0.0),
    Kind("cabin", 200.0, 2e-3, 3e-4),
    Kind("cabin", 400.0, 4e-3, 5e-4),
    Kind("cabin", 600.0, 6e-3, 8e-4),
    Kind("cabin, no eddy", 300.0, 3e-3, 0.0),
    Kind("cabin, strong eddy", 150.0, 1e-3, 2e-3),
    Kind("cabin, trace", 300.0, 2e-3, 3e-4, trace=6e-3),
    Kind("cabin, trace", 500.0, 3e-3, 5e-4, trace=-9e-3),
    Kind("heavy cabin", 1200.0, 1e-2, 1e-3),
    Kind("heavy cabin", 2000.0, 1.5e-2, 1.5e-3),
    Kind("cabin, fluxgate offset", 300.0, 3e-3, 4e-4, flux_offset_nt=1500.0),
    Kind("cabin, fluxgate offset", 500.0, 4e-3, 5e-4, flux_offset_nt=3000.0),
    Kind("uav", 60.0, 5e-4, 1e-4, flux_noise_nt=2.0),
]


def rotation(yaw, pitch, roll):
    """Body-from-NED rotation matrices (n × 3 × 3), ZYX: yaw, pitch, roll in rad."""
    cy, sy, cp, sp, cr, sr = (np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch),
                              np.cos(roll), np.sin(roll))
    r = np.empty((len(yaw), 3, 3))
    r[:, 0, 0], r[:, 0, 1], r[:, 0, 2] = cp * cy, cp * sy, -sp
    r[:, 1, 0] = sr * sp * cy - cr * sy
    r[:, 1, 1] = sr * sp * sy + cr * cy
    r[:, 1, 2] = sr * cp
    r[:, 2, 0] = cr * sp * cy + sr * sy
    r[:, 2, 1] = cr * sp * sy - sr * cy
    r[:, 2, 2] = cr * cp
    return r


def smooth_noise(rng, n, deg, corr_s):
    """Turbulence: white noise low-passed to a correlation time (s), scaled to `deg` RMS (rad)."""
    if deg == 0:
        return np.zeros(n)
    sos = butter(2, 1.0 / corr_s, fs=FS, output="sos")
    x = sosfiltfilt(sos, rng.standard_normal(n + 200))[100:-100]
    return np.deg2rad(deg) * x / x.std()


def turn(start_deg, end_deg):
    """A rate-one turn (3°/s) from one heading to another, banked 20° (yaw, pitch, roll; rad)."""
    sweep = (end_deg - start_deg + 180.0) % 360.0 - 180.0
    if sweep == 0:
        sweep = 180.0
    k = int(abs(sweep) / 3.0 * FS)
    s = np.arange(k) / k
    ease = s - np.sin(2 * np.pi * s) / (2 * np.pi)  # starts and ends at no rate
    bank = np.deg2rad(20.0) * np.sign(sweep) * np.sin(np.pi * s) ** 2
    return np.deg2rad(start_deg + sweep * ease), np.zeros(k), bank


def legs(plan, rng, turbulence):
    """Join legs (heading in degrees → (yaw offsets, pitch, roll) in rad) with turns, and add
    turbulence (degrees RMS: yaw, pitch, roll)."""
    yaw, pitch, roll = [], [], []
    for k, (heading, (dy, p, r)) in enumerate(plan):
        if k:
            for out, part in zip((yaw, pitch, roll), turn(plan[k - 1][0], heading)):
                out.append(part)
        yaw.append(np.deg2rad(heading) + dy)
        pitch.append(p)
        roll.append(r)
    yaw, pitch, roll = (np.concatenate(v) for v in (yaw, pitch, roll))
    n = len(yaw)
    return tuple(v + smooth_noise(rng, n, deg, 2.5)
                 for v, deg in zip((yaw, pitch, roll), turbulence))


def box_attitude(rng):
    """A calibration box: on each heading a quiet stretch, then rolls, pitches and yaws."""
    period, cycles = 6.0, 3
    m, quiet = int(period * cycles * FS), int(20 * FS)
    wave = np.sin(2 * np.pi * np.arange(m) / FS / period)
    zero, still = np.zeros(m), np.zeros(quiet)
    leg = (np.concatenate([still, zero, zero, np.deg2rad(5) * wave, still]),
           np.concatenate([still, zero, np.deg2rad(5) * wave, zero, still]),
           np.concatenate([still, np.deg2rad(10) * wave, zero, zero, still]))
    return legs([(h, leg) for h in (0.0, 90.0, 180.0, 270.0)], rng, (0.2, 0.2, 0.3))


def survey_attitude(rng):
    """Survey lines 120 s long on the four headings, with 0.5–1° of turbulence."""
    k = int(120 * FS)
    line = (np.zeros(k), np.zeros(k), np.zeros(k))
    level = rng.uniform(0.5, 1.0)
    return legs([(h, line) for h in (0, 180, 90, 270, 0, 180)], rng,
                (level * 0.6, level * 0.6, level))


def anomaly(rng, n, largest_nt):
    """Geology along track (slow: 0.002–0.03 Hz) and a diurnal drift (nT)."""
    t = np.arange(n) / FS
    out = np.zeros(n)
    for _ in range(6):
        f = rng.uniform(0.002, 0.03)
        amplitude = rng.uniform(0.2, 1.0) * largest_nt / 3
        out += amplitude * np.sin(2 * np.pi * f * t + rng.uniform(0, 6.3))
    return out + 3.0 * np.sin(2 * np.pi * t / 3600 + rng.uniform(0, 6.3))


@dataclass
class Installation:
    kind: Kind
    permanent: np.ndarray  # nT, body frame
    induced: np.ndarray  # 3 × 3, dimensionless
    eddy: np.ndarray  # 3 × 3, s
    earth_ned: np.ndarray  # nT
    flux_offset: np.ndarray  # nT: what the fluxgate sees of the aircraft, x, y, z
    current: np.ndarray  # nT per A, body frame: the field of the current in column cur_1

    @staticmethod
    def draw(kind, seed):
        rng = np.random.default_rng(seed)
        inc = np.deg2rad(rng.uniform(25, 75))
        dec = np.deg2rad(rng.uniform(-15, 15))
        f = rng.uniform(45000, 58000)
        earth = f * np.array([np.cos(inc) * np.cos(dec), np.cos(inc) * np.sin(dec), np.sin(inc)])
        induced = kind.induced * rng.uniform(-1, 1, (3, 3)) + kind.trace / 3 * np.eye(3)
        parts = (kind.permanent_nt * rng.uniform(-1, 1, 3), induced,
                 kind.eddy_s * rng.uniform(-1, 1, (3, 3)), earth,
                 kind.flux_offset_nt * rng.uniform(-1, 1, 3))
        # Drawn last, and only when there is one: the table's installations stay as they were.
        current = (kind.current_nt_per_a * rng.uniform(-1, 1, 3) if kind.current_nt_per_a
                   else np.zeros(3))
        return Installation(kind, *parts, current)

    def fly(self, attitude, rng, geology_nt=20.0):
        """The flight's columns and the truth: (DataFrame, earth's scalar field in nT)."""
        yaw, pitch, roll = attitude
        n = len(yaw)
        r = rotation(yaw, pitch, roll)
        scale = 1.0 + anomaly(rng, n, geology_nt) / np.linalg.norm(self.earth_ned)
        earth_body = np.einsum("nij,j->ni", r, self.earth_ned) * scale[:, None]
        rate = np.gradient(earth_body, 1.0 / FS, axis=0)
        aircraft = self.permanent + earth_body @ self.induced.T + rate @ self.eddy.T
        truth = np.linalg.norm(earth_body, axis=1)
        scalar_noise = 0.01 * rng.standard_normal(n)
        flux = earth_body + self.flux_offset + self.kind.flux_noise_nt * rng.standard_normal((n, 3))
        amps = self.current_amps(rng, n) if self.current.any() else None
        if amps is not None:
            aircraft = aircraft + amps[:, None] * self.current
        scalar = np.linalg.norm(earth_body + aircraft, axis=1) + scalar_noise
        frame = pd.DataFrame({
            "tt": np.arange(n) / FS,
            "ins_roll": np.rad2deg(roll), "ins_pitch": np.rad2deg(pitch),
            "ins_yaw": np.rad2deg(yaw) % 360,
            "mag_1_uc": scalar,
            "flux_a_x": flux[:, 0], "flux_a_y": flux[:, 1], "flux_a_z": flux[:, 2],
        })
        if amps is not None:
            frame["cur_1"] = amps
        return frame, truth, earth_body

    @staticmethod
    def current_amps(rng, n):
        """A switched load (A): a few amperes that step at random every 1–4 s, and wander."""
        steps = np.repeat(rng.uniform(2, 12, n // 10 + 1), rng.integers(10, 40, n // 10 + 1))
        return steps[:n] + smooth_noise(rng, n, 1.0, 5.0) * 180 / np.pi

    def exact_oracle(self, box_scalar, box_earth, survey_earth, box_vector=None,
                     survey_vector=None, currents=(None, None), earth_known=True):
        """The true model itself, `|B + p + A·B + E·dB/dt| − |B|` with A traceless, fitted by
        nonlinear least squares to the box with the earth's field `box_earth` known (body
        frame, nT); returns the aircraft's field it predicts on `survey_earth` (nT). With
        `box_vector` and `survey_vector` (the fluxgate's readings, nT) B is read from them
        instead, as any compensation must, and only the earth's magnitude is known. With an
        installation's current, `currents` holds the box's and the survey's (A). With
        `earth_known` false the earth's magnitude is not known either: the fit's target is the
        scalar less the fluxgate's magnitude, all that the data tell."""
        box_vector = box_earth if box_vector is None else box_vector
        survey_vector = survey_earth if survey_vector is None else survey_vector
        kind = self.kind
        has = (kind.permanent_nt > 0, kind.induced > 0 or kind.trace != 0, kind.eddy_s > 0)
        traceless = [np.eye(3)[[i]].T @ np.eye(3)[[j]] for i in range(3) for j in range(3)
                     if (i, j) != (2, 2)]
        for k in (0, 4):  # xx, yy: their trace taken out with zz
            traceless[k] = traceless[k] - np.diag([0, 0, 1.0])

        def unpack(q):
            p = q[0:3] if has[0] else np.zeros(3)
            a = sum(c * m for c, m in zip(q[3:11], traceless)) if has[1] else np.zeros((3, 3))
            e = q[11:20].reshape(3, 3) if has[2] else np.zeros((3, 3))
            return p, a, e, q[20], q[21:24] if len(q) > 21 else np.zeros(3)

        def field(q, earth, amps):
            p, a, e, c, k = unpack(q)
            rate = np.gradient(earth, 1.0 / FS, axis=0)
            total = earth + p + earth @ a.T + rate @ e.T
            if amps is not None:
                total = total + amps[:, None] * k
            return np.linalg.norm(total, axis=1) - np.linalg.norm(earth, axis=1) + c

        from scipy.optimize import least_squares
        scale = np.r_[np.full(3, 100.0), np.full(8, 1e-3), np.full(9, 1e-4), 1.0, np.ones(3)]
        scale = scale[:21] if currents[0] is None else scale
        target = box_scalar - np.linalg.norm(box_earth if earth_known else box_vector, axis=1)
        fitted = least_squares(lambda q: field(q * scale, box_vector, currents[0]) - target,
                               np.zeros(len(scale)), x_scale=1.0, method="lm")
        return field(fitted.x * scale, survey_vector, currents[1])

    def oracle_design(self, earth_body):
        """The true model's form in the true earth field: permanent, traceless induced, eddy."""
        norm = np.linalg.norm(earth_body, axis=1)
        u = earth_body / norm[:, None]
        du = np.gradient(u, 1.0 / FS, axis=0)
        cols = [np.ones(len(u))]
        if self.kind.permanent_nt:
            cols += [u[:, i] for i in range(3)]
        if self.kind.induced or self.kind.trace:
            cols += [norm * u[:, i] * u[:, j] for i, j in ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2))]
        if self.kind.eddy_s:
            cols += [norm * u[:, i] * du[:, j] for i in range(3) for j in range(3)]
        return np.column_stack(cols)


def band_std(x):
    sos = butter(4, list(BAND_HZ), btype="bandpass", fs=FS, output="sos")
    return float(np.std(sosfiltfilt(sos, x)[TRIM:-TRIM]))


def scores(compensated, truth):
    d = compensated - truth
    return {"overall": float(np.std(d - d.mean())), "band": band_std(d)}


def run_tolles(tolles, work, box_csv, survey_csv, fit_args):
    model, out = work / "model.json", work / "out.csv"
    fit = subprocess.run([tolles, "fit", str(box_csv), "--scalar", "mag_1_uc", "--vector",
                          "flux_a", "--out", str(model), *fit_args], capture_output=True, text=True)
    if fit.returncode != 0:
        return None, "refused: " + (fit.stderr.strip().splitlines() or ["?"])[-1], None
    subprocess.run([tolles, "compensate", str(survey_csv), "--model", str(model), "--out",
                    str(out), "--uncertainty"], check=True, capture_output=True, text=True)
    spec = json.loads(model.read_text())["fits"][0]
    terms = spec["settings"]["design"]["terms"]
    levels = "levels" if spec["diagnostics"].get("levels") else "no levels"
    grade = (spec.get("verdict") or {}).get("grade", "?")
    note = f"{grade}; {terms}, {spec.get('magnitude', 'linear')}, {levels}"
    frame = pd.read_csv(out)
    return frame["mag_1_c"].to_numpy(), note, frame["mag_1_c_sigma"].to_numpy()


def one(index, kind, tolles, work, fit_args):
    inst = Installation.draw(kind, 1000 + index)
    rng = np.random.default_rng(2000 + index)
    box, _, box_earth = inst.fly(box_attitude(rng), rng)
    survey, truth, survey_earth = inst.fly(survey_attitude(rng), rng)
    box_csv, survey_csv = work / "box.csv", work / "survey.csv"
    box.to_csv(box_csv, index=False)
    survey.to_csv(survey_csv, index=False)
    np.savetxt(work / "truth.txt", truth)
    y = survey["mag_1_uc"].to_numpy()
    row = {"raw": scores(y, truth)}

    flux = lambda f: [f[f"flux_a_{c}"].to_numpy() for c in "xyz"]  # noqa: E731
    beta = fit_arrays(box["mag_1_uc"].to_numpy(), flux(box), FS)
    row["magnav"] = scores(peer_compensated(y, flux(survey), beta), truth)

    a = inst.oracle_design(box_earth)
    target = box["mag_1_uc"].to_numpy() - np.linalg.norm(box_earth, axis=1)
    coef, *_ = np.linalg.lstsq(a, target, rcond=None)
    row["linear oracle"] = scores(y - inst.oracle_design(survey_earth) @ coef, truth)
    row["oracle"] = scores(y - inst.exact_oracle(box["mag_1_uc"].to_numpy(), box_earth,
                                                 survey_earth), truth)
    vector = lambda f: f[[f"flux_a_{c}" for c in "xyz"]].to_numpy()  # noqa: E731
    # The offset is what a sphere fit of the fluxgate's own readings finds to a few nT.
    fluxgate_oracle = inst.exact_oracle(box["mag_1_uc"].to_numpy(), box_earth, survey_earth,
                                        vector(box) - inst.flux_offset,
                                        vector(survey) - inst.flux_offset)
    row["fluxgate oracle"] = scores(y - fluxgate_oracle, truth)

    compensated, note, sigma = run_tolles(tolles, work, box_csv, survey_csv, fit_args)
    if compensated is not None:
        row["tolles"] = scores(compensated, truth)
        error = compensated - truth
        error -= np.nanmean(error)
        row["sigma_coverage"] = float(np.mean(np.abs(error) <= sigma))
        row["sigma_median_nt"] = float(np.nanmedian(sigma))
    row["note"] = note
    return row


def geomean(values):
    values = [v for v in values if math.isfinite(v) and v > 0]
    return math.exp(sum(map(math.log, values)) / len(values)) if values else float("nan")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tolles", default=str(ROOT / "target" / "release" / "tolles"))
    parser.add_argument("--only", type=int, action="append", help="installation number (1–15)")
    parser.add_argument("--fit-args", default="", help="more `tolles fit` flags, one string")
    parser.add_argument("--json", help="write every row to this file")
    parser.add_argument("--keep", help="keep each installation's box, survey and model in DIR/N")
    args = parser.parse_args()

    rows = []
    print("| # | installation | raw overall | MagNav | oracle | fluxgate oracle | **tolles** | "
          "×oracle | ×fluxgate oracle | band: raw | MagNav | oracle | fluxgate oracle | "
          "**tolles** | ×oracle | ×fluxgate oracle | σ median | σ coverage | tolles model |")
    print("|" + "---|" * 19)
    with tempfile.TemporaryDirectory(prefix="tolles-inst-") as tmp:
        for i, kind in enumerate(KINDS, start=1):
            if args.only and i not in args.only:
                continue
            work = Path(args.keep) / str(i) if args.keep else Path(tmp)
            work.mkdir(parents=True, exist_ok=True)
            row = one(i, kind, args.tolles, work, args.fit_args.split())
            row.update(number=i, kind=kind.name)
            rows.append(row)
            t = row.get("tolles", {"overall": float("nan"), "band": float("nan")})
            cells = []
            for k in ("overall", "band"):
                floor = row["fluxgate oracle"][k]
                cells += [row["raw"][k], row["magnav"][k], row["oracle"][k], floor, t[k],
                          t[k] / row["oracle"][k], t[k] / floor]
            cells += [row.get("sigma_median_nt", float("nan")),
                      row.get("sigma_coverage", float("nan"))]
            print(f"| {i} | {kind.name} | " + " | ".join(f"{v:.3g}" for v in cells)
                  + f" | {row['note']} |", flush=True)
    print()
    for k in ("overall", "band"):
        for other in ("oracle", "fluxgate oracle", "magnav", "raw"):
            ratios = [r["tolles"][k] / r[other][k] for r in rows if "tolles" in r]
            if ratios:
                print(f"{k}: tolles / {other}: geometric mean {geomean(ratios):.3f}, "
                      f"worst {max(ratios):.3f}")
    covered = [r["sigma_coverage"] for r in rows if "sigma_coverage" in r]
    if covered:
        inside = sum(0.45 <= c <= 0.90 for c in covered)
        print(f"σ coverage (share of survey rows with |error − mean| ≤ σ): median "
              f"{np.median(covered):.2f}, from {min(covered):.2f} to {max(covered):.2f}; "
              f"45–90 % on {inside} of {len(covered)}")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

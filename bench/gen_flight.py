"""Writes a synthetic maneuvering calibration flight for the speed benchmark.

    python gen_flight.py N OUT.csv [--h5 OUT.h5]

A 10 Hz flight of N samples over a uniform earth field (50 000 nT, inclination 65°,
declination -5°) plus slow "geology": the aircraft flies a box of headings 0, 90, 180, 270°
and rolls, pitches and yaws through a few degrees at 0.1–0.2 Hz. The fluxgate (flux_a_x/y/z,
body frame FRD, nT) sees the earth field; the scalar (mag_1_uc, nT) sees its magnitude plus a
Tolles-Lawson aircraft field (permanent, induced and eddy terms) and 0.05 nT of noise.
Columns: tt (s), mag_1_uc, flux_a_x, flux_a_y, flux_a_z, truth_earth (the scalar without the
aircraft or noise, nT, to score the compensations). Only the benchmark reads these files.
"""

import argparse

import numpy as np
import pandas as pd

FS_HZ = 10.0


def attitude(t):
    """Yaw, pitch, roll (radians) of a box flown over and over with maneuvers on each leg."""
    leg = (t // 300.0).astype(np.int64)  # 5-minute legs
    heading = np.deg2rad(90.0 * (leg % 4))
    kind = (t // 60.0).astype(np.int64) % 3  # roll, pitch, yaw minute by minute
    w = 2 * np.pi
    roll = np.deg2rad(10.0) * np.sin(w * 0.15 * t) * (kind == 0)
    pitch = np.deg2rad(5.0) * np.sin(w * 0.12 * t) * (kind == 1)
    yaw = heading + np.deg2rad(4.0) * np.sin(w * 0.10 * t) * (kind == 2)
    wobble = np.deg2rad(0.5)
    roll += wobble * np.sin(w * 0.43 * t + 0.3)
    pitch += wobble * np.sin(w * 0.31 * t + 1.1)
    return yaw, pitch, roll


def body_field(yaw, pitch, roll, earth_ned):
    """The NED field seen in the body frame (yaw-pitch-roll, ZYX)."""
    n, e, d = earth_ned
    cy, sy = np.cos(yaw), np.sin(yaw)
    cp, sp = np.cos(pitch), np.sin(pitch)
    cr, sr = np.cos(roll), np.sin(roll)
    # Rz(yaw)^T
    x1 = cy * n + sy * e
    y1 = -sy * n + cy * e
    z1 = d
    # Ry(pitch)^T
    x2 = cp * x1 - sp * z1
    z2 = sp * x1 + cp * z1
    # Rx(roll)^T
    y3 = cr * y1 + sr * z2
    z3 = -sr * y1 + cr * z2
    return np.stack([x2, y3, z3])


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("n", type=int)
    parser.add_argument("out")
    parser.add_argument("--h5", help="also write the columns as an HDF5 file (1-D datasets, dt)")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    n = args.n
    t = np.arange(n) / FS_HZ
    yaw, pitch, roll = attitude(t)
    inc, dec = np.deg2rad(65.0), np.deg2rad(-5.0)
    geology = 1.0 + (30.0 * np.sin(2 * np.pi * t / 700.0) + 12.0 * np.sin(2 * np.pi * t / 91.0)) / 50_000.0
    earth = 50_000.0 * np.array([np.cos(inc) * np.cos(dec), np.cos(inc) * np.sin(dec), np.sin(inc)])
    b = body_field(yaw, pitch, roll, earth) * geology  # 3 x n, nT
    del yaw, pitch, roll
    magnitude = np.sqrt((b * b).sum(axis=0))
    unit = b / magnitude
    db = np.gradient(b, axis=1) * FS_HZ  # nT/s
    permanent = np.array([12.0, -7.0, 25.0])  # nT
    # No zz terms, so both the 18-term (MagNav) and the 16-term (tolles' default) models hold
    # the truth exactly and their errors are estimation errors only.
    induced = np.array([[2e-3, 3e-4, -5e-4], [3e-4, -1e-3, 2e-4], [-5e-4, 2e-4, 0.0]])
    eddy = np.array([[4e-3, -1e-3, 0.0], [5e-4, -1e-3, 1e-3], [-2e-3, 1e-3, 0.0]])  # s
    aircraft = permanent @ unit
    aircraft += np.einsum("in,ij,jn->n", unit, induced, b)
    aircraft += np.einsum("in,ij,jn->n", unit, eddy, db)
    del db
    scalar = magnitude + aircraft + 0.05 * rng.standard_normal(n)
    flux = b + 0.2 * rng.standard_normal((3, n))
    columns = {
        "tt": t,
        "mag_1_uc": scalar,
        "flux_a_x": flux[0],
        "flux_a_y": flux[1],
        "flux_a_z": flux[2],
        "truth_earth": magnitude,
    }
    frame = pd.DataFrame(columns)
    frame.to_csv(args.out, index=False, float_format="%.4f")
    if args.h5:
        import h5py

        with h5py.File(args.h5, "w") as h5:
            for name, values in columns.items():
                h5.create_dataset(name, data=np.round(values, 4))
            h5.create_dataset("dt", data=1.0 / FS_HZ)


if __name__ == "__main__":
    main()

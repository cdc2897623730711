"""The benchmark's second peer: the `deinterf` package (PyPI) on the same files.

    python peer_deinterf.py fit FLIGHT.csv MODEL.pkl --config default|magnav
    python peer_deinterf.py compensate FLIGHT.csv MODEL.pkl OUT.csv

Its own Tolles-Lawson procedure, called through its documented API (TollesLawson.fit /
transform on a DataIoC holding a MagVector); the fitted estimator is pickled between the two
steps as tolles keeps its model in a file. Configurations:
- default: deinterf's defaults (16 terms, standardised columns, RidgeCV over 13 alphas with
  10-fold CV), the counterpart of tolles' defaults;
- magnav: 18 terms, unscaled columns, Ridge(alpha=0.001), the counterpart of MagNav settings.
deinterf's filter is fixed at 0.1–0.6 Hz (order 4, filtfilt in transfer-function form), it
does not trim, and its induced/eddy columns are |B|·B̂i·B̂j and |B|·B̂i·dB̂j (np.gradient),
so its compensated values differ from tolles' by design; the benchmark reports by how much.
"""

import argparse
import pickle

import numpy as np
import pandas as pd
from sklearn.linear_model import Ridge

from deinterf.compensator.tmi.linear import Terms, TollesLawson
from deinterf.foundation.sensors import MagVector, Tmi
from deinterf.utils.data_ioc import DataIoC


def read(path):
    frame = pd.read_csv(path, engine="c")
    vector = MagVector(
        bx=frame["flux_a_x"].to_numpy(),
        by=frame["flux_a_y"].to_numpy(),
        bz=frame["flux_a_z"].to_numpy(),
    )
    return frame, DataIoC().add(vector), Tmi(tmi=frame["mag_1_uc"].to_numpy())


def fit(args):
    frame, data, tmi = read(args.flight)
    fs = int(round(1.0 / np.median(np.diff(frame["tt"].to_numpy()))))
    if args.config == "default":
        compensator = TollesLawson(terms=Terms.Terms_16, sampling_rate=fs)
    else:
        compensator = TollesLawson(
            terms=Terms.Terms_18,
            norm=False,
            sampling_rate=fs,
            estimator=Ridge(alpha=0.001, fit_intercept=False),
        )
    compensator.fit(data, tmi)
    with open(args.model, "wb") as f:
        pickle.dump(compensator, f)


def compensate(args):
    frame, data, tmi = read(args.flight)
    with open(args.model, "rb") as f:
        compensator = pickle.load(f)
    frame["mag_1_c"] = np.asarray(compensator.transform(data, tmi))
    frame.to_csv(args.out, index=False)


def main():
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers(dest="command", required=True)
    f = sub.add_parser("fit")
    f.add_argument("flight")
    f.add_argument("model")
    f.add_argument("--config", choices=["default", "magnav"], default="default")
    c = sub.add_parser("compensate")
    c.add_argument("flight")
    c.add_argument("model")
    c.add_argument("out")
    args = parser.parse_args()
    fit(args) if args.command == "fit" else compensate(args)


if __name__ == "__main__":
    main()

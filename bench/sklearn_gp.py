#!/usr/bin/env python3
"""The peer for bench/compare_sklearn.sh: scikit-learn's GaussianProcessRegressor
on the same tared electrode data as `tactile_force eval`.

  split: tare each trial on its first rows, write train.csv (a seeded random
         subset of trials 1-8 of every set) and test.csv (trials 9-10).
  fit:   fit ConstantKernel * RBF + WhiteKernel (isotropic or ARD) on train.csv,
         print one JSON line: fit time, RMSE per axis on test.csv, time per
         log-likelihood+gradient evaluation, single-sample predict latency.
"""
import argparse
import json
import time

import numpy as np

ELECTRODES = [f"e{i}" for i in range(1, 20)]


def read(path):
    with open(path) as f:
        header = f.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return header, data


def split(args):
    header, data = read(args.data)
    col = {h: i for i, h in enumerate(header)}
    e = [col[c] for c in ELECTRODES]
    keys = data[:, [col["set"], col["trial"]]]
    for key in np.unique(keys, axis=0):
        rows = np.where((keys == key).all(axis=1))[0]
        data[np.ix_(rows, e)] -= data[rows[: args.tare_samples]][:, e].mean(axis=0)
    trial = data[:, col["trial"]]
    train = np.where(trial <= 8)[0]
    test = np.where(trial >= 9)[0]
    rng = np.random.RandomState(args.seed)
    train = np.sort(rng.choice(train, size=min(args.n_train, len(train)), replace=False))
    keep = ELECTRODES + args.axes.split(",")
    idx = [col[c] for c in keep]
    for name, rows in (("train", train), ("test", test)):
        np.savetxt(f"{args.out_dir}/{name}.csv", data[np.ix_(rows, idx)], delimiter=",",
                   header=",".join(keep), comments="", fmt="%.6f")
    print(f"train {len(train)} rows, test {len(test)} rows, tared on {args.tare_samples} rows per trial")


def fit(args):
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel
    from sklearn.preprocessing import StandardScaler

    axes = args.axes.split(",")
    _, train = read(f"{args.dir}/train.csv")
    _, test = read(f"{args.dir}/test.csv")
    d = len(ELECTRODES)
    scaler = StandardScaler().fit(train[:, :d])
    xtr, ytr = scaler.transform(train[:, :d]), train[:, d:]
    xte, yte = scaler.transform(test[:, :d]), test[:, d:]
    ls = np.ones(d) if args.kernel == "ard" else 1.0
    kernel = ConstantKernel(1.0) * RBF(length_scale=ls) + WhiteKernel(1e-2)
    gpr = GaussianProcessRegressor(kernel=kernel, normalize_y=True, random_state=0)
    t0 = time.perf_counter()
    gpr.fit(xtr, ytr)
    fit_s = time.perf_counter() - t0

    pred = gpr.predict(xte)
    rmse = {a: float(np.sqrt(np.mean((pred[:, j] - yte[:, j]) ** 2))) for j, a in enumerate(axes)}
    theta = gpr.kernel_.theta
    evals = []
    for _ in range(3):
        t0 = time.perf_counter()
        gpr.log_marginal_likelihood(theta, eval_gradient=True)
        evals.append(time.perf_counter() - t0)
    lat = []
    for i in range(args.latency_samples):
        x = xte[i % len(xte)][None, :]
        t0 = time.perf_counter()
        gpr.predict(x, return_std=True)
        lat.append(time.perf_counter() - t0)
    lat = np.array(lat) * 1e6
    print(json.dumps({
        "kernel": args.kernel, "n_train": len(xtr), "fit_s": fit_s, "rmse": rmse,
        "lml_grad_eval_s": float(np.median(evals)),
        "predict_one_median_us": float(np.median(lat)),
        "predict_one_p99_us": float(np.percentile(lat, 99)),
        "fitted_kernel": str(gpr.kernel_),
    }))


def main():
    p = argparse.ArgumentParser(description=__doc__)
    sub = p.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("split")
    s.add_argument("--data", required=True)
    s.add_argument("--out-dir", required=True)
    s.add_argument("--axes", default="fx,fy,fz")
    s.add_argument("--n-train", type=int, default=2000)
    s.add_argument("--tare-samples", type=int, default=50)
    s.add_argument("--seed", type=int, default=0)
    f = sub.add_parser("fit")
    f.add_argument("--dir", required=True)
    f.add_argument("--axes", default="fx,fy,fz")
    f.add_argument("--kernel", choices=["iso", "ard"], default="iso")
    f.add_argument("--latency-samples", type=int, default=500)
    args = p.parse_args()
    {"split": split, "fit": fit}[args.cmd](args)


if __name__ == "__main__":
    main()

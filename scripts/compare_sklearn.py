#!/usr/bin/env python3
"""GP training speed and accuracy: tactile_force against scikit-learn's
GaussianProcessRegressor, measured in the same run on the same rows.

Data: a `tactile_force collect` CSV; every trial is tared on its first 50 rows
(as `tactile_force` does), n_train rows are drawn (seeded) from trials 1-8 of
every set and the test rows are trials 9-10. Both tools get exactly these
rows: ours through `eval --train --test --tare-samples 0`.

scikit-learn runs the same kernel family, ConstantKernel * RBF + WhiteKernel
(isotropic or ARD), on standardised inputs with normalize_y, in two ways,
each against the same model of ours:
  shared:   one regressor for the 3 outputs (what a user would write; the
            outputs then share hyperparameters), against our
            `--shared-hyper` (one set of hyperparameters for every axis);
  per-axis: one regressor per output, against our default (a GP per axis
            with its own hyperparameters).
Prints fit times, RMSE per axis, the speed-up, sklearn's time per
log-likelihood+gradient evaluation and its single-sample predict latency.
Then, with --whole, each tool's whole process, --repeats times (medians):
our `eval` run (start, read, fit, predict, exit) against a fresh Python
process that imports scikit-learn, reads the same files, fits and predicts.
Every figure is printed with the load average of the moment (the machine
may be shared: the two tools alternate, so both see the same load).
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import time

import numpy as np

ELECTRODES = [f"e{i}" for i in range(1, 20)]


def read(path):
    with open(path) as f:
        header = f.readline().strip().split(",")
    return header, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


def split(data_path, out_dir, axes, n_train, tare_samples=50, seed=0):
    header, data = read(data_path)
    col = {h: i for i, h in enumerate(header)}
    e = [col[c] for c in ELECTRODES]
    keys = data[:, [col["set"], col["trial"]]]
    for key in np.unique(keys, axis=0):
        rows = np.where((keys == key).all(axis=1))[0]
        data[np.ix_(rows, e)] -= data[rows[:tare_samples]][:, e].mean(axis=0)
    trial = data[:, col["trial"]]
    train = np.where(trial <= 8)[0]
    test = np.where(trial >= 9)[0]
    rng = np.random.RandomState(seed)
    train = np.sort(rng.choice(train, size=min(n_train, len(train)), replace=False))
    keep = ELECTRODES + axes
    idx = [col[c] for c in keep]
    paths = {}
    for name, rows in (("train", train), ("test", test)):
        paths[name] = f"{out_dir}/{name}.csv"
        np.savetxt(paths[name], data[np.ix_(rows, idx)], delimiter=",",
                   header=",".join(keep), comments="", fmt="%.6f")
    print(f"data: {data_path}; train {len(train)} rows (trials 1-8), test {len(test)} rows "
          f"(trials 9-10), tared on {tare_samples} rows per trial")
    return paths


def ours(binary, paths, kernel, mode, extra):
    out = subprocess.run(ours_cmd(binary, paths, kernel, mode, extra), check=True, capture_output=True,
                         text=True).stdout
    gp = json.loads(out.strip().splitlines()[-1])["gp"]
    return gp["fit_s"], gp["rmse"]


def sklearn_fit(paths, axes, kernel_name, per_axis, latency_samples):
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel
    from sklearn.preprocessing import StandardScaler

    _, train = read(paths["train"])
    _, test = read(paths["test"])
    d = len(ELECTRODES)
    scaler = StandardScaler().fit(train[:, :d])
    xtr, ytr = scaler.transform(train[:, :d]), train[:, d:]
    xte, yte = scaler.transform(test[:, :d]), test[:, d:]

    def new():
        ls = np.ones(d) if kernel_name == "ard" else 1.0
        kernel = ConstantKernel(1.0) * RBF(length_scale=ls) + WhiteKernel(1e-2)
        return GaussianProcessRegressor(kernel=kernel, normalize_y=True, random_state=0)

    targets = [[j] for j in range(len(axes))] if per_axis else [list(range(len(axes)))]
    t0 = time.perf_counter()
    models = [new().fit(xtr, ytr[:, cols] if len(cols) > 1 else ytr[:, cols[0]]) for cols in targets]
    fit_s = time.perf_counter() - t0
    pred = np.column_stack([m.predict(xte) for m in models])
    rmse = {a: float(np.sqrt(np.mean((pred[:, j] - yte[:, j]) ** 2))) for j, a in enumerate(axes)}

    m = models[0]
    evals = []
    for _ in range(3):
        t0 = time.perf_counter()
        m.log_marginal_likelihood(m.kernel_.theta, eval_gradient=True)
        evals.append(time.perf_counter() - t0)
    lat = []
    for i in range(latency_samples):
        x = xte[i % len(xte)][None, :]
        t0 = time.perf_counter()
        for model in models:
            model.predict(x, return_std=True)
        lat.append(time.perf_counter() - t0)
    lat = np.array(lat) * 1e6
    return fit_s, rmse, float(np.median(evals)), float(np.median(lat)), float(np.percentile(lat, 99))


def ours_cmd(binary, paths, kernel, mode, extra):
    """Our eval run of the model that scikit-learn's `mode` fits, with `extra` options."""
    shared = ["--shared-hyper"] if mode == "shared" else []
    return [binary, "eval", "--train", paths["train"], "--test", paths["test"], "--tare-samples", "0",
            "--max-train", "1000000", "--kernel", kernel, "--channels", "electrodes", "--no-nn",
            "--json"] + shared + extra


def load():
    return "load {:.1f} {:.1f} {:.1f}".format(*os.getloadavg())


def sklearn_whole_process(train, test, kernel_name, per_axis):
    """One whole scikit-learn run (the body of a fresh process)."""
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel
    from sklearn.preprocessing import StandardScaler

    _, tr = read(train)
    _, te = read(test)
    d = len(ELECTRODES)
    scaler = StandardScaler().fit(tr[:, :d])
    k = tr.shape[1] - d
    targets = [[j] for j in range(k)] if per_axis else [list(range(k))]
    preds = []
    for cols in targets:
        ls = np.ones(d) if kernel_name == "ard" else 1.0
        kern = ConstantKernel(1.0) * RBF(length_scale=ls) + WhiteKernel(1e-2)
        m = GaussianProcessRegressor(kernel=kern, normalize_y=True, random_state=0)
        y = tr[:, d:][:, cols]
        m.fit(scaler.transform(tr[:, :d]), y if len(cols) > 1 else y[:, 0])
        preds.append(m.predict(scaler.transform(te[:, :d])))
    pred = np.column_stack(preds)
    print(json.dumps([float(np.sqrt(np.mean((pred[:, j] - te[:, d + j]) ** 2))) for j in range(k)]))


def whole(binary, paths, kernel, modes, repeats, extra):
    """Whole process against whole process, alternated, medians."""
    times = {}
    for _ in range(repeats):
        for mode in modes:
            t0 = time.perf_counter()
            subprocess.run(ours_cmd(binary, paths, kernel, mode, extra), check=True, capture_output=True)
            times.setdefault(("ours", mode), []).append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            subprocess.run([sys.executable, __file__, "--whole-sklearn", paths["train"], paths["test"],
                            kernel, mode], check=True, capture_output=True)
            times.setdefault(("sklearn", mode), []).append(time.perf_counter() - t0)
    runs = lambda ts: ", ".join(f"{t:.2f}" for t in ts)
    print(f"whole process, {repeats} runs each, medians ({load()}):")
    for mode in modes:
        ours_t, theirs_t = times[("ours", mode)], times[("sklearn", mode)]
        o, s = statistics.median(ours_t), statistics.median(theirs_t)
        print(f"  {mode}: tactile_force {o:.2f} s (runs {runs(ours_t)}), scikit-learn {s:.2f} s "
              f"(runs {runs(theirs_t)}) -> tactile_force is {s / o:.1f}x faster")


def fmt(rmse):
    return " ".join(f"{a} {v:.4f}" for a, v in rmse.items())


def main():
    if len(sys.argv) == 6 and sys.argv[1] == "--whole-sklearn":
        sklearn_whole_process(sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5] == "per-axis")
        return
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--bin", required=True, help="the tactile_force binary")
    p.add_argument("--data", required=True, help="a collect CSV")
    p.add_argument("--out-dir", required=True)
    p.add_argument("--axes", default="fx,fy,fz")
    p.add_argument("--n-train", type=int, default=2000)
    p.add_argument("--kernels", default="iso,ard")
    p.add_argument("--sklearn", default="shared,per-axis", help="shared, per-axis or both")
    p.add_argument("--latency-samples", type=int, default=300)
    p.add_argument("--whole", action="store_true", help="time whole processes (medians of --repeats)")
    p.add_argument("--repeats", type=int, default=9)
    p.add_argument("--ours-args", default="", help="more options of our eval, e.g. '--restarts 1'")
    args = p.parse_args()
    axes = args.axes.split(",")
    paths = split(args.data, args.out_dir, axes, args.n_train)
    for kernel in args.kernels.split(","):
        print(f"\n== kernel {kernel}, n_train {args.n_train}, {len(ELECTRODES)} features, axes {args.axes} ==")
        for mode in args.sklearn.split(","):
            fit_s, rmse = ours(args.bin, paths, kernel, mode, args.ours_args.split())
            print(f"{'tactile_force (' + mode + ')':<26} fit {fit_s:8.2f} s   RMSE {fmt(rmse)}   ({load()})")
            s_fit, s_rmse, s_eval, s_med, s_p99 = sklearn_fit(
                paths, axes, kernel, mode == "per-axis", args.latency_samples)
            print(f"{'scikit-learn (' + mode + ')':<26} fit {s_fit:8.2f} s   RMSE {fmt(s_rmse)}   "
                  f"-> tactile_force is {s_fit / fit_s:.1f}x faster ({load()})")
            print(f"{'':<26} {s_eval * 1e3:.0f} ms per likelihood+gradient evaluation; "
                  f"predict one sample, mean+std, all axes: median {s_med:.0f} us, p99 {s_p99:.0f} us")
        if args.whole:
            whole(args.bin, paths, kernel, args.sklearn.split(","), args.repeats, args.ours_args.split())


if __name__ == "__main__":
    main()

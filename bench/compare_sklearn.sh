#!/usr/bin/env bash
# GP fit and prediction speed against scikit-learn, measured in the same run
# on the same data: `collect --seed 1`, each trial tared on its first 50 rows,
# n_train = 2000 rows drawn from trials 1-8 of every set, tested on trials 9-10,
# 19 electrode features, 3 force outputs.
#
#   bench/compare_sklearn.sh [iso|ard|both]     (default: both; ard takes ~15 min for sklearn)
#
# Prints, per kernel: both fit times and their ratio, both RMSEs, sklearn's time
# per log-likelihood+gradient evaluation; then our criterion figures (Cholesky
# at n = 2000, likelihood+gradient, single-sample prediction) and sklearn's
# single-sample predict latency.
set -euo pipefail
cd "$(dirname "$0")/.."
kernels=${1:-both}
[ "$kernels" = both ] && kernels="iso ard"
out=target/bench-sklearn
venv=${VENV:-target/bench-venv}
mkdir -p "$out"

if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet --upgrade pip
  "$venv/bin/pip" install --quiet scikit-learn numpy
fi
py="$venv/bin/python"
echo "scikit-learn $("$py" -c 'import sklearn; print(sklearn.__version__)'), numpy $("$py" -c 'import numpy; print(numpy.__version__)')"

cargo build --release --quiet
bin=target/release/tactile_force
[ -f "$out/seed1.csv" ] || "$bin" collect --seed 1 --out "$out/seed1.csv"
"$py" bench/sklearn_gp.py split --data "$out/seed1.csv" --out-dir "$out" --n-train 2000

field() { "$py" -c "import json,sys; d=json.loads(sys.stdin.read().strip().splitlines()[-1]); print(eval(sys.argv[1]))" "$1"; }

for k in $kernels; do
  echo
  echo "== kernel: $k =="
  ours=$("$bin" eval --train "$out/train.csv" --test "$out/test.csv" --tare-samples 0 \
           --max-train 2000 --kernel "$k" --no-nn --json 2>/dev/null)
  theirs=$("$py" bench/sklearn_gp.py fit --dir "$out" --kernel "$k")
  our_fit=$(echo "$ours" | field 'd["gp"]["fit_s"]')
  their_fit=$(echo "$theirs" | field 'd["fit_s"]')
  echo "tactile_force fit: $(printf %.2f "$our_fit") s   RMSE $(echo "$ours" | field '{a: round(v, 4) for a, v in d["gp"]["rmse"].items()}')"
  echo "scikit-learn  fit: $(printf %.2f "$their_fit") s   RMSE $(echo "$theirs" | field '{a: round(v, 4) for a, v in d["rmse"].items()}')"
  echo "fit speed-up: $("$py" -c "print(f'{$their_fit / $our_fit:.1f}x')")"
  echo "scikit-learn: $(echo "$theirs" | field 'f"{d[\"lml_grad_eval_s\"]:.3f} s per likelihood+gradient evaluation; predict one sample (mean+std) median {d[\"predict_one_median_us\"]:.0f} us, p99 {d[\"predict_one_p99_us\"]:.0f} us"')"
done

echo
echo "== tactile_force criterion benches (n = 2000, 19 features) =="
cargo bench --quiet --bench gp -- --noplot 2>/dev/null | grep -E '^[a-z_/0-9 ]+time:|^gp|time:' || true

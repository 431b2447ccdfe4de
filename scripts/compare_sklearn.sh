#!/usr/bin/env bash
# GP speed against scikit-learn in the same run, then our criterion figures.
#
#   scripts/compare_sklearn.sh [KERNELS] [SKLEARN_MODES] [N_TRAIN]
#     KERNELS        iso,ard (default) | iso | ard
#     SKLEARN_MODES  shared,per-axis (default) | shared | per-axis
#     N_TRAIN        training rows (default 2000); WHOLE=1 also times whole processes;
#                    OURS_ARGS="--restarts 1" passes options to our eval
#
# scikit-learn ARD takes minutes per fit on 2 cores; see scripts/compare_sklearn.py.
set -euo pipefail
cd "$(dirname "$0")/.."
out=target/bench-sklearn
venv=${VENV:-target/bench-venv}
mkdir -p "$out"
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet scikit-learn numpy
fi
py="$venv/bin/python"
echo "scikit-learn $("$py" -c 'import sklearn; print(sklearn.__version__)'), numpy $("$py" -c 'import numpy; print(numpy.__version__)')"

cargo build --release --quiet
bin=target/release/tactile_force
"$bin" collect --seed 1 --out "$out/seed1.csv"
"$py" scripts/compare_sklearn.py --bin "$bin" --data "$out/seed1.csv" --out-dir "$out" \
  --kernels "${1:-iso,ard}" --sklearn "${2:-shared,per-axis}" --n-train "${3:-2000}" \
  ${WHOLE:+--whole} --ours-args="${OURS_ARGS:-}"

echo
echo "== tactile_force criterion benches (n = 2000, 19 features, 3 force axes) =="
cargo bench --quiet --bench gp -- --noplot 2>/dev/null | grep -E 'time:|predict_one mean\+std' || true

#!/usr/bin/env bash
# The nail camera across persons (simulated persons; config/nail_sim.yaml):
# a person's own model (5-fold trial-wise CV: GP, NN, CNN), a generalised
# model that has not seen the person (trained on persons 2-4), and that
# model adapted with 80 s of the person (one trial per set, another
# session). Every model is tested on person 1, session 1 (400 s). Then
# Watanabe et al. 2023's 360-degree test of person 1 in session 3
# (`collect --protocol radial`, 2412 s), scored at the 48 peaks of its
# pushes: person 1's model from session 1's sets, and from those and
# session 1's own 360-degree test.
# Prints the eval tables; R2 and RMSE per axis, fit time, direction error.
# Usage: bench/nail_persons.sh [work dir]   (about 10 min on 2 cores)
set -euo pipefail
cd "$(dirname "$0")/.."
work="${1:-target/nail-persons}"
mkdir -p "$work"
cargo build --release --quiet
tf=target/release/tactile_force
axes=fx,fy,fz,tx,ty,tz
for p in 1 2 3 4; do
  [ -d "$work/p$p" ] || $tf collect --sensor nail --unit "$p" --seed 1 --out "$work/p$p" >/dev/null
done
for s in 1 3; do
  [ -d "$work/p1-radial-s$s" ] ||
    $tf collect --sensor nail --unit 1 --seed "$s" --protocol radial --out "$work/p1-radial-s$s" >/dev/null
done
[ -d "$work/p1-80s" ] ||
  $tf collect --sensor nail --unit 1 --seed 2 --trials 1 --out "$work/p1-80s" >/dev/null

echo "== individual: person 1, 5-fold trial-wise cross-validation"
$tf eval --data "$work/p1" --folds 5 --axes "$axes"

echo "== generalised: trained on persons 2, 3, 4; tested on person 1"
$tf eval --train "$work/p2,$work/p3,$work/p4" --test "$work/p1" --axes "$axes" --no-cnn

echo "== adapted: the generalised GP adapted with 80 s of person 1 (session 2); tested on person 1"
$tf train --data "$work/p2,$work/p3,$work/p4" --axes "$axes" --out "$work/general.json" >/dev/null
$tf adapt --model "$work/general.json" --data "$work/p1-80s" --out "$work/adapted.json"
$tf eval --model "$work/adapted.json" --test "$work/p1"

echo "== person 1's own GP from the same 80 s, tested on person 1 (session 1)"
$tf eval --train "$work/p1-80s" --test "$work/p1" --axes "$axes" --no-nn --no-cnn

echo "== 360-degree test (person 1, session 3): person 1's model from session 1's sets"
$tf eval --train "$work/p1" --test "$work/p1-radial-s3" --axes "$axes" --no-cnn

echo "== the same test: model from session 1's sets and 360-degree test; peaks from 1, 2.5, 3.5 N"
for n in 1 2.5 3.5; do
  $tf eval --train "$work/p1,$work/p1-radial-s1" --test "$work/p1-radial-s3" --axes "$axes" \
    --no-cnn --peak-min-n "$n"
done

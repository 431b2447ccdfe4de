#!/usr/bin/env bash
# Runs the README's examples exactly as written, so that the README and what
# works on a fresh clone cannot drift apart.
#
#   scripts/readme-smoke.sh                  run every `cargo run` line of the
#                                            README's ```sh blocks, in order
#   scripts/readme-smoke.sh --test-command   print the Quickstart's test command
#                                            (.ci/run runs what this prints)
#
# A line passes when it exits 0 and every file it names with --out, --plot or
# --csv exists and is not empty. The default models are trained afresh (an
# empty TACTILE_FORCE_CACHE), as on a new machine. Files the lines write are
# removed at the end unless they were there before.
set -euo pipefail
cd "$(dirname "$0")/.."

# The lines of the README's ```sh blocks, with `\` continuations joined.
sh_lines() {
  awk '/^```/ { if (in_sh) { in_sh = 0 } else if ($0 == "```sh") { in_sh = 1 }; next }
       in_sh { print }' README.md |
    sed -e ':a' -e '/\\$/N; s/\\\n//; ta'
}

if [ "${1:-}" = "--test-command" ]; then
  cmd=$(sh_lines | grep -m1 -E '^cargo (test|nextest)' || true)
  [ -n "$cmd" ] || { echo "readme-smoke: no test command in the README's sh blocks" >&2; exit 1; }
  echo "$cmd"
  exit 0
fi

mapfile -t runs < <(sh_lines | grep -E '^cargo run' || true)
[ "${#runs[@]}" -gt 0 ] || { echo "readme-smoke: no cargo run line in the README" >&2; exit 1; }

export TACTILE_FORCE_CACHE="$PWD/target/readme-smoke/cache"
rm -rf "$TACTILE_FORCE_CACHE"
created=()
cleanup() { [ "${#created[@]}" -eq 0 ] || rm -rf -- "${created[@]}"; }
trap cleanup EXIT

for line in "${runs[@]}"; do
  # Files the line writes (the word after --out, --plot or --csv).
  read -r -a words <<<"$line"
  outputs=()
  for i in "${!words[@]}"; do
    case "${words[$i]}" in
      --out | --plot | --csv) outputs+=("${words[$((i + 1))]}") ;;
    esac
  done
  for f in "${outputs[@]}"; do [ -e "$f" ] || created+=("$f"); done
  echo "readme-smoke: \$ $line"
  start=$SECONDS
  bash -c "$line"
  for f in "${outputs[@]}"; do
    [ -s "$f" ] || { echo "readme-smoke: '$line' did not write $f" >&2; exit 1; }
  done
  echo "readme-smoke: ok in $((SECONDS - start)) s"
done
echo "readme-smoke: ${#runs[@]} README commands ran as written"

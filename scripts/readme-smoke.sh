#!/usr/bin/env bash
# Runs the documented examples exactly as written, so that the pages and what
# works on a fresh clone cannot drift apart.
#
#   scripts/readme-smoke.sh                  check the pages' links, then run
#                                            every `cargo run` line of the
#                                            ```sh blocks of README.md and of
#                                            each page in docs/, in order
#   scripts/readme-smoke.sh --test-command   print the Quickstart's test command
#                                            (.ci/run runs what this prints)
#
# A line passes when it exits 0 (or N, for a line that ends `# exits N`) and
# every file it names with --out, --plot or --csv exists and is not empty. The default models are trained afresh (an
# empty TACTILE_FORCE_CACHE), as on a new machine; no page but
# docs/development.md may name ../shared. Each page runs on its own:
# the files its lines write are removed before the next page (unless they
# were there before), so no page needs another's.
set -euo pipefail
cd "$(dirname "$0")/.."

# The lines of a page's ```sh blocks, with `\` continuations joined.
sh_lines() {
  awk '/^```/ { if (in_sh) { in_sh = 0 } else if ($0 == "```sh") { in_sh = 1 }; next }
       in_sh { print }' "$1" |
    sed -e ':a' -e '/\\$/N; s/\\\n//; ta'
}

if [ "${1:-}" = "--test-command" ]; then
  cmd=$(sh_lines README.md | grep -m1 -E '^cargo (test|nextest)' || true)
  [ -n "$cmd" ] || { echo "readme-smoke: no test command in the README's sh blocks" >&2; exit 1; }
  echo "$cmd"
  exit 0
fi

pages=(README.md docs/*.md)
python3 scripts/check-doc-links.py "${pages[@]}"
# A user's clone has no ../shared (this project's tests' data, beside the
# repository on our machines): no user-facing page may need it. Only the
# contributors' page names it.
if grep -n '\.\./shared' "${pages[@]}" | grep -v '^docs/development\.md:'; then
  echo "readme-smoke: the lines above need ../shared, which a user's clone does not have" >&2
  exit 1
fi

export TACTILE_FORCE_CACHE="$PWD/target/readme-smoke/cache"
rm -rf "$TACTILE_FORCE_CACHE"
created=()
cleanup() { [ "${#created[@]}" -eq 0 ] || rm -rf -- "${created[@]}"; created=(); }
trap cleanup EXIT

total=0
for page in "${pages[@]}"; do
  mapfile -t runs < <(sh_lines "$page" | grep -E '^cargo run' || true)
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
    # A line that documents a refusal or a failure says so: `# exits N`.
    expected=0
    if [[ $line =~ \#\ exits\ ([0-9]+) ]]; then expected=${BASH_REMATCH[1]}; fi
    echo "readme-smoke: $page: \$ $line"
    start=$SECONDS
    rc=0
    bash -c "$line" || rc=$?
    [ "$rc" -eq "$expected" ] || {
      echo "readme-smoke: '$line' ($page) exited $rc, expected $expected" >&2
      exit 1
    }
    for f in "${outputs[@]}"; do
      [ -s "$f" ] || { echo "readme-smoke: '$line' ($page) did not write $f" >&2; exit 1; }
    done
    echo "readme-smoke: ok in $((SECONDS - start)) s"
    total=$((total + 1))
  done
  cleanup
done
[ "$total" -gt 0 ] || { echo "readme-smoke: no cargo run line in the pages" >&2; exit 1; }
echo "readme-smoke: ${total} documented commands of ${#pages[@]} pages ran as written"

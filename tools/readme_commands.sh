#!/usr/bin/env bash
# Runs every command of the README's `sh` blocks, in the README's order, as a newcomer would on a
# fresh clone, and fails on the first one that does not exit 0.
#
# `cargo run --release -- ARGS` and `legwise ARGS` run as the release binary with ARGS, in a scratch directory
# holding the repository's models/ and examples/ (so the files the commands write, such as
# tracker.csv or poses.csv, do not land in the clone). `cargo test` is skipped: CI runs it
# itself; so is `cargo install --path .` (the release build below). Comment lines, and
# commented-out commands, are skipped.
#
# Usage: tools/readme_commands.sh [README]   (from anywhere; CI runs it after `cargo test`)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
readme="${1:-$root/README.md}"

cargo build --release --quiet --manifest-path "$root/Cargo.toml"
binary="$root/target/release/legwise"
if [[ -n "${CARGO_TARGET_DIR:-}" ]]; then
  binary="$CARGO_TARGET_DIR/release/legwise"
fi

scratch="$(mktemp -d)"
trap 'rm -rf "$scratch"' EXIT
cp -r "$root/models" "$root/examples" "$scratch/"
mkdir -p "$scratch/tests/data" && cp -r "$root/tests/data/klipper" "$scratch/tests/data/"

mapfile -t commands < <(awk '/^```sh/{inside=1; next} /^```/{inside=0} inside' "$readme" |
  grep -v '^[[:space:]]*#' | grep -v '^[[:space:]]*$')

count=0
for command in "${commands[@]}"; do
  case "$command" in
    "cargo test"*) echo "readme: skipped (CI runs it): $command"; continue ;;
    "cargo install --path ."*) echo "readme: skipped (the release build above is it): $command"; continue ;;
    "cargo run --release -- "*) args="${command#cargo run --release -- }" ;;
    "legwise "*) args="${command#legwise }" ;;
    *) echo "readme: not a legwise command this script knows how to run: $command" >&2; exit 1 ;;
  esac
  count=$((count + 1))
  start=$SECONDS
  # The README's arguments are plain words (no quotes, no globbing), so splitting on blanks is
  # what the shell would do.
  read -r -a words <<<"$args"
  status=0
  (cd "$scratch" && "$binary" "${words[@]}" >"$scratch/.out" 2>&1) || status=$?
  if [[ $status -ne 0 ]]; then
    cat "$scratch/.out" >&2
    echo "readme: command $count failed with exit $status: $command" >&2
    exit 1
  fi
  echo "readme: $count ok in $((SECONDS - start)) s: $command"
done
echo "readme: all $count commands exit 0, in the README's order"

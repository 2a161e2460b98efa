#!/usr/bin/env bash
# Times the whole-run studies of docs/benchmarks.md and prints their table rows (markdown), so
# that a change of a default that moves a figure shows up in the diff of that file.
#
# Usage: tools/bench_table.sh [WORKDIR] [RUNS]
#   WORKDIR  where the 1 000 002-row CSV is built (once) and the runs write (default
#            /tmp/legwise-bench); the CSV is the four simulations docs/benchmarks.md describes.
#   RUNS     runs of each command (default 3); the row gives the range over them.
# Needs a release build (cargo build --release) and GNU time (/usr/bin/time).
# Each row: figure (wall range, CPU range, peak RSS), command, date (UTC), load average at
# the start of the first run, commit. Run it on a machine as quiet as you can get: wall times
# move by a factor of two with the load (docs/benchmarks.md, Method).
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
bin="$root/target/release/legwise"
work="${1:-/tmp/legwise-bench}"
runs="${2:-3}"
[ -x "$bin" ] || { echo "tools/bench_table.sh: $bin not found: run cargo build --release" >&2; exit 2; }
[ -x /usr/bin/time ] || { echo "tools/bench_table.sh: /usr/bin/time (GNU time) not found" >&2; exit 2; }
mkdir -p "$work"
model="$root/models/5r.yaml"
commit="$(git -C "$root" rev-parse --short HEAD)$(git -C "$root" diff --quiet HEAD -- src || echo '+dirty')"

csv="$work/1m.csv"
if [ ! -f "$csv" ]; then
  for s in 1 2 3; do
    "$bin" simulate --model "$model" --poses random --poses-per-leg 100000 --seed "$s" \
      --out "$work/part$s.csv" >/dev/null
  done
  "$bin" simulate --model "$model" --poses random --poses-per-leg 33334 --seed 4 \
    --out "$work/part4.csv" >/dev/null
  { cat "$work/part1.csv"; for s in 2 3 4; do tail -n +2 "$work/part$s.csv"; done; } >"$csv"
fi

# Runs "$@" RUNS times; prints "wall range s | CPU range s | peak MB" (CPU = user + sys).
measure() {
  local walls=() cpus=() peak=0 wall user sys kb
  for _ in $(seq "$runs"); do
    /usr/bin/time -o "$work/time" -f "%e %U %S %M" "$@" >/dev/null 2>"$work/stderr"
    read -r wall user sys kb <"$work/time"
    walls+=("$wall")
    cpus+=("$(echo "$user + $sys" | bc)")
    [ "$kb" -gt "$peak" ] && peak="$kb"
  done
  local wmin wmax cmin cmax
  wmin="$(printf '%s\n' "${walls[@]}" | sort -g | head -1)"
  wmax="$(printf '%s\n' "${walls[@]}" | sort -g | tail -1)"
  cmin="$(printf '%s\n' "${cpus[@]}" | sort -g | head -1)"
  cmax="$(printf '%s\n' "${cpus[@]}" | sort -g | tail -1)"
  echo "$wmin–$wmax s | $cmin–$cmax s | $((peak / 1024)) MB"
}

row() { # name, command shown, command run...
  local name="$1" shown="$2"
  shift 2
  local load date figure
  load="$(cut -d' ' -f1 /proc/loadavg)"
  date="$(date -u '+%d %b %H:%M')"
  figure="$(cd "$work" && measure "$@")"
  echo "| $name ($runs runs) | $figure | \`$shown\` | $date UTC, load $load, $commit |"
}

echo "| run | wall | CPU (user + sys) | peak RSS | command | date, load average, commit |"
echo "|---|---:|---:|---:|---|---|"
row "1 000 002-row CSV, D&C, weighted (default)" \
  "legwise identify --model models/5r.yaml --measurements 1m.csv" \
  "$bin" identify --model "$model" --measurements "$csv"
row "1 000 002-row CSV, D&C, \`--weights none\`" \
  "legwise identify --model models/5r.yaml --measurements 1m.csv --weights none" \
  "$bin" identify --model "$model" --measurements "$csv" --weights none
row "Monte Carlo, 5R, 1000 trials" \
  "legwise montecarlo --model models/5r.yaml --trials 1000 --seed 1 --json mc.json" \
  "$bin" montecarlo --model "$model" --trials 1000 --seed 1 --json "$work/mc.json"

#!/usr/bin/env python3
"""Measures the figures of docs/benchmarks.md and writes them into its generated table.

Usage: tools/bench_table.py [--bench NAME[=FILTER] ...] [--study NAME ...] [--runs N]
                            [--work DIR] [--no-run] [--write FILE]

  --bench identify='identify_leg/.*/lm'  runs `cargo bench --bench identify -- FILTER
        --warm-up-time 1 --measurement-time 3` and takes every criterion result it wrote
        (target/criterion/**/new/{benchmark,estimates}.json): the median and its 95 % interval.
        Repeatable; without FILTER the whole bench.
  --study csv|csv-weights-none|mc1000|mc10000   times a whole run RUNS times with GNU time
        (wall range, CPU = user + sys range, peak RSS). The 1 000 002-row CSV is built once in
        WORKDIR as docs/benchmarks.md describes. Repeatable.
  --runs N     runs of each study (default 3).
  --work DIR   where the CSV is built and the runs write (default /tmp/legwise-bench).
  --no-run     no cargo bench: read back the criterion results already in target/criterion
               (every one, whatever bench wrote it, or those whose ids the FILTER matches),
               dated by their files, the load not recorded.
  --write FILE the markdown file whose generated table (between the lines
               `<!-- bench_table.py: begin -->` and `<!-- bench_table.py: end -->`) gets the rows
               measured now, each replacing the row of the same figure; rows not measured now
               stay. Without --write the rows are printed.

Each row: figure (criterion id or study name), measured value, command, date (UTC), load
average at the start of its measurement, commit (`+dirty` if src/ differs from it). A change of
a default that moves a figure shows in the diff of the written file. Exit status 2 on bad
options or a missing tool, 1 when a measured command fails.
"""
import argparse
import glob
import json
import os
import re
import shutil
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BEGIN = "<!-- bench_table.py: begin -->"
END = "<!-- bench_table.py: end -->"
HEADER = [
    "| figure | measured | command | date (UTC), load average, commit |",
    "|---|---|---|---|",
]
MODEL = "models/5r.yaml"

# Study name -> (figure, command shown (from the repository root), arguments after the binary).
STUDIES = {
    "csv": (
        "1 000 002-row CSV, D&C, weighted (the default)",
        "legwise identify --model models/5r.yaml --measurements 1m.csv",
        ["identify", "--model", MODEL, "--measurements", "{csv}"],
    ),
    "csv-weights-none": (
        "1 000 002-row CSV, D&C, `--weights none`",
        "legwise identify --model models/5r.yaml --measurements 1m.csv --weights none",
        ["identify", "--model", MODEL, "--measurements", "{csv}", "--weights", "none"],
    ),
    "mc1000": (
        "Monte Carlo, 5R, 1000 trials",
        "legwise montecarlo --model models/5r.yaml --trials 1000 --seed 1 --json mc.json",
        ["montecarlo", "--model", MODEL, "--trials", "1000", "--seed", "1", "--json", "{work}/mc.json"],
    ),
    "mc10000": (
        "Monte Carlo, 5R, 10 000 trials",
        "legwise montecarlo --model models/5r.yaml --trials 10000 --seed 1 --json mc.json",
        ["montecarlo", "--model", MODEL, "--trials", "10000", "--seed", "1", "--json", "{work}/mc.json"],
    ),
}


def fail(message, code=2):
    print(f"tools/bench_table.py: {message}", file=sys.stderr)
    sys.exit(code)


def load():
    with open("/proc/loadavg") as f:
        return f.read().split()[0]


def now():
    return time.strftime("%d %b %Y %H:%M", time.gmtime())


def commit():
    head = subprocess.run(
        ["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True, text=True
    ).stdout.strip()
    dirty = subprocess.run(["git", "-C", ROOT, "diff", "--quiet", "HEAD", "--", "src"]).returncode
    return head + ("+dirty" if dirty else "")


def duration(ns):
    """A criterion time (ns) in the unit that keeps 3–4 significant digits."""
    for unit, scale in (("s", 1e9), ("ms", 1e6), ("µs", 1e3)):
        if ns >= scale:
            return ns / scale, unit
    return ns, "ns"


def criterion_row(directory, command, stamp):
    with open(os.path.join(directory, "benchmark.json")) as f:
        bench = json.load(f)
    with open(os.path.join(directory, "estimates.json")) as f:
        median = json.load(f)["median"]
    value, unit = duration(median["point_estimate"])
    scale = median["point_estimate"] / value
    low = median["confidence_interval"]["lower_bound"] / scale
    high = median["confidence_interval"]["upper_bound"] / scale
    figure = f"`{bench['full_id']}`"
    measured = f"{value:.4g} {unit} [{low:.4g}, {high:.4g}] (median, 95 % CI)"
    return figure, f"| {figure} | {measured} | `{command}` | {stamp} |"


def criterion_stamps():
    """Every criterion result (…/new/estimates.json) and the time it was written."""
    pattern = os.path.join(ROOT, "target", "criterion", "**", "new", "estimates.json")
    return {path: os.path.getmtime(path) for path in glob.glob(pattern, recursive=True)}


def criterion_results(before=None):
    """Directories of criterion results (…/new) written since the stamps `before` were taken
    (new or rewritten: not merely recent, so a bench run right after another does not take the
    other's last results); all of them if None."""
    stamps = criterion_stamps()
    return sorted(
        os.path.dirname(path)
        for path, written in stamps.items()
        if before is None or before.get(path) != written
    )


def run_bench(spec, no_run, rows):
    name, _, filter_ = spec.partition("=")
    if not re.fullmatch(r"[a-z_]+", name):
        fail(f"--bench {spec}: expected NAME or NAME=FILTER with a bench of benches/ (e.g. identify)")
    if not os.path.exists(os.path.join(ROOT, "benches", f"{name}.rs")):
        fail(f"--bench {spec}: no benches/{name}.rs")
    args = [filter_] if filter_ else []
    args += ["--warm-up-time", "1", "--measurement-time", "3"]
    shown = "cargo bench --bench " + name + " -- " + " ".join(
        f"'{a}'" if re.search(r"[^\w.-]", a) else a for a in args
    )
    stamp = f"{now()}, load {load()}, {commit()}"
    if no_run:
        pattern = re.compile(filter_) if filter_ else None
        before = None
    else:
        before = criterion_stamps()
        done = subprocess.run(["cargo", "bench", "--bench", name, "--"] + args, cwd=ROOT)
        if done.returncode != 0:
            fail(f"`{shown}` failed (exit {done.returncode})", 1)
        pattern = None
    for directory in criterion_results(before):
        if no_run:
            # Read back: the date of the result, the load of its run unknown.
            written = os.path.getmtime(os.path.join(directory, "estimates.json"))
            when = time.strftime("%d %b %Y %H:%M", time.gmtime(written))
            stamp = f"{when}, load not recorded (read back), {commit()}"
        figure, row = criterion_row(directory, shown, stamp)
        if pattern is None or pattern.search(figure.strip("`")):
            rows[figure] = row


def run_study(name, runs, work, rows):
    if name not in STUDIES:
        fail(f"--study {name}: expected one of {', '.join(STUDIES)}")
    binary = os.path.join(ROOT, "target", "release", "legwise")
    if not os.access(binary, os.X_OK):
        fail(f"{binary} not found: run cargo build --release")
    if not os.access("/usr/bin/time", os.X_OK):
        fail("/usr/bin/time (GNU time) not found")
    os.makedirs(work, exist_ok=True)
    csv = os.path.join(work, "1m.csv")
    if name.startswith("csv") and not os.path.exists(csv):
        build_csv(binary, work, csv)
    figure, shown, template = STUDIES[name]
    args = [a.format(csv=csv, work=work) for a in template]
    stamp = f"{now()}, load {load()}, {commit()}"
    walls, cpus, peak = [], [], 0
    for _ in range(runs):
        timing = os.path.join(work, "time")
        with open(os.path.join(work, "stdout"), "w") as out, open(os.path.join(work, "stderr"), "w") as err:
            done = subprocess.run(
                ["/usr/bin/time", "-o", timing, "-f", "%e %U %S %M", binary] + args,
                cwd=ROOT, stdout=out, stderr=err,
            )
        if done.returncode not in (0, 3):
            fail(f"`{shown}` exited {done.returncode} (see {work}/stderr)", 1)
        with open(timing) as f:
            wall, user, system, kb = f.read().split()[-4:]
        walls.append(float(wall))
        cpus.append(float(user) + float(system))
        peak = max(peak, int(kb))
    measured = (
        f"{min(walls):.2f}–{max(walls):.2f} s wall, {min(cpus):.2f}–{max(cpus):.2f} s CPU, "
        f"{peak // 1024} MB ({runs} run{'s' if runs > 1 else ''})"
    )
    rows[figure] = f"| {figure} | {measured} | `{shown}` | {stamp} |"


def build_csv(binary, work, csv):
    """The 1 000 002-row file: four simulations of the 5R concatenated without their headers."""
    parts = [(1, 100000), (2, 100000), (3, 100000), (4, 33334)]
    for seed, per_leg in parts:
        subprocess.run(
            [binary, "simulate", "--model", MODEL, "--poses", "random", "--poses-per-leg",
             str(per_leg), "--seed", str(seed), "--out", os.path.join(work, f"part{seed}.csv")],
            cwd=ROOT, check=True, stdout=subprocess.DEVNULL,
        )
    with open(csv, "w") as out:
        for k, (seed, _) in enumerate(parts):
            with open(os.path.join(work, f"part{seed}.csv")) as part:
                lines = part.readlines()
            out.writelines(lines if k == 0 else lines[1:])


def write(path, rows):
    """Replaces the rows of the same figure in `path`'s generated table, appends the others."""
    with open(path) as f:
        text = f.read()
    if text.count(BEGIN) != 1 or text.count(END) != 1 or text.index(BEGIN) > text.index(END):
        fail(f"{path}: expected one line `{BEGIN}` before one line `{END}`")
    head, rest = text.split(BEGIN, 1)
    table, tail = rest.split(END, 1)
    kept = {}
    for line in table.strip().splitlines():
        if line.startswith("| ") and not line.startswith(HEADER[0][:10]):
            kept[line.split(" | ")[0][2:]] = line
    kept.update(rows)
    lines = HEADER + [kept[k] for k in sorted(kept)]
    with open(path, "w") as f:
        f.write(head + BEGIN + "\n" + "\n".join(lines) + "\n" + END + tail)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bench", action="append", default=[])
    parser.add_argument("--study", action="append", default=[])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--work", default="/tmp/legwise-bench")
    parser.add_argument("--no-run", action="store_true")
    parser.add_argument("--write")
    options = parser.parse_args()
    if options.runs < 1:
        fail(f"--runs {options.runs}: expected at least 1")
    if not options.bench and not options.study:
        fail("nothing to measure: give --bench NAME[=FILTER] and/or --study NAME")
    if options.bench and not options.no_run and shutil.which("cargo") is None:
        fail("cargo not found")
    rows = {}
    for spec in options.bench:
        run_bench(spec, options.no_run, rows)
    for name in options.study:
        run_study(name, options.runs, os.path.abspath(options.work), rows)
    if options.write:
        write(options.write, rows)
    else:
        print("\n".join(HEADER + [rows[k] for k in sorted(rows)]))


if __name__ == "__main__":
    main()

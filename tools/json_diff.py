#!/usr/bin/env python3
"""Compares two legwise JSON reports number by number.

Usage: tools/json_diff.py BEFORE.json AFTER.json [--rel 1e-12] [--ignore KEY ...]

Prints every path whose numbers differ by more than `--rel` relative to the larger
magnitude (or whose strings or shapes differ), then a summary line; keys named by
`--ignore` (timings by default: any key containing "seconds", "ms" or "time") are skipped,
and counts of solver work (iterations, evaluations, refinement steps) are listed apart.
Exit status 0 when nothing beyond the tolerance differs, 1 otherwise.
"""
import argparse
import json
import sys

WORK = ("iterations", "evaluations", "refinement_steps", "row_solves")


def walk(a, b, path, out):
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                out.append((path + "/" + k, "missing on one side", None))
            else:
                walk(a[k], b[k], path + "/" + k, out)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append((path, f"length {len(a)} vs {len(b)}", None))
        for i, (x, y) in enumerate(zip(a, b)):
            walk(x, y, f"{path}[{i}]", out)
    elif isinstance(a, bool) or isinstance(b, bool) or not (
        isinstance(a, (int, float)) and isinstance(b, (int, float))
    ):
        if a != b:
            out.append((path, f"{a!r} vs {b!r}", None))
    else:
        scale = max(abs(a), abs(b))
        rel = abs(a - b) / scale if scale > 0 else 0.0
        out.append((path, f"{a!r} vs {b!r}", rel))


def main():
    p = argparse.ArgumentParser()
    p.add_argument("before")
    p.add_argument("after")
    p.add_argument("--rel", type=float, default=1e-12)
    p.add_argument("--ignore", nargs="*", default=["seconds", "_ms", "time", "elapsed"])
    args = p.parse_args()
    a = json.load(open(args.before))
    b = json.load(open(args.after))
    out = []
    walk(a, b, "", out)
    bad, work, largest, compared = 0, 0, 0.0, 0
    for path, what, rel in out:
        leaf = path.rsplit("/", 1)[-1].split("[")[0]
        if any(k in leaf for k in args.ignore):
            continue
        if rel is None:
            print(f"DIFF {path}: {what}")
            bad += 1
            continue
        if any(k in leaf for k in WORK):
            if rel > 0:
                print(f"work {path}: {what}")
                work += 1
            continue
        compared += 1
        largest = max(largest, rel)
        if rel > args.rel:
            print(f"DIFF {path}: {what} (relative {rel:.3e})")
            bad += 1
    print(
        f"{compared} numbers compared, largest relative difference {largest:.3e}; "
        f"{bad} beyond {args.rel:g}; {work} solver-work counts differ"
    )
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())

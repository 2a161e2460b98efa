"""The Python module's calling overhead on the 5R, in one run (docs/benchmarks.md):

* ``library`` — criterion's median of ``in_memory/5r/identify`` (``cargo bench --bench
  in_memory``): the library's own time for the identification the module asks for, CSV text in,
  reports out, no Python;
* ``native`` — ``legwise._native.identify`` on the same CSV text, from Python (the boundary:
  arguments and strings across, the GIL released and taken back);
* ``numpy`` — ``legwise.identify(model, columns)`` from numpy columns, the whole public call
  (the columns across as lists, the CSV text made and read by the library, the native call,
  the Report);
* ``numpy+dict`` — the same and its report parsed (``.to_dict()``);
* ``command`` — ``legwise identify --measurements FILE --json -`` as a process, for scale.

The three in-process calls are interleaved (one of each per round, ``--calls`` rounds after a warm-up),
so that each sees the same machine; each figure is a median. Run from the
repository's root, with the module installed (``pip install ./python``) and the release binary
built: ``python python/benchmarks/overhead.py``.
"""

import argparse
import json
import pathlib
import statistics
import subprocess
import tempfile
import time

import legwise
from legwise import _native

ROOT = pathlib.Path(__file__).resolve().parents[2]
MODEL = str(ROOT / "models" / "5r.yaml")


def timed(calls, rounds):
    """The wall times of each of ``calls`` (name to function), called in turn for ``rounds``
    rounds after 5 warm-up rounds, the order reversed every other round (s)."""
    times = {name: [] for name in calls}
    order = list(calls)
    for round in range(rounds + 5):
        for name in order if round % 2 else reversed(order):
            start = time.perf_counter()
            calls[name]()
            if round >= 5:
                times[name].append(time.perf_counter() - start)
    return times


def medians_ms(calls, rounds):
    """The median wall time of each of ``calls`` (:func:`timed`), ms."""
    return {name: 1e3 * statistics.median(t) for name, t in timed(calls, rounds).items()}


def criterion_median_ms():
    """Runs the criterion benchmark and reads its median (ms)."""
    subprocess.run(
        ["cargo", "bench", "--quiet", "--bench", "in_memory", "--", "--warm-up-time", "1",
         "--measurement-time", "3"],
        cwd=ROOT, check=True, capture_output=True,
    )
    estimates = ROOT / "target" / "criterion" / "in_memory_5r" / "identify" / "new" / "estimates.json"
    return json.loads(estimates.read_text())["median"]["point_estimate"] / 1e6


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=200, help="timed calls per figure")
    parser.add_argument("--binary", default=str(ROOT / "target" / "release" / "legwise"))
    options = parser.parse_args()
    csv, _ = _native.simulate(["--model", MODEL])
    columns = legwise.read_csv_text(csv)
    arguments = ["--model", MODEL]
    library = criterion_median_ms()
    with tempfile.TemporaryDirectory() as directory:
        path = pathlib.Path(directory) / "5r.csv"
        path.write_text(csv)
        run = [options.binary, "identify", "--model", MODEL, "--measurements", str(path),
               "--json", "-"]
        times = timed(
            {
                "native": lambda: _native.identify(arguments, csv),
                "numpy": lambda: legwise.identify(MODEL, columns),
                "numpy+dict": lambda: legwise.identify(MODEL, columns).to_dict(),
            },
            options.calls,
        )
        figures = {name: 1e3 * statistics.median(t) for name, t in times.items()}
        command = lambda: subprocess.run(run, capture_output=True, check=True)  # noqa: E731
        figures.update(medians_ms({"command": command}, max(20, options.calls // 10)))
    # The same round's calls saw the same machine: their ratio is the steadier figure.
    paired = {
        name: statistics.median(a / b for a, b in zip(times[name], times["native"]))
        for name in ("numpy", "numpy+dict")
    }
    rows = len(csv.splitlines()) - 1
    print(f"5R, {rows} rows of simulated measurements; medians (ms), ratios to the library's "
          "and to the native call's")
    native = figures["native"]
    for name, value in [("library", library)] + list(figures.items()):
        print(f"  {name:<10} {value:8.3f}   {value / library:5.2f}x   {value / native:5.2f}x")
    for name, ratio in paired.items():
        print(f"  {name} / native, median of the rounds' ratios: {ratio:.3f}")


if __name__ == "__main__":
    main()

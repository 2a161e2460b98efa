"""Identifies the 5R from a pandas DataFrame, draws the parameter errors, writes the calibrated
model and checks it on poses held out of the fit.

    pip install ./python pandas matplotlib
    cargo run --release -- simulate --model models/5r.yaml --out measurements.csv
    python python/examples/identify_5r.py measurements.csv

Run from the repository's root. The measurements come from the model's simulation (its own
seed), so the real values are known: ``legwise.Mechanism`` gives them.
"""

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

import legwise  # noqa: E402

model = legwise.Mechanism("models/5r.yaml")
frame = pd.read_csv(sys.argv[1] if len(sys.argv) > 1 else "measurements.csv")
report = legwise.identify(model, frame)
print(report.text)

# The parameter errors: identified minus real, with their 2σ bars.
names = [name for name in model.identified if model.parameters[name].real is not None]
errors = [report.parameters[n][0] - model.parameters[n].real for n in names]
sigmas = [2 * (report.parameters[n][1] or 0.0) for n in names]
plt.bar(names, [1e3 * e for e in errors], yerr=[1e3 * s for s in sigmas], capsize=3)
plt.ylabel("identified - real (× 1000: mm, mrad, ‰ of a gain)")
plt.xticks(rotation=45)
plt.title("5R: parameter errors after identification (bars: 2σ)")
plt.tight_layout()
plt.savefig("5r-errors.png")
print("wrote 5r-errors.png")

# The calibrated model, then poses it was not fitted to (another seed, random poses).
if report.trusted:
    print(report.write_calibrated("5r-calibrated.yaml"))
    held_out = legwise.simulate(model, seed=99, poses="random")
    evaluation = legwise.evaluate("5r-calibrated.yaml", held_out, against=model)
    after = evaluation["position_error_m"]["rms"]
    before = evaluation["against"]["position_error_m"]["rms"]
    print(f"held-out position error RMS: {1e3 * before:.3f} mm nominal, {1e3 * after:.4f} mm calibrated")
else:
    print("not trusted:", *report.warnings, sep="\n  ")

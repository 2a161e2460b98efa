"""Identifies the 5R from a pandas DataFrame and draws the parameter errors.

    pip install ./python pandas matplotlib
    cargo run --release -- simulate --model models/5r.yaml --out measurements.csv
    python python/examples/identify_5r.py measurements.csv
"""

import sys

import matplotlib.pyplot as plt
import pandas as pd

import legwise

frame = pd.read_csv(sys.argv[1] if len(sys.argv) > 1 else "measurements.csv", dtype={"leg": str})
frame["leg"] = frame["leg"].fillna("")
report = legwise.identify("models/5r.yaml", frame)
print(report.text)
result = report.to_dict()["results"][0]
names, errors = [], []
for leg in result["legs"]:
    for p in leg["parameters"]:
        if not p["fixed"] and p.get("real") is not None:
            names.append(p["name"])
            errors.append(p["identified"] - p["real"])
plt.bar(names, errors)
plt.ylabel("identified - real (SI units)")
plt.title("5R: parameter errors after identification")
plt.savefig("5r-errors.png")
print("wrote 5r-errors.png")

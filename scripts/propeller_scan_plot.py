#!/usr/bin/python3
"""Propeller criteria against the restitution coefficient (thesis figs. 6.6, 6.7).

    /usr/bin/python3 scripts/propeller_scan_plot.py runs/propeller-scan/criteria.csv [OUTDIR]

Reads the scan table (e, seed, contrast, v_H, dv_y), plots Sigma_max/Sigma_min and
v_H/dv_y against e and against 1 - e^2 (mean over seeds, error bars = standard error), and
finds where each criterion crosses its threshold (contrast = 2, v_H/dv_y = 1) by linear
interpolation of the means between the bracketing e values. With several seeds per e the
crossing's uncertainty comes from resampling the seeds (bootstrap, 2,000 draws). Writes
criteria_vs_e.png and crossings.json into OUTDIR (default: the table's directory).
"""
import csv
import json
import os
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

table = sys.argv[1]
out = sys.argv[2] if len(sys.argv) > 2 else os.path.dirname(os.path.abspath(table))
rows = list(csv.DictReader(open(table)))
if not rows:
    sys.exit(f"{table}: no rows")
by_e = {}
for r in rows:
    by_e.setdefault(float(r["e"]), []).append((float(r["contrast"]), float(r["v_H"]) / float(r["dv_y"])))
es = np.array(sorted(by_e))
samples = [np.array(by_e[e]) for e in es]


def crossing(means, threshold):
    """First e at which the mean drops through the threshold (criteria fall as e grows)."""
    for k in range(len(es) - 1):
        a, b = means[k] - threshold, means[k + 1] - threshold
        if a >= 0 > b or a <= 0 < b:
            return float(es[k] + (es[k + 1] - es[k]) * a / (a - b))
    return None


result = {}
fig, axes = plt.subplots(2, 2, figsize=(10, 7))
rng = np.random.default_rng(1)
for col, (name, threshold, label) in enumerate([("contrast", 2.0, "Sigma_max / Sigma_min"),
                                                 ("velocity_ratio", 1.0, "v_H / dv_y")]):
    means = np.array([s[:, col].mean() for s in samples])
    errs = np.array([s[:, col].std(ddof=1) / np.sqrt(len(s)) if len(s) > 1 else 0.0 for s in samples])
    c = crossing(means, threshold)
    boot = []
    if all(len(s) > 1 for s in samples):
        for _ in range(2000):
            m = np.array([rng.choice(s[:, col], len(s)).mean() for s in samples])
            x = crossing(m, threshold)
            if x is not None:
                boot.append(x)
    result[name] = {"threshold": threshold, "crossing_e": c,
                    "crossing_e_std": float(np.std(boot)) if len(boot) > 10 else None,
                    "seeds_per_e": {f"{e:g}": len(s) for e, s in zip(es, samples)},
                    "mean": {f"{e:g}": float(m) for e, m in zip(es, means)}}
    for row, x in enumerate([es, 1 - es ** 2]):
        ax = axes[row, col]
        ax.errorbar(x, means, yerr=errs, marker="o", capsize=3)
        ax.axhline(threshold, color="k", ls="--", lw=0.8)
        if c is not None:
            ax.axvline(c if row == 0 else 1 - c * c, color="r", lw=0.8)
        ax.set_xlabel("e" if row == 0 else "1 - e^2")
        ax.set_ylabel(label)
fig.suptitle("propeller criteria vs restitution (red: crossing of the threshold)")
fig.tight_layout()
fig.savefig(os.path.join(out, "criteria_vs_e.png"), dpi=110)
json.dump(result, open(os.path.join(out, "crossings.json"), "w"), indent=2)
for name, r in result.items():
    print(f"{name}: crossing at e = {r['crossing_e']}" + (f" +- {r['crossing_e_std']:.3f}" if r["crossing_e_std"] else ""))

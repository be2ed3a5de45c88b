#!/usr/bin/python3
"""<s>(D/d) from a scan (scripts/clog-physics-study at several D/d), fitted two ways:

    /usr/bin/python3 scripts/clog_scan.py runs/clog-scan [variant] [--plot out.png]

 - silo form (Zuriguel et al. 2005, Thomas & Durian 2015): <s> = A exp(C (D/d)^2), no finite
   transition: clogs only become rarer;
 - divergence (To et al. 2001, Marin et al. 2018's reading): <s> = A (x_c - D/d)^-gamma,
   "no clogging" beyond x_c.
Weighted least squares on ln <s> (weights from each point's standard error); prints each fit's
parameters, chi^2 per degree of freedom, and the D/d at which the fit reaches <s> = 1e3, 1e4.
Runs stopped by a guard are left out; runs that reached the time limit count with their s.
"""
import csv
import math
import os
import sys

import numpy as np


def points(root, variant):
    out = []
    for d in sorted(os.listdir(root)):
        path = os.path.join(root, d, variant, "ensemble.csv")
        if not d.startswith("Dd_") or not os.path.exists(path):
            continue
        rows = [r for r in csv.DictReader(open(path)) if not r["ended"].startswith("guard")]
        s = np.array([float(r["escapees"]) for r in rows])
        if len(s) < 2:
            continue
        unclogged = sum(r["clogged"] != "1" for r in rows)
        out.append((float(d[3:]), s.mean(), s.std(ddof=1) / math.sqrt(len(s)), len(s), unclogged))
    return out


def fit_exp(x, y, w):
    # ln s = ln A + C x^2: linear
    X = np.vstack([np.ones_like(x), x ** 2]).T
    W = np.diag(w)
    p = np.linalg.solve(X.T @ W @ X, X.T @ W @ y)
    chi2 = float(((X @ p - y) ** 2 * w).sum())
    return p, chi2


def fit_div(x, y, w):
    # ln s = ln A - gamma ln(x_c - x): linear at fixed x_c; scan x_c
    best = None
    for xc in np.linspace(x.max() + 0.01, x.max() + 5, 2000):
        X = np.vstack([np.ones_like(x), -np.log(xc - x)]).T
        W = np.diag(w)
        p = np.linalg.solve(X.T @ W @ X, X.T @ W @ y)
        chi2 = float(((X @ p - y) ** 2 * w).sum())
        if best is None or chi2 < best[2]:
            best = (xc, p, chi2)
    return best


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    root = args[0]
    variant = args[1] if len(args) > 1 else "base"
    pts = points(root, variant)
    print("| D/d | runs | not clogged | <s> | std. error |")
    print("|---|---|---|---|---|")
    for x, m, se, n, u in pts:
        print(f"| {x} | {n} | {u} | {m:.1f} | {se:.1f} |")
    if len(pts) < 3:
        return
    x = np.array([p[0] for p in pts])
    y = np.log([p[1] for p in pts])
    w = np.array([(p[1] / p[2]) ** 2 for p in pts])  # 1 / var(ln s)
    dof = len(x) - 2
    p, chi2 = fit_exp(x, y, w)
    print(f"\nexp form: <s> = {math.exp(p[0]):.3g} exp({p[1]:.3f} (D/d)^2), chi2/dof = {chi2 / dof:.2f}")
    for target in (1e3, 1e4):
        print(f"  <s> = {target:.0e} at D/d = {math.sqrt((math.log(target) - p[0]) / p[1]):.2f}")
    xc, q, chi2d = fit_div(x, y, w)
    dof_d = len(x) - 3
    print(f"divergence: <s> = {math.exp(q[0]):.3g} ({xc:.2f} - D/d)^-{q[1]:.2f}, chi2/dof = "
          f"{chi2d / dof_d if dof_d > 0 else float('nan'):.2f}")
    for target in (1e3, 1e4):
        print(f"  <s> = {target:.0e} at D/d = {xc - math.exp((q[0] - math.log(target)) / q[1]):.2f}")
    if "--plot" in sys.argv:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        out = sys.argv[sys.argv.index("--plot") + 1]
        fig, ax = plt.subplots(figsize=(5, 3.6))
        ax.errorbar(x, [p[1] for p in pts], yerr=[p[2] for p in pts], fmt="o", label=f"cassini ({variant})")
        xs = np.linspace(1.2, 2.3, 200)
        ax.plot(xs, np.exp(p[0] + p[1] * xs ** 2), "-", label="A exp(C (D/d)^2)")
        xd = xs[xs < xc]
        ax.plot(xd, np.exp(q[0] - q[1] * np.log(xc - xd)), "--", label="A (x_c - D/d)^-gamma")
        ax.plot([1.7, 2.07], [100, 1000], "s", color="k", label="Marin et al. 2018 (order of magnitude)")
        ax.set_yscale("log")
        ax.set_xlabel("D/d")
        ax.set_ylabel("<s>")
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(out, dpi=120)
        print("wrote", out)


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""<s>(D/d) from a scan (scripts/clog-physics-study at several D/d), fitted two ways:

    /usr/bin/python3 scripts/clog_scan.py runs/clog-scan [variant] [--plot out.png]

 - silo form (Zuriguel et al. 2005, Thomas & Durian 2015): <s> = A exp(C (D/d)^2), no finite
   transition: clogs only become rarer;
 - divergence (To et al. 2001, Marin et al. 2018's reading): <s> = A (x_c - D/d)^-gamma,
   "no clogging" beyond x_c.
Weighted least squares on ln <s> (weights from each point's standard error); prints each fit's
parameters, chi^2 per degree of freedom, and the D/d at which the fit reaches <s> = 1e3, 1e4.
Runs stopped by a guard are left out. A run that reached the time limit without a clog counts
with its s so far (a lower bound); a point where most runs did so is only a lower bound on
<s>: it is not fitted, and each fit's value there is printed beside it. --fit-from X / --fit-to Y fit only X <= D/d <= Y.
"""
import math
import os
import sys

import numpy as np
sys.path.insert(0, os.path.join(os.path.dirname(os.path.realpath(__file__)), os.pardir, "python"))
from cassini_tools import read_ensemble


def points(root, variant):
    out = []
    for d in sorted(os.listdir(root)):
        path = os.path.join(root, d, variant, "ensemble.csv")
        if not d.startswith("Dd_") or not os.path.exists(path):
            continue
        rows = [r for r in read_ensemble(path, raw=True) if not r["ended"].startswith("guard")]
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
    argv = list(sys.argv[1:])
    fit_from, fit_to, plot_out = 0.0, 1e9, None
    if "--fit-from" in argv:
        k = argv.index("--fit-from")
        fit_from = float(argv[k + 1])
        del argv[k:k + 2]
    if "--fit-to" in argv:
        k = argv.index("--fit-to")
        fit_to = float(argv[k + 1])
        del argv[k:k + 2]
    if "--plot" in argv:
        k = argv.index("--plot")
        plot_out = argv[k + 1]
        del argv[k:k + 2]
    root = argv[0]
    variants = (argv[1] if len(argv) > 1 else "base").split(",")
    ax = None
    if plot_out:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(5.5, 3.8))
    for k, variant in enumerate(variants):
        print(f"\n{variant}\n")
        analyse(root, variant, fit_from, fit_to, ax, f"C{k}")
    if ax is not None:
        ax.plot([1.7, 2.07], [100, 1000], "s", color="k", label="Marin et al. 2018 (order of magnitude)")
        ax.set_yscale("log")
        ax.set_xlabel("D/d")
        ax.set_ylabel("<s>")
        ax.legend(fontsize=6.5)
        fig.tight_layout()
        fig.savefig(plot_out, dpi=120)
        print("wrote", plot_out)


NAMES = {"base": "mu = 0.5 (thesis)", "mu0.1_inlet8": "mu = 0.1"}


def analyse(root, variant, fit_from, fit_to, ax, color):
    allpts = points(root, variant)
    name = NAMES.get(variant, variant)
    print("| D/d | runs | not clogged (time limit) | <s> | std. error |")
    print("|---|---|---|---|---|")
    for x, m, se, n, u in allpts:
        print(f"| {x} | {n} | {u} | {'> ' if 2 * u > n else ''}{m:.1f} | {se:.1f} |")
    bounds = [p for p in allpts if 2 * p[4] > p[3]]
    pts = [p for p in allpts if 2 * p[4] <= p[3] and fit_from <= p[0] <= fit_to]
    if len(pts) < 3:
        return
    x = np.array([p[0] for p in pts])
    y = np.log([p[1] for p in pts])
    w = np.array([(p[1] / p[2]) ** 2 for p in pts])  # 1 / var(ln s)
    p, chi2 = fit_exp(x, y, w)
    print(f"\nfitted {x.min()} <= D/d <= {x.max()}: exp form: <s> = {math.exp(p[0]):.3g} exp({p[1]:.3f} (D/d)^2), "
          f"chi2/dof = {chi2 / (len(x) - 2):.2f}")
    for target in (1e3, 1e4):
        print(f"  <s> = {target:.0e} at D/d = {math.sqrt((math.log(target) - p[0]) / p[1]):.2f}")
    xc, q, chi2d = fit_div(x, y, w)
    dof_d = len(x) - 3
    print(f"divergence: <s> = {math.exp(q[0]):.3g} ({xc:.2f} - D/d)^-{q[1]:.2f}, chi2/dof = "
          f"{chi2d / dof_d if dof_d > 0 else float('nan'):.2f}")
    for target in (1e3, 1e4):
        print(f"  <s> = {target:.0e} at D/d = {xc - math.exp((q[0] - math.log(target)) / q[1]):.2f}")
    for x0, m0, _, _, _ in bounds:
        div = math.exp(q[0] - q[1] * math.log(xc - x0)) if x0 < xc else float("inf")
        print(f"  at D/d = {x0} (<s> > {m0:.0f}): exp form {math.exp(p[0] + p[1] * x0 ** 2):.0f}, divergence {div:.0f}")
    if ax is not None:
        fitted = [pt for pt in allpts if 2 * pt[4] <= pt[3]]
        ax.errorbar([pt[0] for pt in fitted], [pt[1] for pt in fitted], yerr=[pt[2] for pt in fitted], fmt="o",
                    color=color, label=f"cassini, {name}")
        if bounds:
            ax.plot([b[0] for b in bounds], [b[1] for b in bounds], "^", color=color,
                    label=f"{name}: lower bound (no clog in 20 s)")
        xs = np.linspace(x.min(), 2.3, 200)
        ax.plot(xs, np.exp(p[0] + p[1] * xs ** 2), "-", color=color, lw=0.8, label=f"{name}: A exp(C (D/d)^2), fitted {x.min()}-{x.max()}")
        xd = xs[xs < xc]
        ax.plot(xd, np.exp(q[0] - q[1] * np.log(xc - xd)), "--", color=color, lw=0.8,
                label=f"{name}: A (x_c - D/d)^-gamma")


if __name__ == "__main__":
    main()

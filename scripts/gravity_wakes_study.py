#!/usr/bin/python3
"""Gravity wakes, equilibrated: groups of runs (seeds of one code and box), the transient cut by a
stated criterion, errors from independent seeds or blocks.

  scripts/gravity_wakes_study.py NAME=RUN[,RUN...] [NAME=RUN,...] [--min-window 3] [--json OUT]

Each RUN is a cassini run directory or a scripts/gravity-wakes-rebound output directory (the
per-snapshot quantities are scripts/gravity_wakes.py's: wake wavelength and pitch from the
surface density's spectrum, Toomre Q, dispersions, thickness). A file RUN.time holding
"user system elapsed" seconds (as /usr/bin/time -f "%U %S %e" writes it) adds CPU per orbit.

Stationarity criterion (per group, on the one-orbit means of Q, which rises while the wakes
heat the ring): the window starts at the earliest whole orbit t_s >= 1 from which a straight line
through every run's orbit means to the end changes by at most max(3 %, 2 standard errors of the
runs' own slopes, or of the line's slope for a single run) across the window, the window holding
at least --min-window orbits. A group without such a window is reported as not stationary.

Errors: each quantity's window mean per run; the group's value is the mean over runs and its
error the standard error over the runs (independent seeds). A single run's error is that of its
one-orbit block means (the wakes' pattern decorrelates within about an orbit: the lag-one
autocorrelation of the block means is printed to check it).
"""
import argparse
import glob
import json
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
import gravity_wakes as gw  # noqa: E402

KEYS = ("wavelength", "pitch", "Q", "sigma_x", "sigma_y", "sigma_z", "thickness")


def rows_of(run):
    paths = sorted(glob.glob(os.path.join(run, "snap_*.h5md"))) or sorted(glob.glob(os.path.join(run, "snap_*.txt")))
    if not paths:
        sys.exit(f"gravity_wakes_study.py: no snapshots in {run}")
    rows = []
    for p in paths:
        s = gw.snapshot(p)
        T0 = 2 * math.pi / s["omega"]
        disp, thick, sig = gw.moments(s)
        _, lam, pitch = gw.wake(s)
        rows.append(dict(orbits=s["time"] / T0, wavelength=lam, pitch=pitch, Q=disp[1] * s["omega"] / (3.36 * gw.G * sig),
                         sigma_x=disp[0], sigma_y=disp[1], sigma_z=disp[2], thickness=thick, surface_density=sig,
                         critical=4 * math.pi ** 2 * gw.G * sig / s["omega"] ** 2, particles=len(s["mass"])))
    return rows


def orbit_means(rows, key):
    """{orbit k: mean of `key` over snapshots with k < t <= k + 1}, whole orbits only."""
    out = {}
    for k in range(int(max(r["orbits"] for r in rows) + 0.01)):  # snapshots at whole orbits of T0 rounded
        v = [r[key] for r in rows if k + 0.01 < r["orbits"] <= k + 1.01]
        if len(v) >= 3:
            out[k] = float(np.mean(v))
    return out


def window_start(runs, min_window, first=1):
    """The earliest whole orbit t_s >= first meeting the criterion (module docstring), or None."""
    series = [orbit_means(rows, "Q") for rows in runs]
    end = min(max(s) for s in series) + 1  # orbits every run completed
    for ts in range(first, end - min_window + 1):
        xs = np.concatenate([np.arange(ts, end) + 0.5 for _ in series])
        ys = np.concatenate([[s[k] for k in range(ts, end)] for s in series])
        fit, cov = np.polyfit(xs, ys, 1, cov=True) if len(xs) > 3 else (np.polyfit(xs, ys, 1), None)
        if len(series) > 1:
            slopes = [np.polyfit(np.arange(ts, end) + 0.5, [s[k] for k in range(ts, end)], 1)[0] for s in series]
            slope_err = float(np.std(slopes, ddof=1) / math.sqrt(len(slopes)))
        else:
            slope_err = float(math.sqrt(cov[0, 0])) if cov is not None else 0.0
        span = end - ts
        if abs(fit[0] * span) <= max(0.03 * ys.mean(), 2 * slope_err * span):
            return ts, end
    return None, end


def group_table(name, runs_dirs, min_window, first=1):
    runs = [rows_of(d) for d in runs_dirs]
    ts, end = window_start(runs, min_window, first)
    out = dict(name=name, runs=runs_dirs, particles=runs[0][-1]["particles"], critical=runs[0][-1]["critical"],
               window=[ts, end] if ts is not None else None)
    cpu = []
    for d, rows in zip(runs_dirs, runs):
        f = d.rstrip("/") + ".time"
        if os.path.exists(f):
            with open(f) as fh:
                last = fh.read().split()
            try:
                cpu.append((float(last[-3]) + float(last[-2])) / rows[-1]["orbits"])
            except (ValueError, IndexError):
                pass
    out["cpu_per_orbit"] = float(np.mean(cpu)) if cpu else None
    if ts is None:
        return out
    for key in KEYS:
        per_run = [np.mean([v for k, v in orbit_means(rows, key).items() if ts <= k < end]) for rows in runs]
        if len(runs) > 1:
            out[key] = [float(np.mean(per_run)), float(np.std(per_run, ddof=1) / math.sqrt(len(per_run)))]
        else:
            blocks = [v for k, v in orbit_means(runs[0], key).items() if ts <= k < end]
            b = np.array(blocks)
            out[key] = [float(b.mean()), float(b.std(ddof=1) / math.sqrt(len(b)))]
            if key == "Q" and len(b) > 2:
                d = b - b.mean()
                out["Q_block_lag1"] = float(np.sum(d[1:] * d[:-1]) / np.sum(d * d))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("groups", nargs="+", help="NAME=RUN[,RUN...]")
    ap.add_argument("--min-window", type=int, default=3, help="orbits the stationary window must hold at least")
    ap.add_argument("--from", dest="first", type=int, default=1,
                    help="the window starts at this orbit or later (one run's slope error, widened by the rise's "
                         "curvature, can pass the criterion while Q still rises: read the orbit means)")
    ap.add_argument("--json", help="write the table here")
    a = ap.parse_args()
    table = []
    for g in a.groups:
        if "=" not in g:
            sys.exit(f"gravity_wakes_study.py: '{g}' is not NAME=RUN[,RUN...]")
        name, runs = g.split("=", 1)
        table.append(group_table(name, runs.split(","), a.min_window, a.first))
    print(f"{'group':22s} {'runs':>4} {'N':>6} {'window':>8} {'lambda m':>13} {'/crit':>5} {'pitch deg':>11} {'Q':>11} "
          f"{'sigma x,y,z mm/s':>24} {'H m':>11} {'CPU-s/orbit':>11}")
    for t in table:
        cpu = f"{t['cpu_per_orbit']:.1f}" if t["cpu_per_orbit"] else "-"
        if t["window"] is None:
            print(f"{t['name']:22s} {len(t['runs']):4d} {t['particles']:6d} {'none':>8}  not stationary {cpu:>11}")
            continue
        pm = lambda k, s=1.0, f=".1f": f"{s * t[k][0]:{f}}+-{s * t[k][1]:{f}}"
        print(f"{t['name']:22s} {len(t['runs']):4d} {t['particles']:6d} {t['window'][0]:>3d}-{t['window'][1]:<4d} "
              f"{pm('wavelength'):>13} {t['wavelength'][0] / t['critical']:5.2f} {pm('pitch'):>11} {pm('Q', f='.2f'):>11} "
              f"{1e3 * t['sigma_x'][0]:.2f},{1e3 * t['sigma_y'][0]:.2f},{1e3 * t['sigma_z'][0]:.2f} "
              f"(+-{1e3 * t['sigma_y'][1]:.2f} y) {pm('thickness', f='.2f'):>11} {cpu:>11}"
              + (f"  [Q block lag-1 {t['Q_block_lag1']:+.2f}]" if "Q_block_lag1" in t else ""))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(table, f, indent=1)


if __name__ == "__main__":
    main()

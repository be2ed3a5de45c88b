"""Propeller checks against Hill-frame theory (issue 17, item 4), from the snapshots of runs of
cases/propeller:

   /usr/bin/python3 scripts/propeller_theory.py gap  RUN_SMALL RUN_LARGE [--scale 2] [--window 4084]
   /usr/bin/python3 scripts/propeller_theory.py wake RUN [--from T] [--to T]

gap:  the radial offset of the gaps downstream. RUN_LARGE is RUN_SMALL with every length times
      SCALE (moonlet mass x SCALE^3 and radius x SCALE, so r_H x SCALE; box x SCALE, particle count
      x SCALE^2 at the same optical depth). The surface density against |y| is taken downstream,
      x sign(y) in [1, 5] km x SCALE, over the last WINDOW seconds; the gap's offset is the centroid
      of the density deficit max(0, 1 - Sigma/Sigma_0) over |y| < 0.45 Ly (Sigma_0: the box's mean),
      and its deepest point. Theory: both scale with r_H, so the ratios are SCALE.
wake: the moonlet wake's azimuthal wavelength. A particle passing the moonlet at radial offset y
      gets a radial kick and then moves on its epicycle (period 2 pi / Omega0) while the shear
      carries it downstream at 1.5 Omega0 |y|: its radial velocity repeats every 3 pi |y| in x,
      and the pattern is stationary in the moonlet's frame. Mean v_y of LE1 (or all) particles in
      bands of |y|, binned in downstream distance s (from 2 |y|, past the encounter, to the front
      of material that has passed since the start), is fitted with A cos(2 pi s / lambda + phi) + c.
      The linear kinematics holds for test particles (a run without "contact"): in a collisional
      ring the wake is damped and its phase drifts (docs/propeller.md).
"""
import argparse, math, os, sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.realpath(__file__)), os.pardir, "python"))
from cassini_tools import Hill, Run, SATURN_MASS as MS, ORBIT_RADIUS as R0

OMEGA0 = Hill({}).omega0  # the propeller cases use hill's default Saturn and orbit

ap = argparse.ArgumentParser()
ap.add_argument("mode", choices=["gap", "wake"])
ap.add_argument("runs", nargs="+")
ap.add_argument("--scale", type=float, default=2.0)
ap.add_argument("--window", type=float, default=4084.0)
ap.add_argument("--from", dest="t_from", type=float, default=0.0)
ap.add_argument("--to", dest="t_to", type=float, default=1e30)
a = ap.parse_args()


def frames(run, t0, t1):
    """(time, positions, velocities, snapshot) of the main box LE1, for frames in [t0, t1]."""
    for frame in Run(run).frames(start=t0, end=t1):
        snap = frame.read(columns=["position", "velocity", "le_copy"], copy=0)
        yield snap.time, snap.position, snap.velocity, snap


def gap_offset(run, scale):
    t1 = max(f.time for f in Run(run).frames())
    acc, ref, n = None, 0.0, 0
    for t, x, v, f in frames(run, t1 - a.window, t1):
        box = f.edges
        Lx, Ly = float(box[0][0]), float(box[1][1])
        edges = np.linspace(0, 0.45 * Ly, 46)
        s = x[:, 0] * np.sign(x[:, 1])
        sel = (s >= 1000 * scale) & (s <= 5000 * scale)
        h, _ = np.histogram(np.abs(x[sel, 1]), bins=edges)
        acc = h if acc is None else acc + h
        ref += len(x) / (Lx * Ly)  # the box's mean surface number density
        n += 1
    dens = acc / n / (np.diff(edges) * 2 * 4000 * scale)
    ref /= n
    y = 0.5 * (edges[1:] + edges[:-1])
    deficit = np.clip(1 - dens / ref, 0, None)
    centroid = float(np.sum(y * deficit) / np.sum(deficit))
    ymin = float(y[np.argmin(dens)])
    return centroid, ymin, y, dens, ref, n


if a.mode == "gap":
    small, large = a.runs
    c1, m1, y1, d1, r1, n1 = gap_offset(small, 1.0)
    c2, m2, y2, d2, r2, n2 = gap_offset(large, a.scale)
    rh = R0 * (1.27e10 / (3 * MS)) ** (1 / 3)
    print(f"frames: {n1} and {n2}")
    print(f"gap centroid of the deficit: {c1:.0f} m ({c1 / rh:.2f} r_H) and {c2:.0f} m ({c2 / (a.scale * rh):.2f} r_H'):"
          f" ratio {c2 / c1:.3f} (theory {a.scale:g})")
    print(f"deepest point: {m1:.0f} m and {m2:.0f} m: ratio {m2 / m1:.3f}")
    print("|y|/r_H   Sigma/Sigma_ref (small)   (large, at the same |y|/r_H')")
    for k in range(0, len(y1), 3):
        j = int(np.argmin(np.abs(y2 / a.scale - y1[k])))
        print(f"{y1[k] / rh:6.2f}   {d1[k] / r1:6.3f}   {d2[j] / r2:6.3f}")
else:
    run = a.runs[0]
    bands = [(b, b + 100) for b in range(800, 1600, 100)]
    sbins, sums = None, None
    n, t_first = 0, None
    for t, x, v, f in frames(run, a.t_from, a.t_to):
        if sbins is None:  # downstream distance up to half the box (then the periodic image)
            sbins = np.arange(0.0, 0.5 * float(f.edges[0][0]), 150.0)
            sums = {b: (np.zeros(len(sbins) - 1), np.zeros(len(sbins) - 1)) for b in bands}
        n += 1
        t_first = t if t_first is None else min(t_first, t)
        s = x[:, 0] * np.sign(x[:, 1])
        ay = np.abs(x[:, 1])
        vy = v[:, 1] * np.sign(x[:, 1])  # mirror: the pattern at -y is the one at +y turned by pi
        for b in bands:
            sel = (ay >= b[0]) & (ay < b[1])
            h, _ = np.histogram(s[sel], bins=sbins, weights=vy[sel])
            c, _ = np.histogram(s[sel], bins=sbins)
            sums[b][0][:] += h
            sums[b][1][:] += c
    centres = 0.5 * (sbins[1:] + sbins[:-1])
    print(f"{n} frames; band |y| (m): fitted wavelength (m), 3 pi <|y|> (m), ratio, amplitude (mm/s), s range (m)")
    for b in bands:
        yc = 0.5 * (b[0] + b[1])
        # Downstream of the encounter (s > 2 |y|) and behind the front of material that has passed
        # the moonlet since the start (s < 1.5 Omega0 |y| t).
        s_max = 0.95 * 1.5 * OMEGA0 * b[0] * t_first
        ok = (sums[b][1] > 0) & (centres > 2 * yc) & (centres < s_max)
        s, vy = centres[ok], sums[b][0][ok] / sums[b][1][ok]
        best = None
        for lam in np.linspace(2000, 20000, 3601):
            k = 2 * math.pi / lam
            A = np.column_stack([np.cos(k * s), np.sin(k * s), np.ones_like(s)])
            coef, res, *_ = np.linalg.lstsq(A, vy, rcond=None)
            r = float(np.sum((A @ coef - vy) ** 2))
            if best is None or r < best[0]:
                best = (r, lam, math.hypot(coef[0], coef[1]))
        theory = 3 * math.pi * yc
        print(f"{b[0]}-{b[1]}: {best[1]:.0f}  {theory:.0f}  {best[1] / theory:.3f}  {best[2] * 1e3:.2f}  {s.min():.0f}-{s.max():.0f}")

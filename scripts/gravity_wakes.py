#!/usr/bin/python3
"""Gravity wakes in a self-gravitating ring patch: wavelength, pitch angle, Toomre Q, dispersion.

  scripts/gravity_wakes.py RUN_DIR [--from ORBITS] [--figure PNG] [--json OUT]

reads the run's H5MD snapshots (cases/gravity-wakes writes ten per orbit; or the text frames of
scripts/gravity-wakes-rebound, the same patch in REBOUND) and, per snapshot:
  - the surface density on a grid in the sheared coordinate x' = x - S (y - lo_y) / Ly (S the
    Lees-Edwards offset), where the patch is periodic in both directions, its power spectrum,
    and the physical wave vector of each mode k = (kx, ky - kx S / Ly);
  - the wake wave vector: the power-weighted centroid of the modes above half the peak power
    (folded to ky > 0; wavelengths above 4 of the largest particles' diameters); wavelength 2 pi / |k|, pitch angle atan(|kx| / |ky|) (the angle between
    the crests and the azimuthal x axis);
  - Toomre Q = sigma_y Omega0 / (3.36 G Sigma) from the mass-weighted radial dispersion;
  - velocity dispersions per component (x relative to the shear flow) and the rms thickness.
It prints a table, the mean and the standard error over snapshots from --from orbits on, and the
Toomre critical wavelength 4 pi^2 G Sigma / Omega0^2 beside it.
"""
import argparse
import glob
import json
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.realpath(__file__)), os.pardir, "python"))
from cassini_tools import G, Snapshot


def snapshot(path):
    if path.endswith(".txt"):  # scripts/gravity-wakes-rebound's frames, already in cassini's axes
        with open(path) as f:
            t, Lx, Ly, Lz, omega = (float(v) for v in f.readline().split()[1:])
        d = np.loadtxt(path, ndmin=2)
        return {"position": d[:, 0:3], "velocity": d[:, 3:6], "radius": d[:, 6], "mass": d[:, 7], "time": t,
                "offset": 1.5 * omega * Ly * t, "L": np.array([Lx, Ly, Lz]), "lo": -0.5 * np.array([Lx, Ly, Lz]),
                "shear_rate": 1.5 * omega, "omega": omega}
    snap = Snapshot(path, columns=["position", "velocity", "mass", "radius"])
    s = dict(snap.columns)
    s.update(time=snap.time, offset=snap.offset, L=snap.lengths, lo=snap.origin, shear_rate=snap.shear_rate,
             omega=snap.frame_rotation)
    return s


def wake(s, cells=128):
    """Wake wave vector (kx, ky), its wavelength and pitch angle (degrees) of one snapshot.
    cells: bins per axis, or (bins along x, bins along y) for an elongated box."""
    cx, cy = (cells, cells) if np.isscalar(cells) else cells
    x, y = s["position"][:, 0], s["position"][:, 1]
    Lx, Ly = s["L"][0], s["L"][1]
    S = s["offset"] - Lx * math.floor(s["offset"] / Lx)
    if S >= Lx / 2:
        S -= Lx
    xs = (x - S * (y - s["lo"][1]) / Ly - s["lo"][0]) % Lx
    ys = (y - s["lo"][1]) % Ly
    sigma, _, _ = np.histogram2d(xs, ys, bins=(cx, cy), range=[[0, Lx], [0, Ly]], weights=s["mass"])
    power = np.abs(np.fft.fft2(sigma - sigma.mean())) ** 2
    m = np.fft.fftfreq(cx, 1.0 / cx)[:, None]
    n = np.fft.fftfreq(cy, 1.0 / cy)[None, :]
    kx = 2 * np.pi * m / Lx + 0 * n
    ky = 2 * np.pi * n / Ly - kx * S / Ly
    flip = ky < 0  # P(k) = P(-k): fold onto ky > 0
    kx, ky = np.where(flip, -kx, kx), np.abs(ky)
    # Wakes are collective: modes shorter than 4 of the largest particles' diameters hold the
    # particles' own granularity, not wakes.
    power[np.hypot(kx, ky) > 2 * np.pi / (8 * s["radius"].max())] = 0
    power[0, 0] = 0
    peak = power >= 0.5 * power.max()
    w = power[peak]
    kc = np.array([np.sum(w * kx[peak]), np.sum(w * ky[peak])]) / w.sum()
    k = np.hypot(*kc)
    return kc, 2 * np.pi / k, math.degrees(math.atan2(abs(kc[0]), abs(kc[1])))


def moments(s):
    m = s["mass"]
    v = s["velocity"].copy()
    v[:, 0] -= s["shear_rate"] * s["position"][:, 1]
    mid = s["lo"][2] + 0.5 * s["L"][2]
    mean = np.average(v, axis=0, weights=m)
    disp = np.sqrt(np.average((v - mean) ** 2, axis=0, weights=m))
    thick = math.sqrt(np.average((s["position"][:, 2] - mid) ** 2, weights=m))
    sigma_surface = m.sum() / (s["L"][0] * s["L"][1])
    return disp, thick, sigma_surface


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run")
    ap.add_argument("--from", dest="start", type=float, default=1.0, help="average from this many orbits on")
    ap.add_argument("--figure", help="write the surface density of the last snapshot and the time series here")
    ap.add_argument("--json", help="write the table and the averages here")
    a = ap.parse_args()
    paths = sorted(glob.glob(os.path.join(a.run, "snap_*.h5md"))) or sorted(glob.glob(os.path.join(a.run, "snap_*.txt")))
    if not paths:
        sys.exit(f"gravity_wakes.py: no snap_*.h5md (cassini) or snap_*.txt (scripts/gravity-wakes-rebound) in {a.run}")
    rows = []
    for p in paths:
        s = snapshot(p)
        T0 = 2 * math.pi / s["omega"]
        disp, thick, sig = moments(s)
        kc, lam, pitch = wake(s)
        Q = disp[1] * s["omega"] / (3.36 * G * sig)
        rows.append(dict(orbits=s["time"] / T0, wavelength=lam, pitch=pitch, Q=Q, sigma_x=disp[0], sigma_y=disp[1],
                         sigma_z=disp[2], thickness=thick))
    lam_cr = 4 * math.pi ** 2 * G * sig / s["omega"] ** 2
    print(f"Sigma = {sig:.1f} kg/m^2, Omega0 = {s['omega']:.5e} 1/s, Toomre critical wavelength {lam_cr:.1f} m")
    print(f"{'orbits':>7} {'lambda m':>9} {'pitch deg':>9} {'Q':>6} {'sx mm/s':>8} {'sy mm/s':>8} {'sz mm/s':>8} {'H m':>6}")
    for r in rows:
        print(f"{r['orbits']:7.2f} {r['wavelength']:9.1f} {r['pitch']:9.1f} {r['Q']:6.2f} {1e3 * r['sigma_x']:8.3f} "
              f"{1e3 * r['sigma_y']:8.3f} {1e3 * r['sigma_z']:8.3f} {r['thickness']:6.2f}")
    late = [r for r in rows if r["orbits"] >= a.start - 1e-9]
    summary = {"critical_wavelength": lam_cr, "surface_density": sig, "from_orbits": a.start, "snapshots": len(late)}
    if late:
        print(f"mean over {len(late)} snapshots from {a.start:g} orbits (+- standard error):")
        for key in ("wavelength", "pitch", "Q", "sigma_x", "sigma_y", "sigma_z", "thickness"):
            v = np.array([r[key] for r in late])
            err = v.std(ddof=1) / math.sqrt(len(v)) if len(v) > 1 else float("nan")
            summary[key] = [float(v.mean()), float(err)]
            scale = 1e3 if key.startswith("sigma") else 1
            print(f"  {key:10s} {scale * v.mean():9.3f} +- {scale * err:.3f}{' mm/s' if scale > 1 else ''}")
        print(f"  wavelength / critical wavelength = {summary['wavelength'][0] / lam_cr:.2f}")
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"rows": rows, "summary": summary}, f, indent=1)
    if a.figure:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(1, 2, figsize=(11, 4.8))
        s = snapshot(paths[-1])
        order = np.argsort(s["position"][:, 2])
        for img in (-1, 0, 1):  # the patch and its sheared images above and below
            shift = img * s["offset"]
            px = (s["position"][order, 0] + shift - s["lo"][0]) % s["L"][0] + s["lo"][0]
            py = s["position"][order, 1] + img * s["L"][1]
            ax[0].scatter(px, py, s=(s["radius"][order] * 300 / s["L"][0]) ** 2, c=s["position"][order, 2], cmap="viridis",
                          alpha=1.0 if img == 0 else 0.35, linewidths=0)
        ax[0].set_aspect("equal")
        ax[0].set_xlim(s["lo"][0], s["lo"][0] + s["L"][0])
        ax[0].set_ylim(s["lo"][1] - 0.5 * s["L"][1], s["lo"][1] + 1.5 * s["L"][1])
        ax[0].set_xlabel("x (azimuthal, m)")
        ax[0].set_ylabel("y (radial, m)")
        ax[0].set_title(f"t = {rows[-1]['orbits']:.1f} orbits (faint: sheared images)")
        t = [r["orbits"] for r in rows]
        ax[1].plot(t, [r["wavelength"] / lam_cr for r in rows], "o-", label="wavelength / critical wavelength")
        ax[1].plot(t, [r["pitch"] / 25 for r in rows], "s-", label="pitch angle / 25 deg")
        ax[1].plot(t, [r["Q"] for r in rows], "^-", label="Toomre Q")
        ax[1].axhline(1, color="grey", lw=0.5)
        ax[1].set_xlabel("orbits")
        ax[1].legend()
        fig.tight_layout()
        fig.savefig(a.figure, dpi=110)
        print(f"figure: {a.figure}")


if __name__ == "__main__":
    main()

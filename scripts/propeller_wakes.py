#!/usr/bin/python3
"""A moonlet in a self-gravitating ring: does it open a propeller? (issue 18, item 5)

  scripts/propeller_wakes.py RUN [RUN ...] --hill-radius R [--from ORBITS] [--figure PNG]

Per run (H5MD snapshots of a Hill patch with modules moonlet and self-gravity), averaged over
the snapshots from --from orbits on, in the moonlet's frame (x azimuthal, y radial; the shear
carries material at y > 0 towards +x, so the gaps trail downstream at x > 0 for y > 0 and at
x < 0 for y < 0):
  - surface density map (bins of r_H / 4) and the Toomre critical wavelength 4 pi^2 G Sigma / Omega0^2;
  - Michikoshi & Kokubo's ratio r_H / lambda_cr (propeller expected above ~1);
  - gap depth 1 - Sigma_gap / Sigma_mean, Sigma_gap the mean over 2 r_H < |x| < 8 r_H,
    r_H < |y| < 3 r_H on the downstream sides;
  - the thesis's criteria: contrast Sigma_max / Sigma_min of the radial profile averaged over
    3 r_H < |x| < 6 r_H downstream (both sides folded onto y > 0), |y| < 5 r_H (propeller if > 2),
    and the Hill velocity r_H Omega0 against the radial dispersion beyond |y| > 4 r_H (propeller
    if larger).
"""
import argparse, math, os, sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.realpath(__file__)), os.pardir, "python"))
from cassini_tools import G, Run


def frames(run, start):
    """The frames from `start` orbits on, as dicts of the particle columns and the box."""
    out = []
    for frame in Run(run).frames():
        snap = frame.read(columns=["position", "velocity", "mass"])
        omega = snap.frame_rotation
        if snap.time * omega / (2 * math.pi) < start - 1e-9:
            continue
        out.append(dict(x=snap.position, v=snap.velocity, m=snap.mass, omega=omega, rate=snap.shear_rate,
                        lo=snap.origin, L=snap.lengths, t=snap.time))
    return out


def analyse(run, rh, start, bin_size=10.0):
    fs = frames(run, start)
    if not fs:
        raise SystemExit(f"{run}: no snapshots from {start} orbits on")
    lo, L, omega = fs[0]["lo"], fs[0]["L"], fs[0]["omega"]
    nx, ny = int(round(L[0] / bin_size)), int(round(L[1] / bin_size))
    sigma = np.zeros((nx, ny))
    disp = []
    for f in fs:
        h, _, _ = np.histogram2d(f["x"][:, 0], f["x"][:, 1], bins=[nx, ny], range=[[lo[0], lo[0] + L[0]], [lo[1], lo[1] + L[1]]],
                                 weights=f["m"])
        sigma += h / (L[0] / nx * L[1] / ny) / len(fs)
        far = np.abs(f["x"][:, 1]) > 4 * rh
        disp.append(math.sqrt(np.average((f["v"][far, 1] - np.average(f["v"][far, 1], weights=f["m"][far])) ** 2,
                                         weights=f["m"][far])))
    xc = lo[0] + (np.arange(nx) + 0.5) * L[0] / nx
    yc = lo[1] + (np.arange(ny) + 0.5) * L[1] / ny
    X, Y = np.meshgrid(xc, yc, indexing="ij")
    mean = sigma.mean()
    lam = 4 * math.pi ** 2 * G * mean / omega ** 2
    downstream = np.sign(X) == np.sign(Y)
    gap = downstream & (np.abs(X) > 2 * rh) & (np.abs(X) < 8 * rh) & (np.abs(Y) > rh) & (np.abs(Y) < 3 * rh)
    band = downstream & (np.abs(X) > 3 * rh) & (np.abs(X) < 6 * rh) & (np.abs(Y) < 5 * rh)
    edges = np.arange(0, 5 * rh + bin_size, bin_size)
    prof = [sigma[band & (np.abs(Y) >= a) & (np.abs(Y) < b)].mean() for a, b in zip(edges[:-1], edges[1:])
            if np.any(band & (np.abs(Y) >= a) & (np.abs(Y) < b))]
    return dict(run=run, snapshots=len(fs), sigma_mean=mean, critical_wavelength=lam, rh_over_lambda=rh / lam,
                gap_depth=1 - sigma[gap].mean() / mean, contrast=max(prof) / max(min(prof), 1e-30),
                v_hill=rh * omega, dv_y=float(np.mean(disp)), map=sigma, extent=[lo[0], lo[0] + L[0], lo[1], lo[1] + L[1]])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("runs", nargs="+")
    ap.add_argument("--hill-radius", type=float, required=True, help="r_H of the moonlet (m)")
    ap.add_argument("--from", dest="start", type=float, default=0.8, help="average from this many orbits on")
    ap.add_argument("--bin", type=float, default=None, help="map bin (m); default r_H / 4")
    ap.add_argument("--figure")
    a = ap.parse_args()
    res = [analyse(r, a.hill_radius, a.start, a.bin or a.hill_radius / 4) for r in a.runs]
    print(f"{'run':>12} {'Sigma':>7} {'lambda_cr':>9} {'rH/lam':>7} {'gap depth':>9} {'contrast':>8} {'v_H mm/s':>8} {'dv_y mm/s':>9}")
    for r in res:
        print(f"{os.path.basename(r['run'].rstrip('/')):>12} {r['sigma_mean']:7.1f} {r['critical_wavelength']:9.1f} "
              f"{r['rh_over_lambda']:7.2f} {r['gap_depth']:9.2f} {r['contrast']:8.2f} {1e3 * r['v_hill']:8.2f} {1e3 * r['dv_y']:9.2f}")
    if a.figure:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, axes = plt.subplots(1, len(res), figsize=(6 * len(res), 3.8), squeeze=False)
        for ax, r in zip(axes[0], res):
            im = ax.imshow(r["map"].T / r["sigma_mean"], origin="lower", extent=r["extent"], vmin=0, vmax=2.5, cmap="magma",
                           aspect="equal")
            ax.add_patch(plt.Circle((0, 0), a.hill_radius, fill=False, color="cyan", lw=0.8))
            ax.set_title(f"r_H / lambda_cr = {r['rh_over_lambda']:.2f}: gap depth {r['gap_depth']:.2f}")
            ax.set_xlabel("x (azimuthal, m)")
            ax.set_ylabel("y (radial, m)")
            fig.colorbar(im, ax=ax, label="Sigma / mean")
        fig.tight_layout()
        fig.savefig(a.figure, dpi=110)
        print(f"figure: {a.figure}")


if __name__ == "__main__":
    main()

"""Propeller analysis of a ring run (thesis 6.2-6.3) from its H5MD snapshots via cassini-cg.
   /usr/bin/python3 scripts/propeller_analysis.py RUN_DIR [--window 1000] [--end T] [--copy 0] [--out DIR]
Under modified Lees-Edwards boundaries the main box LE1 is analysed (--copy 1: the feed LE2).
Writes sigma_map.png (log10 Sigma, like thesis fig. 6.4), fluctuation_map.png (fig. 6.8),
linecut.png (Sigma along y at x = 990 m) and criteria.json:
  contrast   Sigma_max / Sigma_min along x = 990 m, ignoring 2w near y = +-Ly/2 (propeller if > 2)
  v_H, dv_y  Hill velocity h Omega0 and the radial velocity dispersion (propeller if v_H > dv_y)
"""
import argparse, json, os, subprocess, sys

import h5py
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
sys.path.insert(0, os.path.join(ROOT, "python"))
from cassini_tools import Run, RunError

ap = argparse.ArgumentParser()
ap.add_argument("run")
ap.add_argument("--window", type=float, default=1000.0, help="time-average over the last WINDOW seconds")
ap.add_argument("--width", type=float, default=100.0, help="Gaussian kernel width w (m)")
ap.add_argument("--grid", default="200x50", help="CG grid (thesis: 10,000 points over the box)")
ap.add_argument("--moonlet-mass", type=float, default=1.27e10)
ap.add_argument("--end", type=float, default=None, help="window ends at this time (default: the last snapshot)")
ap.add_argument("--copy", type=int, default=0, help="modified Lees-Edwards runs: 0 = LE1 (main box), 1 = LE2 (feed)")
ap.add_argument("--out", default=None)
a = ap.parse_args()
out = a.out or a.run
os.makedirs(out, exist_ok=True)

try:
    run = Run(a.run)
    snaps = run.frames()
    hill = run.hill()
except RunError as e:
    sys.exit(f"propeller_analysis: error: {e}")
if not snaps:
    sys.exit(f"{a.run}: no snapshots (run with output.snapshot_every)")
t_end = max(s.time for s in snaps) if a.end is None else max(s.time for s in snaps if s.time <= a.end + 1e-6)
frames = [s.path for s in snaps if t_end - a.window <= s.time <= t_end]
fields = os.path.join(out, "fields.h5")
mpirun = ["mpirun", "--oversubscribe"] + (["--allow-run-as-root"] if os.getuid() == 0 else [])
env = dict(os.environ, OMPI_MCA_btl_vader_single_copy_mechanism="none")
subprocess.run(mpirun + ["-n", "2", os.path.join(ROOT, "build", "cassini-cg")] + frames +
               ["--grid", a.grid, "--width", str(a.width), "--kernel", "gauss", "--background", "shear",
                "--copy", str(a.copy), "--out", fields, "--force"], check=True, env=env, stdout=subprocess.DEVNULL)

f = h5py.File(fields)
x, y = f["grid_x"][:], f["grid_y"][:]
sigma = f["density"][:]                 # [ny][nx], mass per area (kg/m^2)
fluct = f["background_fluctuation"][:]  # rms |v - 1.5 Omega0 y e_x|
extent = [x[0], x[-1], y[0], y[-1]]

plt.figure(figsize=(11, 3.2))
plt.imshow(np.log10(np.maximum(sigma, 1e-3)), origin="lower", extent=extent, aspect="auto", cmap="viridis")
plt.colorbar(label="log10 Sigma (kg/m^2)")
plt.xlabel("x (m)"); plt.ylabel("y (m)")
plt.title(f"surface density, t = {t_end:.0f} s, averaged over {len(frames)} frames ({a.window:.0f} s)")
plt.tight_layout(); plt.savefig(os.path.join(out, "sigma_map.png"), dpi=110); plt.close()

plt.figure(figsize=(11, 3.2))
plt.imshow(fluct, origin="lower", extent=extent, aspect="auto", cmap="magma")
plt.colorbar(label="rms |v - 1.5 Omega0 y e_x| (m/s)")
plt.xlabel("x (m)"); plt.ylabel("y (m)")
plt.tight_layout(); plt.savefig(os.path.join(out, "fluctuation_map.png"), dpi=110); plt.close()

# The cut at exactly x = 990 m, interpolated between the two grid columns around it (the
# nearest column can be half a spacing away: 945 m on a 90 m grid).
ix = int(np.searchsorted(x, 990.0)) - 1
wx = (990.0 - x[ix]) / (x[ix + 1] - x[ix])
cut = (1 - wx) * sigma[:, ix] + wx * sigma[:, ix + 1]
Ly = y[-1] - y[0] + (y[1] - y[0])
keep = abs(y) <= Ly / 2 - 2 * a.width
contrast = float(cut[keep].max() / max(cut[keep].min(), 1e-300))
plt.figure(figsize=(6, 4))
plt.plot(y, cut, "-")
plt.axvspan(y[0], -Ly / 2 + 2 * a.width, color="0.9"); plt.axvspan(Ly / 2 - 2 * a.width, y[-1], color="0.9")
plt.xlabel("y (m)"); plt.ylabel("Sigma (kg/m^2)"); plt.title(f"x = 990 m: Sigma_max/Sigma_min = {contrast:.2f}")
plt.tight_layout(); plt.savefig(os.path.join(out, "linecut.png"), dpi=110); plt.close()

h = hill.hill_radius(a.moonlet_mass)
v_h = h * hill.omega0
# radial dispersion: particle data of the last frame (one copy of the box under modified
# Lees-Edwards boundaries), relative to the shear flow
vy = snaps[[s.path for s in snaps].index(frames[-1])].read(columns=["velocity", "le_copy"], copy=a.copy).velocity[:, 1]
dv_y = float(np.std(vy))
result = dict(time=t_end, frames=len(frames), contrast=contrast, propeller_by_contrast=contrast > 2,
              hill_radius=h, v_H=v_h, dv_y=dv_y, propeller_by_velocity=v_h > dv_y)
json.dump(result, open(os.path.join(out, "criteria.json"), "w"), indent=2)
print(json.dumps(result, indent=2))

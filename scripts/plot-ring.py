#!/usr/bin/python3
"""Picture of a ring run from its particle dumps: surface density (log scale) over the patch
and the velocity deviation from the Keplerian shear near the moonlet.
   /usr/bin/python3 scripts/plot-ring.py RUN_DIR [OUT.png]
"""
import math, os, sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.realpath(__file__)), os.pardir, "python"))
from cassini_tools import Run, RunError

run = sys.argv[1]
out = sys.argv[2] if len(sys.argv) > 2 else os.path.join(run, "ring.png")
try:
    ring = Run(run)
    time, data = ring.dump()
    omega0 = ring.hill().omega0
except RunError as e:
    sys.exit(f"plot-ring: error: {e}")
x, y, vx, vy, a = data[:, 3], data[:, 4], data[:, 6], data[:, 7], data[:, 2]

fig, (ax1, ax3, ax2) = plt.subplots(3, 1, figsize=(11, 11))
# Surface density Sigma = 3 rho / (4 a) in the thesis convention = mass per area on the plane.
bins = (180, 40)
mass = 500.0 * 4 / 3 * math.pi * a**3
H, xe, ye = np.histogram2d(x, y, bins=bins, range=[[-9000, 9000], [-1000, 1000]], weights=mass)
H /= (xe[1] - xe[0]) * (ye[1] - ye[0])
im = ax1.imshow(np.log10(H.T + 1e-3), origin="lower", extent=[-9000, 9000, -1000, 1000], aspect="auto", cmap="viridis")
fig.colorbar(im, ax=ax1, label="log10 surface density (kg/m^2)")
ax1.add_patch(plt.Circle((0, 0), 150, color="w", fill=False))
ax1.set_title(f"{os.path.basename(os.path.normpath(run))}: t = {time:.0f} s = {time * omega0 / (2 * math.pi):.2f} orbits")
ax1.set_xlabel("x (azimuthal, m)")
ax1.set_ylabel("y (radial, m)")

# Zoom on the moonlet: surface density relative to the undisturbed ring, smoothed over ~100 m
# (a few particles per bin otherwise). The propeller's two gaps are the dark bands beside the
# moonlet, the outer one (y > 0) at +x and the inner one at -x: the "S".
zx, zy, h = 3000.0, 1000.0, 50.0
Z, _, _ = np.histogram2d(x, y, bins=(int(2 * zx / h), int(2 * zy / h)), range=[[-zx, zx], [-zy, zy]], weights=mass)
g = np.exp(-0.5 * (np.arange(-4, 5) / 1.5) ** 2)
g /= g.sum()
for axis in (0, 1):
    Z = np.apply_along_axis(lambda r: np.convolve(np.pad(r, 4, mode="wrap" if axis == 0 else "edge"), g, "valid"), axis, Z)
Z /= mass.sum() / (18000.0 * 2000.0) * h * h
im = ax3.imshow(Z.T, origin="lower", extent=[-zx, zx, -zy, zy], aspect="auto", cmap="magma", vmin=0, vmax=1.6)
fig.colorbar(im, ax=ax3, label="Sigma / Sigma_0")
ax3.add_patch(plt.Circle((0, 0), 150, color="c", fill=False))
ax3.set_title("near the moonlet: the propeller's gaps (dark) beside the moonlet, outer at +x, inner at -x")
ax3.set_xlabel("x (m)")
ax3.set_ylabel("y (m)")
near = (np.abs(x) < 2500)
dv = np.hypot(vx - 1.5 * omega0 * y, vy)
sc = ax2.scatter(x[near], y[near], c=dv[near], s=2, cmap="magma", vmin=0, vmax=np.percentile(dv, 99))
fig.colorbar(sc, ax=ax2, label="|v - 1.5 Omega0 y e_x| (m/s)")
ax2.add_patch(plt.Circle((0, 0), 150, color="c", fill=False))
ax2.set_xlim(-2500, 2500)
ax2.set_title("velocity deviation from the shear flow: the moonlet's wakes")
ax2.set_ylim(-1000, 1000)
ax2.set_xlabel("x (m)")
ax2.set_ylabel("y (m)")
fig.tight_layout()
fig.savefig(out, dpi=110)
print(out)

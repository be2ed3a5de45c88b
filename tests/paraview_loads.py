#!/usr/bin/python3
"""ParaView opens what cassini writes: the particle .xdmf of a snapshot and cassini-cg's field
.xdmf (2D and 3D grids) load with every array, a 2D field lies in the x-y plane, and
scripts/paraview-screenshots renders both to non-blank images. Skipped (exit 77) without
pvpython (Debian's python3-paraview) and xvfb-run.

usage: paraview_loads.py CASSINI CASSINI_CG REPO WORK MPIEXEC [MPI flags...]
"""
import os
import re
import shutil
import subprocess
import sys

import matplotlib.image as mpimg

cassini, cg, repo, work = (os.path.abspath(a) for a in sys.argv[1:5])
mpi = [sys.argv[5], "-n", "2", *sys.argv[6:]]
if not shutil.which("pvpython") or not shutil.which("xvfb-run"):
    print("pvpython or xvfb-run missing: skipped")
    sys.exit(77)
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
run = os.path.join(work, "gas")
subprocess.run(mpi + [cassini, os.path.join(repo, "cases", "gas"), "--out", run, "--set", "time.end=0.0004",
                      "--set", "output.snapshot_every=0.0002"], check=True, capture_output=True)
fields = ["background_fluctuation", "body_force_density", "density", "momentum", "stress", "velocity",
          "velocity_fluctuation", "wall_traction"]
failures = 0
for grid in ("30x20", "30x20x20"):
    out = os.path.join(work, f"fields_{grid}.h5")
    subprocess.run(mpi + [cg, run, "--grid", grid, "--width", "0.002", "--out", out], check=True, capture_output=True)
    shots = os.path.join(work, f"shots_{grid}")
    p = subprocess.run([os.path.join(repo, "scripts", "paraview-screenshots"), os.path.join(run, "snap_000002000.xdmf"),
                        out.replace(".h5", ".xdmf"), shots], capture_output=True, text=True, timeout=300)
    print(p.stdout)
    loaded = re.search(r"fields: \d+ points, arrays (.*)", p.stdout)
    names = [a.split("(")[0] for a in loaded.group(1).split(", ")] if loaded else []
    b = re.search(r"fields: bounds x \[(\S+), (\S+)\] y \[(\S+), (\S+)\] z \[(\S+), (\S+)\]", p.stdout)
    ok = p.returncode == 0 and sorted(names) == fields and b is not None
    if ok:
        x0, x1, y0, y1, z0, z1 = map(float, b.groups())
        flat = z0 == z1
        ok = (x1 - x0 > 0.02) and (y1 - y0 > 0.01) and (flat == (grid.count("x") == 1))
    for png in ("particles.png", "fields.png"):
        path = os.path.join(shots, png)
        # Not blank: the centre of the picture (away from the colour bar and axes) has structure.
        ok = ok and os.path.exists(path) and mpimg.imread(path)[100:400, 300:1100, :3].std() > 0.01
    print(f"{grid}: {'ok' if ok else 'FAILED'}" + ("" if ok else p.stderr[-2000:]))
    failures += not ok
sys.exit(1 if failures else 0)

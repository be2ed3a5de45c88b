#!/usr/bin/python3
"""Real clients open cassini's output: MDAnalysis reads a snapshot and the whole-run view
(scripts/run-trajectory) the documented way, and sees exactly what h5py reads, frame by frame,
also when the particle count changes between frames (the clogging scene's inlet and outlet).
Skipped (exit 77) when MDAnalysis is not installed.

usage: mdanalysis_reads.py CASSINI REPO WORK MPIEXEC [MPI flags...]
"""
import os
import shutil
import subprocess
import sys
import warnings

import h5py
import numpy as np

try:
    import MDAnalysis as mda
except ImportError:
    print("MDAnalysis not installed: skipped")
    sys.exit(77)
warnings.simplefilter("ignore")

cassini, repo, work = (os.path.abspath(a) for a in sys.argv[1:4])
mpi = [sys.argv[4], "-n", "2", *sys.argv[5:]]
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)


def universe(path):
    """The documented way (README): SI units, so no unit conversion."""
    n = h5py.File(path, "r")["particles/grains/position/value"].shape[1]
    u = mda.Universe.empty(n, trajectory=True)
    u.load_new(path, format="H5MD", convert_units=False)
    return u


failures = 0
for case, sets in (("gas", ["time.end=0.0006", "output.snapshot_every=0.0002"]),
                   ("clogging", ["time.end=0.03", "output.snapshot_every=0.01"])):
    run = os.path.join(work, case)
    cmd = mpi + [cassini, os.path.join(repo, "cases", case), "--out", run]
    for s in sets:
        cmd += ["--set", s]
    subprocess.run(cmd, check=True, capture_output=True)
    frames = sorted(f for f in os.listdir(run) if f.startswith("snap_") and f.endswith(".h5md"))
    u = universe(os.path.join(run, frames[-1]))
    with h5py.File(os.path.join(run, frames[-1]), "r") as h:
        same = np.array_equal(u.atoms.positions.astype(float), h["particles/grains/position/value"][0].astype(np.float32))
    print(f"{case}: MDAnalysis reads {frames[-1]}: positions {'equal' if same else 'DIFFER'} to h5py's")
    failures += not same
    subprocess.run([os.path.join(repo, "scripts", "run-trajectory"), run], check=True)
    u = universe(os.path.join(run, "trajectory.h5md"))
    counts = []
    for ts, f in zip(u.trajectory, frames):
        with h5py.File(os.path.join(run, f), "r") as h:
            x = h["particles/grains/position/value"][0]
            t = h["particles/grains/position/time"][0]
        n = len(x)
        counts.append(n)
        ok = (np.array_equal(ts.positions[:n], x.astype(np.float32)) and np.isnan(ts.positions[n:]).all()
              and abs(ts.time - t) <= 1e-12 * max(1, abs(t)))
        failures += not ok
        if not ok:
            print(f"{case}: frame {ts.frame} ({f}) differs from the snapshot")
    print(f"{case}: whole-run view: {len(u.trajectory)} frames of {len(frames)}, particle counts {counts}")
    failures += len(u.trajectory) != len(frames)
    if case == "clogging" and len(set(counts)) < 2:
        print("clogging: the particle count did not change between frames: the test would not see it")
        failures += 1
sys.exit(1 if failures else 0)

#!/usr/bin/python3
"""python/cassini_tools, the scripts' shared reader, against the files it reads.

A 2-rank gas run with snapshots, text dumps and an ensemble; a ring-section run for the Hill
frame. Checks: the reader returns what h5py and the csv module read directly (bit for bit); the
text dump (written independently, per rank) agrees with the snapshot of the same step to its 6
printed digits; the Hill constants equal Omega0 = sqrt(G M / r0^3) computed here, and the
solver's own frame_rotation stored in the snapshot (C++) to 1e-14; bad input is a RunError
naming the file.

usage: python_tools.py CASSINI SOURCE_DIR WORK MPIEXEC [MPI flags...]
"""
import csv
import math
import os
import shutil
import subprocess
import sys

import h5py
import numpy as np

cassini, source, work = (os.path.abspath(a) for a in sys.argv[1:4])
mpi = [sys.argv[4], "-n", "2", *sys.argv[5:]]
sys.path.insert(0, os.path.join(source, "python"))
from cassini_tools import ContinuedRun, Run, RunError, G, launch  # noqa: E402

shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
failures = []


def check(name, ok, detail=""):
    print(("PASS " if ok else "FAIL ") + name + ("" if ok else ": " + str(detail)[-800:]))
    if not ok:
        failures.append(name)


def run(args):
    p = subprocess.run([*mpi, cassini, *args], cwd=work, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"FAIL: cassini {' '.join(args)} exited {p.returncode}\n{p.stdout[-2000:]}{p.stderr[-2000:]}")


run([f"{source}/cases/gas", "--out", "gas", "--set", "time.end=2e-5", "--set", "output.snapshot_every=1e-5",
     "--set", "output.dump_every=1e-5", "--set", "output.observe_every=2e-6"])
r = Run(f"{work}/gas")
check("summary", r.summary["status"] == "completed" and r.summary["final_step"] == 100, r.summary)
check("case", r.case["seed"] == 7 and r.case["species"][0]["radius"] == 0.0005, r.case)
obs = r.observables()
with open(f"{work}/gas/observables.csv") as f:
    rows = list(csv.DictReader(f))
check("observables.csv: every row and column", len(obs["time"]) == len(rows) == 11
      and all(obs[k][i] == float(rows[i][k]) for k in rows[0] for i in range(len(rows))), len(rows))
with h5py.File(f"{work}/gas/observables.h5md") as f:
    ke = f["observables/kinetic_energy/value"][:]
check("observables.csv and observables.h5md agree (12 printed digits)",
      np.allclose(ke, obs["kinetic_energy"], rtol=1e-11, atol=0), (ke, obs["kinetic_energy"]))
frames = r.frames()
check("frames: every snapshot in step order", [f.step for f in frames] == [0, 50, 100]
      and [f.time for f in frames] == [0.0, 1e-5, 2e-5], [(f.step, f.time) for f in frames])
check("frames in a time window", [f.step for f in r.frames(start=0.5e-5, end=2e-5)] == [50, 100])
snap = frames[-1].read()
with h5py.File(frames[-1].path) as f:
    x = f["particles/grains/position/value"][0]
    ids = f["particles/grains/id/value"][0]
check("a snapshot's columns as h5py reads them", np.array_equal(snap.position, x) and np.array_equal(snap.id, ids)
      and len(snap) == 6875 and snap.step == 100, snap.step)
check("a snapshot's box and case", np.allclose(snap.lengths, [0.03, 0.02, 0.02], rtol=1e-15)
      and snap.boundary == ["periodic"] * 3 and snap.case["seed"] == 7, (snap.lengths, snap.boundary))
t, d = r.dump()
check("the last text dump, all ranks, in id order", t == snap.time and len(d) == 6875
      and np.array_equal(d[:, 0], snap.id.ravel()), (t, len(d)))
check("the text dump agrees with the snapshot of the same step (6 digits)",
      np.allclose(d[:, 3:6], snap.position, rtol=1e-5, atol=1e-9), np.abs(d[:, 3:6] - snap.position).max())

run([f"{source}/cases/gas", "--out", "ens", "--ensemble", "2", "--set", "time.end=2e-6"])
rows = Run(f"{work}/ens").ensemble()
check("ensemble.csv rows, numbers as float", len(rows) == 2 and rows[1]["seed"] == 8.0 and rows[0]["clog_time"] is None,
      rows)

run([f"{source}/cases/ring-section", "--out", "ring", "--set", "particles.count=1000", "--set", "time.end=10",
     "--set", "output.snapshot_every=10"])
ring = Run(f"{work}/ring")
hill = ring.hill()
omega0 = math.sqrt(6.674e-11 * 5.68e26 / 1.17e8 ** 3)
stored = ring.frames()[-1].read(columns=["id"]).frame_rotation
check("Hill frame: Omega0 = sqrt(G M / r0^3), the solver's own to 1e-14",
      abs(hill.omega0 / omega0 - 1) < 1e-14 and abs(hill.omega0 / stored - 1) < 1e-14 and G == 6.674e-11,
      (hill.omega0, omega0, stored))
check("Hill frame: T0, shear rate, Hill radius", abs(hill.period - 2 * math.pi / omega0) < 1e-9
      and abs(hill.shear_rate / (1.5 * omega0) - 1) < 1e-14
      and abs(hill.hill_radius(1.27e10) / (1.17e8 * (1.27e10 / (3 * 5.68e26)) ** (1 / 3)) - 1) < 1e-14)

for label, thunk, needle in (
        ("a missing run", lambda: Run(f"{work}/nope"), "no such directory"),
        ("a file as a run", lambda: Run(f"{work}/gas/summary.json"), "is a file"),
        ("an observables file as a snapshot",
         lambda: __import__("cassini_tools").Snapshot(f"{work}/gas/observables.h5md"), "observables.h5md"),
        ("a truncated snapshot", lambda: (open(f"{work}/trunc.h5md", "wb").write(open(frames[1].path, "rb").read(2000)),
                                          __import__("cassini_tools").Snapshot(f"{work}/trunc.h5md")), "trunc.h5md"),
        ("a dump of a step never dumped", lambda: Run(f"{work}/gas").dump(step=7), "step 7")):
    try:
        thunk()
        check(f"{label} is refused", False, "no error")
    except RunError as e:
        check(f"{label} is refused naming it", needle in str(e), e)

# launch() and ContinuedRun, the studies' way to run cassini and to continue a run stopped
# part-way: a copy of the gas run cut back to step 50 (as if killed there) continues from that
# snapshot into gasc-part1 and ends where the uninterrupted run did (restart exactness is the
# solver's; this checks the parts, the restart point and the overrides are passed right), the
# cut run is not touched, and a failed run is a RunError naming its log.
gas_sets = ["time.end=2e-5", "output.snapshot_every=1e-5", "output.dump_every=0", "output.observe_every=2e-6"]
shutil.copytree(f"{work}/gas", f"{work}/gasc")
for name in ("snap_000000100.h5md", "summary.json"):
    os.remove(f"{work}/gasc/{name}")
cut = ContinuedRun(f"{work}/gasc")
out, restart = cut.next()
check("ContinuedRun: a run cut at step 50 continues from it into a new part",
      not cut.finished() and out == f"{work}/gasc-part1" and restart == f"{work}/gasc/snap_000000050.h5md", (out, restart))
shutil.copytree(f"{work}/gasc", f"{work}/gasd")
os.makedirs(f"{work}/gasd-part1")  # a continuation killed before its first snapshot
check("ContinuedRun: a part that wrote no snapshot is redone in place, from the snapshot before it",
      ContinuedRun(f"{work}/gasd").next() == (f"{work}/gasd-part1", f"{work}/gasd/snap_000000050.h5md"),
      ContinuedRun(f"{work}/gasd").next())
seconds, stopped = launch([*mpi, cassini, f"{source}/cases/gas"], out, gas_sets, restart=restart)
end = cut.frames()[-1].read(columns=["id", "position"])
ref = frames[-1].read(columns=["id", "position"])
check("ContinuedRun + launch: the parts are the uninterrupted run (steps 0, 50, 100; bitwise at 100)",
      not stopped and cut.finished() and [f.step for f in cut.frames()] == [0, 50, 100]
      and os.path.exists(f"{work}/gasc-part1.log") and sorted(os.listdir(f"{work}/gasc")) == sorted(
          n for n in os.listdir(f"{work}/gas") if n not in ("snap_000000100.h5md", "summary.json"))
      and np.array_equal(end.position[np.argsort(end.id)], ref.position[np.argsort(ref.id)]),
      [f.path for f in cut.frames()])
# A completed run asked to go further (a study's --orbits raised) is not finished: it continues
# from its last snapshot into the next part and then is. Its end (step 130) is no multiple of
# snapshot_every (50 steps): the run still ends with a frame of its final state.
longer = ["time.end=2.6e-5" if s.startswith("time.end=") else s for s in gas_sets]
out, restart = cut.next()
check("ContinuedRun: a completed run asked to go further continues from its last snapshot",
      cut.finished(until=2e-5) and not cut.finished(until=2.6e-5)
      and (out, restart) == (f"{work}/gasc-part2", f"{work}/gasc-part1/snap_000000100.h5md"), (out, restart))
launch([*mpi, cassini, f"{source}/cases/gas"], out, longer, restart=restart)
check("ContinuedRun: ... and reaches the new end with a frame there (steps 0, 50, 100, 130)",
      cut.finished(until=2.6e-5) and [f.step for f in cut.frames()] == [0, 50, 100, 130], [f.path for f in cut.frames()])
try:
    launch([*mpi, cassini, f"{source}/cases/gas"], f"{work}/gas-bad", gas_sets + ["time.dt=-1"])
    check("launch: a failed run is refused", False, "no error")
except RunError as e:
    check("launch: a failed run is a RunError naming its log", "gas-bad.log" in str(e), e)

print(f"{len(failures)} failed")
sys.exit(1 if failures else 0)

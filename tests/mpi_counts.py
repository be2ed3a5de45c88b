#!/usr/bin/python3
"""summary.json's MPI counts (src/parallel/MpiCounters.cpp) against what the step loop is
designed to do, on 2 ranks.

- Point-to-point: the PMPI count of sends must cover the halo's own count of its messages
  (two independent counters of the same traffic; the PMPI one also sees migration's).
- Collectives: the plain step makes one reduction (rebuild? guard?), the progress check one
  every 64 steps, the energy guard two every 100; rebuilds add a few. The multi-rate ring's contact steps are designed to need
  no more than that: wake-ups reach the ghosts by neighbour messages, not by a collective
  (it was two per contact step).

usage: mpi_counts.py CASSINI SOURCE_DIR WORK MPIEXEC [MPI flags...]
"""
import json
import os
import shutil
import subprocess
import sys

cassini, source, work = (os.path.abspath(a) for a in sys.argv[1:4])
mpi = [sys.argv[4], "-n", "2", *sys.argv[5:]]
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
failures = []


def check(name, ok, detail=""):
    print(("PASS " if ok else "FAIL ") + name + ("" if ok else ": " + str(detail)))
    if not ok:
        failures.append(name)


def summary(case, out, *sets):
    args = [f"{source}/cases/{case}", "--out", out]
    for s in sets:
        args += ["--set", s]
    p = subprocess.run([*mpi, cassini, *args], cwd=work, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"FAIL: cassini {' '.join(args)} exited {p.returncode}\n{p.stdout[-2000:]}{p.stderr[-2000:]}")
    with open(os.path.join(work, out, "summary.json")) as f:
        return json.load(f)


gas = summary("gas", "gas", "time.end=0.002", "output.observe_every=0.002")
m = gas["mpi_per_step_per_rank"]
rebuilds = gas["neighbour_rebuilds"] / gas["steps"]
# The halo counts from set-up on (its first ghost build), PMPI from the step loop on: 0.1 % slack.
check("gas: sends counted by PMPI cover the halo's messages",
      m["send"]["calls"] * 2 >= 0.999 * gas["halo_messages_per_step"] > 0, (m["send"], gas["halo_messages_per_step"]))
check("gas: the halo's bytes are among the bytes sent",
      m["send"]["bytes"] * 2 >= 0.999 * gas["halo_bytes_per_step"] > 0, (m["send"], gas["halo_bytes_per_step"]))
periodic = 1 / 64 + 2 / 100
check("gas: one reduction per step, progress and energy checks, a few per rebuild",
      1.0 <= m["collectives"] <= 1.0 + periodic + 6 * rebuilds + 0.002, (m["collectives"], rebuilds))
check("gas: the per-step reduction is in the comm stage",
      abs(m["collectives_by_stage"]["comm"] - 1.0) <= 6 * rebuilds + 0.01, m["collectives_by_stage"])

ring = summary("propeller", "ring", "time.end=2000", "output.dump_every=0", "output.observe_every=2000")
m = ring["mpi_per_step_per_rank"]
rebuilds = ring["neighbour_rebuilds"] / ring["steps"]
check("multi-rate ring: no collective beyond the plain step's",
      m["collectives"] <= 1.0 + periodic + 8 * rebuilds + 0.002, (m["collectives"], m["collectives_by_stage"], rebuilds))
check("multi-rate ring: the integrator makes no collective on contact steps",
      m["collectives_by_stage"]["integrate"] < 0.01, m["collectives_by_stage"])

print(f"{len(failures)} failure(s)")
sys.exit(1 if failures else 0)

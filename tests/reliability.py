#!/usr/bin/python3
"""Nothing lost, nothing hangs, nothing unexplained: cassini's command-line and fault contract.

Runs the solver (and cassini-cg) as a user would, on a tiny gas, and checks how each bad
input, dangerous --out, mismatched restart, guard stop and full disk ends: exit code, one
clear message naming what went wrong, valid summary.json, and no file of the user's touched.
A full disk is a real tmpfs when this runs as root and may mount one; otherwise the
write-failure injection (CASSINI_FAIL_WRITE) stands in for it. Prints one line per case.

usage: reliability.py CASSINI CASSINI_CG CASE_DIR WORK MPIEXEC [MPI flags...]
"""
import json
import os
import re
import shutil
import subprocess
import sys
import time

import h5py

cassini, cg, case_dir, work, mpiexec = [os.path.abspath(a) if i < 4 else a for i, a in enumerate(sys.argv[1:6])]
mpi_flags = sys.argv[6:]
results = []


def run(args, ranks=2, cwd=None, env=None, exe=None, timeout=120):
    """Runs cassini (or exe) under mpiexec; returns (exit code, stdout + stderr, seconds)."""
    full_env = dict(os.environ, **(env or {}))
    cmd = [mpiexec, "-n", str(ranks), *mpi_flags]
    for k in (env or {}):
        cmd += ["-x", k]
    cmd += [exe or cassini, *args]
    t0 = time.time()
    try:
        p = subprocess.run(cmd, cwd=cwd or work, env=full_env, capture_output=True, text=True, timeout=timeout)
        return p.returncode, p.stdout + p.stderr, time.time() - t0
    except subprocess.TimeoutExpired as e:
        return "hung", str(e.stdout or "") + str(e.stderr or ""), time.time() - t0


def check(name, ok, detail=""):
    results.append((name, bool(ok)))
    print(("PASS " if ok else "FAIL ") + name + ("" if ok else ": " + detail[-1500:]))


def write(path, text):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        f.write(text)


def summary(run_dir):
    with open(os.path.join(run_dir, "summary.json")) as f:
        return json.load(f)  # raises on inf/NaN or broken JSON


def complete_frames(run_dir):
    """Every snap_*.h5md must open and carry parameters@complete; returns their names."""
    names = sorted(f for f in os.listdir(run_dir) if f.endswith(".h5md") and f.startswith("snap_"))
    for n in names:
        with h5py.File(os.path.join(run_dir, n), "r") as f:
            assert f["parameters"].attrs["complete"] in (b"yes", "yes"), n
    return names


shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
shutil.copytree(case_dir, os.path.join(work, "gas"))
short = ["--set", "time.end=2e-5", "--set", "output.snapshot_every=1e-5"]

# ---- 1. --force never deletes what cassini did not make
rc, out, _ = run(["gas", "--out", "gas", "--force", *short])
check("--out = the case directory is refused", rc == 2 and "holds" in out and os.path.exists(f"{work}/gas/case.toml"), out)
write(f"{work}/afile", "user data\n")
rc, out, _ = run(["gas", "--out", "afile", "--force", *short])
check("--out = a regular file is refused", rc == 2 and open(f"{work}/afile").read() == "user data\n", out)
os.makedirs(f"{work}/sub/deeper", exist_ok=True)
write(f"{work}/sub/keep.txt", "keep\n")
for target in (".", ".."):
    rc, out, _ = run([f"{work}/gas", "--out", target, "--force", *short], cwd=f"{work}/sub/deeper")
    check(f"--out {target} (working directory or a parent) is refused",
          rc == 2 and "working directory" in out and os.path.exists(f"{work}/sub/keep.txt"), out)
write(f"{work}/mine/precious.txt", "thesis draft\n")
rc, out, _ = run(["gas", "--out", "mine", "--force", *short])
check("--force on a directory cassini did not make is refused",
      rc == 2 and "nothing was deleted" in out and os.path.exists(f"{work}/mine/precious.txt"), out)
rc, out, _ = run(["gas", "--out", "r1", *short])
check("a first run completes", rc == 0 and os.path.exists(f"{work}/r1/snap_000000100.h5md"), out)
write(f"{work}/r1/notes.txt", "x")
rc, out, _ = run(["gas", "--out", "r1", *short])
check("an existing run directory without --force is refused", rc == 2 and "--force" in out, out)
rc, out, _ = run(["gas", "--out", "r1", "--force", *short])
check("--force replaces a run directory cassini made", rc == 0 and not os.path.exists(f"{work}/r1/notes.txt"), out)

# --force never deletes an input the case names: particles.file in a run directory, the flow cache
rc, out, _ = run(["gas", "--out", "holder", *short])
write(f"{work}/holder/p.txt", "0.02 0.01 0.01 0 0 0 0.0005\n")
case = open(f"{work}/gas/case.toml").read()
case = case.replace('init = "random"', f'init = "file"\nfile = "{work}/holder/p.txt"').replace("volume_fraction = 0.3\n", "")
write(f"{work}/fromfile/case.toml", case.replace("velocity_sigma = 0.1             # m/s per component\n", ""))
rc, out, _ = run(["fromfile", "--out", "holder", "--force", *short])
check("--force on the run directory holding particles.file is refused, the file kept",
      rc == 2 and "particles.file" in out and os.path.exists(f"{work}/holder/p.txt"), out)
shutil.copytree(os.path.join(os.path.dirname(case_dir), "clogging"), f"{work}/clog")  # with its flow cache, if any
rc, out, _ = run(["gas", "--out", "clog/other-cache", *short])
rc, out, _ = run(["clog", "--out", "clog/other-cache", "--force", "--set", 'flow.cache="other-cache"'])
check("--force on the flow cache directory is refused", rc == 2 and "flow.cache" in out
      and os.path.exists(f"{work}/clog/other-cache/summary.json"), out)

# ---- 2. restarts check what they continue, and never delete their source
snap = "r1/snap_000000050.h5md"
rc, out, _ = run(["gas", "--restart", snap, "--out", "r1", "--force"])
check("continuing in place is refused up front, the source kept",
      rc == 2 and "continuing a run in place" in out and os.path.exists(f"{work}/{snap}"), out)
rc, out, _ = run(["gas", "--restart", "r1/nope.h5md", "--out", "r2"])
check("a missing restart file is named, nothing created",
      rc == 2 and "no such file" in out and not os.path.exists(f"{work}/r2"), out)
for key, value in (("species.0.radius", "0.0004"), ("species.0.density", "2600.0"), ("domain.hi", "[0.04, 0.02, 0.02]"),
                   ("particles.volume_fraction", "0.25")):
    rc, out, _ = run(["gas", "--restart", snap, "--out", "r2", "--set", f"{key}={value}"])
    short_key = key.replace(".0.", "[0].")
    check(f"restart with another {key} is refused naming the key",
          rc == 2 and short_key in out and "was made with" in out and not os.path.exists(f"{work}/r2"), out)
rc, out, _ = run(["gas", "--restart", snap, "--out", "r2", "--set", "time.end=3e-5", "--set", "guards.max_overlap=0.3",
                  "--set", "output.snapshot_every=1e-5"])
check("restart with a new end time and guards runs", rc == 0, out)
run_id = summary(f"{work}/r1")["run_id"]
check("a continuation keeps the run id", summary(f"{work}/r2")["run_id"] == run_id and run_id, str(run_id))
s2 = summary(f"{work}/r2")
check("summary.json says which code, when, where, how and from what",
      all(s2.get(k) for k in ("version", "commit", "started", "ended_at", "host", "ranks", "command"))
      and "--set time.end=3e-5" in s2["command"] and str(s2.get("restarted_from", "")).endswith(snap)
      and summary(f"{work}/r1")["restarted_from"] is None, str(s2))
# A snapshot from before contact.scheme existed (no contact_scheme attribute) continues with the
# scheme it was made with, Verlet, and says so; a current one continues with its own.
with h5py.File(f"{work}/{snap}", "r") as f:
    scheme_attr = f["parameters"].attrs.get("contact_scheme")
check("a snapshot records its contact scheme", scheme_attr in (b"exact", "exact"), str(scheme_attr))
shutil.copy(f"{work}/{snap}", f"{work}/legacy.h5md")
with h5py.File(f"{work}/legacy.h5md", "a") as f:
    del f["parameters"].attrs["contact_scheme"]
rc, out, _ = run(["gas", "--restart", "legacy.h5md", "--out", "r_legacy", "--set", "time.end=3e-5"])
check("a snapshot older than contact.scheme continues with Verlet, and says so",
      rc == 0 and 'continuing with "verlet"' in open(f"{work}/r_legacy/run.log").read(), out)

# ---- 3. every stop is explained; summary.json is always valid JSON
s = summary(f"{work}/r1")
check("summary.json of a completed run", s["status"] == "completed" and s["stop_reason"] == "reached time.end", str(s))
# Per-stage timers (as LAMMPS prints them): every stage on every rank, min <= mean <= max, the
# means adding up to the wall time (the "other" stage is the rest), the pair loop doing work.
st = s.get("stage_seconds", {})
stages = ("integrate", "pair", "neighbour", "comm", "modules", "output", "other")
check("summary.json has the time per stage",
      all(k in st and 0 <= st[k]["min"] <= st[k]["mean"] <= st[k]["max"] for k in stages)
      and abs(sum(st[k]["mean"] for k in stages) / s["wall_seconds"] - 1) < 1e-6 and st["pair"]["mean"] > 0, str(st))
check("run.log has the table of time per stage", "time per stage" in open(f"{work}/r1/run.log").read(), "")
guard_re = re.compile(r"guard tripped at step \d+, t = [0-9.e+-]+ s, rank \d: .*particle \d+")
for label, line, needle in (("1e308 speed", "0.02 0.01 0.01 1e308 0 0 0.0005", "tunnelling"),
                            ("ten diameters per step", "0.02 0.01 0.01 5000 0 0 0.0005", "tunnelling")):
    write(f"{work}/fast/p.txt", line + "\n0.025 0.01 0.01 0 0 0 0.0005\n")
    case = open(f"{work}/gas/case.toml").read()
    case = case.replace('init = "random"', 'init = "file"\nfile = "p.txt"').replace("volume_fraction = 0.3\n", "")
    case = case.replace("velocity_sigma = 0.1             # m/s per component\n", "")
    write(f"{work}/fast/case.toml", case)
    out_dir = f"fast_{label.split()[0]}"
    rc, out, _ = run(["fast", "--out", out_dir, "--set", "time.end=1e-5"])
    s = summary(f"{work}/{out_dir}")
    dumps = os.listdir(f"{work}/{out_dir}/dump")
    m = re.search(r"at step (\d+)", s.get("stop_reason", ""))
    check(f"{label}: guard stop with step, time, rank, particle, cause; valid summary",
          rc == 3 and guard_re.search(out) and needle in out and s["status"] == "stopped by a guard"
          and needle in s["stop_reason"], out)
    check(f"{label}: the diagnostic dump is of the step reported",
          m and any(d.startswith("diagnostic_%09d" % int(m.group(1))) for d in dumps), str(dumps) + out)
write(f"{work}/ovl/p.txt", "0.02 0.01 0.01 0 0 0 0.0005\n0.0205 0.01 0.01 0 0 0 0.0005\n")
write(f"{work}/ovl/case.toml", open(f"{work}/fast/case.toml").read())
rc, out, _ = run(["ovl", "--out", "ovl_run"])
s = summary(f"{work}/ovl_run")
log = open(f"{work}/ovl_run/run.log").read()
check("an error after the output exists reaches run.log and summary.json",
      rc == 2 and s["status"] == "error" and "overlap" in s["stop_reason"] and "overlap" in log, out + log)

def interrupted_run(args, sig, out_dir):
    """Starts cassini under mpiexec, sends `sig` to mpiexec once the step loop runs (as a
    scheduler or Ctrl-C would); returns (exit code, output, seconds from the signal to the end)."""
    import signal as _signal
    cmd = [mpiexec, "-n", "2", *mpi_flags, cassini, *args, "--out", out_dir, "--set", "output.progress_every=0.05"]
    p = subprocess.Popen(cmd, cwd=work, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    text = ""
    for line in p.stdout:  # the first progress line: the step loop is running
        text += line
        if line.startswith("step ") or line.startswith("run "):
            break
    t0 = time.time()
    p.send_signal(sig)
    try:
        text += p.communicate(timeout=60)[0]
    except subprocess.TimeoutExpired:
        p.kill()
        return "hung", text, time.time() - t0
    return p.returncode, text, time.time() - t0


import signal
for sig, name in ((signal.SIGTERM, "SIGTERM"), (signal.SIGINT, "SIGINT")):
    # (mpirun passes SIGINT on to the ranks as SIGTERM)
    rc, out, secs = interrupted_run(["gas", "--set", "time.end=1", "--set", "output.snapshot_every=1e-4"], sig,
                                    f"intr_{name}")
    s = summary(f"{work}/intr_{name}")
    m = re.search(r"at step (\d+), t = ", s.get("stop_reason", ""))
    check(f"{name} to mpirun: every rank stops at a step boundary, summary.json says interrupted with the step "
          f"({secs:.1f} s)", rc != "hung" and s["status"] == "interrupted" and "interrupted by SIG" in s["stop_reason"] and m
          and int(m.group(1)) == s["final_step"], out + str(s))
    try:
        complete_frames(f"{work}/intr_{name}")
        whole = not any(f.endswith(".partial") for f in os.listdir(f"{work}/intr_{name}"))
        check(f"{name}: every frame left is complete", whole, str(os.listdir(f"{work}/intr_{name}")))
    except Exception as e:
        check(f"{name}: every frame left is complete", False, str(e))
rc, out, _ = interrupted_run(["gas", "--set", "time.end=1", "--set", "output.snapshot_on_signal=true"], signal.SIGTERM,
                             "intr_snap")
s = summary(f"{work}/intr_snap")
last = f"intr_snap/snap_{s['final_step']:09d}.h5md"
check("output.snapshot_on_signal: the interrupted run leaves a snapshot of its last step",
      s["status"] == "interrupted" and os.path.exists(f"{work}/{last}"), out + str(s))
rc, out, _ = run(["gas", "--restart", last, "--out", "intr_cont", "--set", f"time.end={s['simulated_time'] + 2e-6}"])
check("... from which the run continues", rc == 0 and summary(f"{work}/intr_cont")["status"] == "completed", out)
rc, out, _ = run(["gas", "--ensemble", "2", "--out", "ens_done", "--set", "time.end=2e-6"])
s = summary(f"{work}/ens_done")
check("an ensemble that completes writes summary.json",
      rc == 0 and s["status"] == "completed" and s["runs_finished"] == 2 and s["ensemble_runs"] == 2, out + str(s))
rc, out, _ = interrupted_run(["gas", "--ensemble", "40", "--set", "time.end=2e-4"], signal.SIGTERM, "ens_intr")
s = summary(f"{work}/ens_intr")
rows = open(f"{work}/ens_intr/ensemble.csv").read().splitlines()
check("an interrupted ensemble says so and keeps the finished runs' rows",
      rc != "hung" and s["status"] == "interrupted" and s["runs_finished"] == len(rows) - 1 < 40, out + str(s))

# ---- 4. exit codes and messages
for label, args, code, needle in (
        ("unknown option", ["gas", "--bogus"], 2, "--bogus"),
        ("no case", [], 2, "case is required"),
        ("--help", ["--help"], 0, "Usage"),
        ("missing case", ["nowhere"], 2, "no such case file"),
        ("--ensemble 0", ["gas", "--ensemble", "0"], 2, "ensemble")):
    rc, out, _ = run(args)
    check(f"{label}: exit {code}", rc == code and needle in out, f"rc={rc} {out}")
os.makedirs(f"{work}/dircase/case.toml", exist_ok=True)
rc, out, _ = run(["dircase", "--out", "x1"])
check("case.toml that is a directory is refused", rc == 2 and "is a directory" in out, out)
write(f"{work}/typo/case.toml", open(f"{work}/gas/case.toml").read().replace("end = 0.02", "ned = 0.02"))
rc, out, _ = run(["typo", "--out", "x2"])
check("a typo of a required key names what was written", rc == 2 and "time.end" in out and "time.ned" in out, out)
write(f"{work}/typo2/case.toml", open(f"{work}/gas/case.toml").read().replace("[time]", "[tme]"))
rc, out, _ = run(["typo2", "--out", "x3"])
check("a misspelt table is reported, not only the keys it hides", rc == 2 and "tme.end" in out, out)
write(f"{work}/nan/p.txt", "0.02 0.01 0.01 0 nan 0 0.0005\n")
write(f"{work}/nan/case.toml", open(f"{work}/fast/case.toml").read())
rc, out, _ = run(["nan", "--out", "x4"])
check("NaN in an init file names the field", rc == 2 and "field 'vy'" in out, out)
rc, out, _ = run(["gas", "--out", "x5", "--set", "particles.volume_fraction=0.3", "--set", "domain.hi=[30.0,20.0,20.0]"])
check("a particle count that cannot fit is refused with the memory it needs", rc == 2 and "GB" in out, out)

# Nonsense is refused by name (each was once accepted silently)
gas_case = open(f"{work}/gas/case.toml").read()
write(f"{work}/twopair/case.toml", gas_case + '\n[[pair]]\nspecies = ["glass", "glass"]\ne = 0.8\n'
      '\n[[pair]]\nspecies = ["glass", "glass"]\ne = 0.7\n')
write(f"{work}/outside/p.txt", "0.05 0.01 0.01 0 0 0 0.0005\n")
write(f"{work}/outside/case.toml", open(f"{work}/fast/case.toml").read())
write(f"{work}/hertz/case.toml", gas_case.replace("t_c = 1.0e-5                     # s, contact duration",
                                                  'model = "hertz"\nyoungs_modulus = 6.3e10\nimpact_speed = 0.001'))
os.mkfifo(f"{work}/fifo.toml")
for label, args, key in (
        ("time.end beyond 9e15 steps", ["gas", "--set", "time.end=1e300"], "time.end"),
        ("output.observe_every = 0", ["gas", "--set", "output.observe_every=0"], "output.observe_every"),
        ("two [[pair]] tables for one pair", ["twopair"], "pair[1].species"),
        ("a bead outside the periodic box", ["outside"], "outside the box"),
        ("a Hertz impact_speed far below the initial speeds", ["hertz"], "species[0].impact_speed"),
        ("a FIFO as the case file", ["fifo.toml"], "not a regular file"),
        ("a restart whose end is not after the snapshot", ["gas", "--restart", snap, "--set", "time.end=1e-5"],
         "time.end"),
        ("clog.count_from < 0", ["clog", "--set", "clog.count_from=-1"], "clog.count_from"),
        ("a continuous-mode key in single mode", ["clog", "--set", "clog.avalanches=3"], "clog.avalanches"),
        ("a self-gravity mesh larger than memory",
         ["gas", "--set", 'modules=["contact","self-gravity"]', "--set", 'domain.boundary=["periodic","periodic","open"]',
          "--set", "self_gravity.grid=[4096,4096,4096]"], "self_gravity.grid")):
    rc, out, secs = run([*args, "--out", f"refused_{key.split()[0]}"], timeout=60)
    check(f"{label}: refused naming {key}", rc == 2 and key in out, out)
# Restarts compare what the cases resolve to, not how they are spelt
rc, out, _ = run(["gas", "--restart", snap, "--out", "r_default", "--set", 'contact.scheme="exact"',
                  "--set", "time.end=3e-5"])
check("a restart that writes a default out (contact.scheme = \"exact\") runs", rc == 0, out)
write(f"{work}/gas_dt/case.toml", gas_case.replace("n_c = 50                         # dt = t_c / 50", "dt = 2.0e-7"))
rc, out, _ = run(["gas_dt", "--restart", snap, "--out", "r_dt", "--set", "time.end=3e-5"])
check("a restart giving dt for the equivalent n_c runs", rc == 0, out)
rc, out, _ = run(["gas_dt", "--restart", snap, "--out", "r_dt2", "--set", "time.end=3e-5", "--set", "time.dt=1e-7"])
check("... and another dt is refused naming time.dt", rc == 2 and "time.dt" in out, out)
rc, out, _ = run(["clog", "--ensemble", "2", "--out", "ens_snap", "--set", "output.snapshot_every=0.1",
                  "--set", "time.end=0.001"])
check("--ensemble with snapshots set says they are not written", rc == 0 and "output.snapshot_every" in out, out)
rc, out, _ = run(["clog", "--out", "clog_eta", "--set", "time.end=0.05", "--set", "output.progress_every=0.01"])
check("a run a clog may end early gives its ETA as an upper bound", rc == 0 and "ETA <= " in out and "(or at a clog)" in out,
      out)

# ---- 5. cassini-cg
rc, out, _ = run(["r1/snap_000000100.h5md", "r1/snap_999.h5md"], exe=cg)
check("cassini-cg names a missing snapshot", rc == 2 and "no such snapshot" in out, out)
rc, out, _ = run(["r1", "--grid", "0x-3"], exe=cg)
check("cassini-cg --grid 0x-3 refused", rc == 2 and "--grid" in out, out)
rc, out, _ = run(["r1", "--width", "-1"], exe=cg)
check("cassini-cg --width -1 refused", rc == 2 and "--width" in out, out)
for label, args, needle in (("--width inf", ["--width", "inf"], "--width"), ("--margin nan", ["--margin", "nan"], "--margin"),
                            ("a kernel wider than the box", ["--width", "0.5"], "narrower than the box"),
                            ("--background shear:abc", ["--background", "shear:abc"], "shear:RATE")):
    rc, out, _ = run(["r1", *args, "--out", "nonsense.h5"], exe=cg)
    check(f"cassini-cg {label} refused", rc == 2 and needle in out and not os.path.exists(f"{work}/nonsense.h5"), out)
rc, out, _ = run(["gas", "--out", "r3", *short])
rc, out, _ = run(["r1/snap_000000100.h5md", "r3/snap_000000100.h5md", "--out", "mix.h5"], exe=cg)
check("cassini-cg refuses frames of different runs", rc == 2 and "another run" in out, out)
rc, out, _ = run(["r1/snap_000000100.h5md", "r3/snap_000000100.h5md", "--out", "mix.h5", "--mix-runs"], exe=cg)
check("... unless --mix-runs", rc == 0, out)
rc, out, _ = run(["r1/snap_000000100.h5md", "r2/snap_000000150.h5md", "--out", "cont.h5"], exe=cg)
check("cassini-cg averages a run with its continuation", rc == 0, out)


# ---- 5b. scripts/run-trajectory: named errors, exit 2 for bad input, 4 for a failed write
traj = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "scripts", "run-trajectory")


def trajectory(args):
    p = subprocess.run([traj, *args], cwd=work, capture_output=True, text=True)
    return p.returncode, p.stdout + p.stderr


os.makedirs(f"{work}/trunc")
shutil.copy(f"{work}/r1/snap_000000000.h5md", f"{work}/trunc/")
with open(f"{work}/r1/snap_000000050.h5md", "rb") as src, open(f"{work}/trunc/snap_000000050.h5md", "wb") as dst:
    dst.write(src.read(3000))
rc, out = trajectory(["trunc"])
check("run-trajectory names a truncated frame (exit 2)", rc == 2 and "snap_000000050.h5md" in out
      and "Traceback" not in out and not os.path.exists(f"{work}/trunc/trajectory.h5md"), out)
rc, out = trajectory(["r1/observables.h5md"])
check("run-trajectory given a file, not a run directory (exit 2)", rc == 2 and "run directory" in out
      and "Traceback" not in out, out)
rc, out = trajectory(["r1"])
with h5py.File(f"{work}/r1/trajectory.h5md", "r") as f:
    creator_ok = "version" in f["h5md/creator"].attrs and "name" in f["h5md/author"].attrs
check("run-trajectory's file has h5md/author and creator@version", rc == 0 and creator_ok, out)

# ---- 6. a write failure on any rank ends the job, names the file and the reason
def disk_full_case(label, args, env, expect_file, run_dir, failing_rank=None):
    rc, out, secs = run(args, env=env, timeout=90)
    ok = rc not in (0, "hung") and secs < 30 and "No space left on device" in out and expect_file in out
    if failing_rank is not None:  # the failing rank records the error before it aborts the job
        try:
            s = summary(run_dir)
            ok = ok and s["status"] == "error" and f"rank {failing_rank}" in s["stop_reason"] \
                and expect_file in s["stop_reason"]
        except (OSError, ValueError, KeyError) as e:
            ok, out = False, out + f"\nno summary.json naming rank {failing_rank}: {e}"
    try:
        frames = complete_frames(run_dir)
        ok = ok and all(not f.endswith(".h5md") or f in frames for f in os.listdir(run_dir) if f.startswith("snap_"))
    except Exception as e:  # a frame that looks complete but is not
        ok, out = False, out + f"\nincomplete frame: {e}"
    check(f"{label}: all ranks stop in {secs:.1f} s naming {expect_file} and the reason", ok, f"rc={rc} {out}")


more = ["--set", "time.end=4e-5", "--set", "output.snapshot_every=1e-5"]
disk_full_case("injected failure on rank 1 mid-snapshot (rank 0 still writing)",
               ["gas", "--out", "inj1", *more], {"CASSINI_FAIL_WRITE": "snap_000000100@1"},
               "snap_000000100.h5md.partial", f"{work}/inj1", failing_rank=1)
disk_full_case("injected failure of observables.h5md", ["gas", "--out", "inj2", *more],
               {"CASSINI_FAIL_WRITE": "observables.h5md"}, "observables.h5md", f"{work}/inj2", failing_rank=0)
rc, out, _ = run(["r1", "--out", "inj_fields.h5"], exe=cg, env={"CASSINI_FAIL_WRITE": "fields"})
check("cassini-cg: an injected write failure exits 4 naming the file, no fields.h5",
      rc == 4 and "inj_fields.h5.partial" in out and not os.path.exists(f"{work}/inj_fields.h5"), f"rc={rc} {out}")
# Out of memory, for real: a skin of half the box makes every particle every other's neighbour
# (~1e9 pairs in the 55,000-particle box), under 1 GiB of address space per rank (prlimit).
prlimit = shutil.which("prlimit")
if prlimit:
    rc, out, secs = run([f"--as={1 << 30}", cassini, "gas", "--out", "oom", "--set", "time.end=1e-4",
                         "--set", "domain.hi=[0.06,0.04,0.04]", "--set", "contact.skin=0.019"], exe=prlimit)
    try:
        s = summary(f"{work}/oom")
        ok = s["status"] == "error" and re.search(r"rank [01]: out of memory", s["stop_reason"]) is not None
    except (OSError, ValueError, KeyError) as e:
        ok, out = False, out + f"\nno summary.json naming the rank out of memory: {e}"
    check(f"out of memory on a rank: all ranks stop in {secs:.1f} s (exit 4), summary.json names the rank",
          rc == 4 and ok, f"rc={rc} {out}")
else:
    print("note: no prlimit: the out-of-memory case is not run")
tmpfs = f"{work}/tmpfs"
os.makedirs(tmpfs)
mounted = os.geteuid() == 0 and subprocess.run(["mount", "-t", "tmpfs", "-o", "size=3m", "tmpfs", tmpfs],
                                               capture_output=True).returncode == 0
if mounted:
    try:
        disk_full_case("full tmpfs during a snapshot (2 ranks)", ["gas", "--out", f"{tmpfs}/run", *more], {},
                       ".h5md.partial", f"{tmpfs}/run")
        subprocess.run(["umount", tmpfs])
        subprocess.run(["mount", "-t", "tmpfs", "-o", "size=300k", "tmpfs", tmpfs])
        rc, out, secs = run(["r1", "--grid", "60x40x40", "--out", f"{tmpfs}/fields.h5"], exe=cg, timeout=90)
        check(f"cassini-cg on a full tmpfs: exit 4 in {secs:.1f} s naming the file and the reason, nothing that looks "
              "complete", rc == 4 and "fields.h5.partial" in out and "No space left on device" in out
              and not os.path.exists(f"{tmpfs}/fields.h5") and not os.path.exists(f"{tmpfs}/fields.xdmf"), f"rc={rc} {out}")
        subprocess.run(["umount", tmpfs])
        subprocess.run(["mount", "-t", "tmpfs", "-o", "size=8k", "tmpfs", tmpfs])
        with open(f"{tmpfs}/filler", "wb") as filler:  # the disk is full before the script starts
            try:
                filler.write(b"x" * 16384)
            except OSError:
                pass
        rc, out = trajectory(["r1", "--out", f"{tmpfs}/traj.h5md"])
        check("run-trajectory on a full disk: exit 4 naming the file, nothing left", rc == 4 and "traj.h5md" in out
              and "Traceback" not in out and not os.path.exists(f"{tmpfs}/traj.h5md")
              and not os.path.exists(f"{tmpfs}/traj.h5md.partial"), f"rc={rc} {out}")
        subprocess.run(["umount", tmpfs])
        subprocess.run(["mount", "-t", "tmpfs", "-o", "size=100k", "tmpfs", tmpfs])
        disk_full_case("full tmpfs during observables", ["gas", "--out", f"{tmpfs}/run", "--set", "time.end=2e-4",
                                                         "--set", "output.observe_every=2e-7"], {},
                       "observables.", f"{tmpfs}/run")
    finally:
        subprocess.run(["umount", tmpfs])
else:
    print("note: no tmpfs (not root or mount refused): the injected failures above stand in for a full disk")

failed = [n for n, ok in results if not ok]
print(f"\n{len(results) - len(failed)} of {len(results)} reliability cases passed")
sys.exit(1 if failed else 0)

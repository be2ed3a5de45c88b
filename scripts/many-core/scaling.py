#!/usr/bin/env python3
"""MPI scaling of cassini, side by side with LAMMPS (Debian's binary and, where it runs there,
the source build of scripts/lammps-source as "lammps-src"), on one many-core machine.
cassini's copy of ../shared/tools/many-core/scaling.py: bundled by scripts/many-core/make-bundle.sh.

Run by run-scaling.sh after `. env.sh` (CB = the unpacked bundle). Writes $OUT/scaling.csv
(one row per run, rewritten after each run), $OUT/summaries.json (cassini's summary.json per
run) and appends everything readable to $OUT/logs.txt.

Plan, most important first; each run under a timeout, and a run is skipped when its estimate
does not fit in what is left of SCALING_BUDGET_S (seconds since this script started):
  A. granular gas (scripts/bench.py's scene, LAMMPS's in.gas), N = 200k, mu = 0.5:
     cassini and LAMMPS alternating at 1, 2, 4, 8, 16 ranks, the same steps
  B. cases/propeller (multirate) for a fixed simulated time at 1, 2, 4, 8, 16 ranks
  C. cases/gravity-wakes (self-gravity) as shipped (1,492 particles) at 1, 2, 4, 16 ranks, and its
     800 m patch (23,872 particles, 256 x 256 x 40 mesh; scripts/gravity_cost.py) at 1, 2, 4, 8, 16
  D. weak scaling, the gas with mu = 0.5, 50k particles per rank (box 50P x 40 x 25 sites,
     slabs along x), cassini and LAMMPS at 1, 4, 16 ranks
  E. the frictionless 200k gas, as A
  F. cassini's METIS decomposition (domain.decomposition = "metis") on A's scene at 4, 8, 16 ranks
     (LAMMPS cuts the box in 3D; cassini's default is one slab per rank along x)
  G. A again (run-to-run scatter), as long as time is left
  H. propeller weak scaling (30k particles per rank), multi-rate and plain
  I. the 2M gas at 8 and 16 ranks, both codes (peak memory per rank)
  P. a 120,000-particle propeller patch (cases/propeller 4x longer), 0.1 orbit, 1-16 ranks
  R. cassini's grid of regions (domain.decomposition = "grid": 4 x 1 x 2 at 8, 4 x 1 x 4 at 16)
     on A's and E's scenes at 4, 8, 16 ranks (the halo that slabs cannot shrink: issue 43)
SCALING_ORDER sets the order (default CARBEDFGHIP); SCALING_ONLY the plans run.
Environment knobs: SCALING_BUDGET_S (default 330), SCALING_MAX_RANKS (default: CPU count),
SCALING_SCALE (multiplies every step count / simulated time; default 1), SCALING_ONLY (plan
letters, default ABCDEFGHIPR), SCALING_WORK (run directories, default /tmp/scaling-runs).
"""
import json, os, re, shutil, signal, subprocess, sys, time

T_START = time.monotonic()
CB = os.path.dirname(os.path.abspath(__file__))
OUT = os.environ["OUT"]
BUDGET = float(os.environ.get("SCALING_BUDGET_S", "330"))
MAXRANKS = int(os.environ.get("SCALING_MAX_RANKS", str(os.cpu_count() or 1)))
SCALE = float(os.environ.get("SCALING_SCALE", "1"))
ONLY = set(os.environ.get("SCALING_ONLY", "ABCDEFGHIPR").replace(",", ""))
WORK = os.environ.get("SCALING_WORK", "/tmp/scaling-runs")
LIB = os.path.join(CB, "usr/lib/x86_64-linux-gnu")
BIN = os.path.join(CB, "usr/bin")
LOADER = os.environ.get("CB_LOADER") == "1"  # the host's glibc is too old: run every ELF through the bundle's
ENV = dict(os.environ, LD_LIBRARY_PATH=LIB, PATH=BIN + ":" + os.environ.get("PATH", "/usr/bin:/bin"))
sys.path.insert(0, os.path.join(CB, "scripts"))
import types  # noqa: E402
# bench.py reads results through cassini_tools (numpy); only its case text is used here
sys.modules.setdefault("cassini_tools", types.SimpleNamespace(Run=None))
import bench  # noqa: E402  (the project's scripts/bench.py: the gas scene's case text)

LOG = open(os.path.join(OUT, "logs.txt"), "a")
ROWS, SUMMARIES = [], {}
LMP_SRC = False  # LAMMPS built from source (lmp-src) runs here: set by the preflight
TRANSPORT = []   # extra mpirun arguments chosen by the preflight
# TCP over loopback (a sandbox may have no other interface; btl_tcp excludes 127.0.0.1/8 by default)
TCP = ["--mca", "btl", "self,tcp", "--mca", "btl_tcp_if_include", "lo"]
FIELDS = ["plan", "scene", "code", "N", "mu", "ranks", "steps", "sim_time", "ext_wall_s", "loop_wall_s",
          "psteps_per_s", "psteps_per_s_per_rank", "speedup", "efficiency", "rss_max_mb", "rss_sum_mb", "cpu_s_max", "cpu_s_sum",
          "pair_s", "neigh_s", "integrate_or_modify_s", "comm_s", "modules_s", "output_s", "other_s",
          "rebuilds", "halo_bytes_per_step", "halo_msgs_per_step", "imbalance_mean", "rc", "transport", "note"]


def elapsed():
    return time.monotonic() - T_START


def log(*a):
    print(*a, file=LOG, flush=True)


def say(*a):
    print(f"[{elapsed():6.1f}s]", *a, flush=True)
    log(f"[{elapsed():6.1f}s]", *a)


def exe(path):
    """An ELF of the bundle as a command prefix (through the bundle's loader if needed)."""
    if LOADER:
        return [os.path.join(CB, "glibc/ld-linux-x86-64.so.2"), "--library-path", LIB + ":" + os.path.join(CB, "glibc"), path]
    return [path]


def descendants(pid):
    kids, parent = [], {}
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as f:
                    parent[int(d)] = int(f.read().rsplit(")", 1)[1].split()[1])
            except (OSError, ValueError, IndexError):
                pass
    pending = [pid]
    while pending:
        p = pending.pop()
        for c, pp in parent.items():
            if pp == p:
                kids.append(c)
                pending.append(c)
    return kids


def run_mpi(ranks, app, rdir, timeout, transport=None):
    """mpirun -n ranks app (each rank under rsswrap.sh); returns a dict."""
    transport = TRANSPORT if transport is None else transport
    os.makedirs(rdir, exist_ok=True)
    cmd = exe(os.path.join(BIN, "orterun")) + ["--allow-run-as-root", "--oversubscribe", "--bind-to", "none"] + \
        transport + ["-n", str(ranks), os.path.join(CB, "rsswrap.sh"), rdir] + app
    log("$ " + " ".join(cmd))
    t0 = time.monotonic()
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=ENV, cwd=rdir,
                         start_new_session=True, text=True, errors="replace")
    timed_out = False
    try:
        out, _ = p.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        timed_out = True
        kids = descendants(p.pid)
        for sig in (signal.SIGTERM, signal.SIGKILL):
            for q in [p.pid] + kids:
                try:
                    os.kill(q, sig)
                except OSError:
                    pass
            try:
                p.wait(timeout=3)
            except subprocess.TimeoutExpired:
                pass
            kids = [k for k in kids if os.path.exists(f"/proc/{k}")]
        try:
            out, _ = p.communicate(timeout=5)
        except subprocess.TimeoutExpired:
            out = ""
    wall = time.monotonic() - t0
    rss, cpu = [], []
    for r in range(ranks):
        try:
            v = open(os.path.join(rdir, f"rss.{r}")).read().split()
            rss.append(int(v[0]))
            cpu.append(float(v[1]) + float(v[2]))
        except (OSError, ValueError, IndexError):
            pass
    out = out or ""
    if len(out) > 6000:
        out = out[:2500] + "\n[...]\n" + out[-3500:]
    log(f"rc={p.returncode} timed_out={timed_out} wall={wall:.2f}s rss_kb={rss} cpu_s={cpu}")
    if out.strip():
        log(out.rstrip())
    return dict(rc=p.returncode, timed_out=timed_out, wall=wall, rss=rss, cpu=cpu, out=out)


# ---------------------------------------------------------------------------- scenes

def gas_case(rdir, dims, friction, steps):
    n = dims[0] * dims[1] * dims[2]
    bench.SIZES[n] = dims
    bench.STEPS = steps
    os.makedirs(rdir, exist_ok=True)
    with open(os.path.join(rdir, "case.toml"), "w") as f:
        f.write(bench.case_text(n, friction))
    return n


def cassini_app(case, out, sets=()):
    app = exe(os.path.join(BIN, "cassini")) + [case, "--out", out, "--force"]
    for s in sets:
        app += ["--set", s]
    return app


def parse_lammps(logpath):
    try:
        text = open(logpath, errors="replace").read()
    except OSError:
        return None, ""
    m = re.search(r"Loop time of ([0-9.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms", text)
    if not m:
        return None, text[-3000:]
    d = dict(loop=float(m.group(1)), steps=int(m.group(3)), atoms=int(m.group(4)))
    for sec in ("Pair", "Neigh", "Comm", "Output", "Modify", "Other"):
        mm = re.search(rf"^{sec}\s*\|\s*([0-9.eE+-]*)\s*\|\s*([0-9.eE+-]+)\s*\|", text, re.M)
        if mm:
            d[sec] = float(mm.group(2))
    mm = re.search(r"Neighbor list builds = (\d+)", text)
    if mm:
        d["builds"] = int(mm.group(1))
    i = text.find("Loop time of")
    return d, text[i:i + 2500]


def row(**k):
    r = {f: "" for f in FIELDS}
    r.update(k)
    return r


def do_cassini(plan, scene, rdir, case, ranks, sets, timeout, n, mu, tag):
    out = os.path.join(rdir, "out")
    r = run_mpi(ranks, cassini_app(case, out, sets), rdir, timeout)
    s = {}
    try:
        s = json.load(open(os.path.join(out, "summary.json")))
        SUMMARIES[tag] = s
        log("summary.json: " + json.dumps({k: v for k, v in s.items() if k not in ("case",)}))
    except (OSError, ValueError):
        pass
    st = {k: v.get("mean", "") for k, v in s.get("stage_seconds", {}).items()}
    rr = row(plan=plan, scene=scene, code="cassini", N=s.get("particles", n), mu=mu, ranks=ranks,
             steps=s.get("steps", ""), sim_time=s.get("simulated_time", ""), ext_wall_s=round(r["wall"], 3),
             loop_wall_s=s.get("wall_seconds", ""), psteps_per_s=s.get("particle_steps_per_second", ""),
             pair_s=st.get("pair", ""), neigh_s=st.get("neighbour", ""), integrate_or_modify_s=st.get("integrate", ""),
             comm_s=st.get("comm", ""), modules_s=st.get("modules", ""), output_s=st.get("output", ""),
             other_s=st.get("other", ""), rebuilds=s.get("neighbour_rebuilds", ""),
             halo_bytes_per_step=s.get("halo_bytes_per_step", ""), halo_msgs_per_step=s.get("halo_messages_per_step", ""),
             imbalance_mean=s.get("imbalance_mean", ""), rc=("timeout" if r["timed_out"] else r["rc"]),
             transport=" ".join(TRANSPORT) or "default(vader)",
             note=("" if s.get("status", "") == "completed" else s.get("status", "no summary")))
    if r["rss"]:
        rr["rss_max_mb"] = round(max(r["rss"]) / 1024, 1)
        rr["rss_sum_mb"] = round(sum(r["rss"]) / 1024, 1)
        rr["cpu_s_max"] = round(max(r["cpu"]), 2)
        rr["cpu_s_sum"] = round(sum(r["cpu"]), 2)
    if rr["psteps_per_s"] != "":
        rr["psteps_per_s_per_rank"] = rr["psteps_per_s"] / ranks
    return rr, r


def do_lammps(plan, scene, rdir, dims, friction, steps, ranks, timeout, binary="lmp"):
    logpath = os.path.join(rdir, "log.lammps")
    app = exe(os.path.join(BIN, binary)) + ["-in", os.path.join(CB, "peers/in.gas"), "-log", logpath, "-screen", "none",
                                           "-var", "nx", str(dims[0]), "-var", "ny", str(dims[1]), "-var", "nz", str(dims[2]),
                                           "-var", "friction", str(friction), "-var", "nsteps", str(steps)]
    r = run_mpi(ranks, app, rdir, timeout)
    d, tail = parse_lammps(logpath)
    if tail:
        log("log.lammps (from the loop time):\n" + tail.rstrip())
    n = dims[0] * dims[1] * dims[2]
    rr = row(plan=plan, scene=scene, code=("lammps" if binary == "lmp" else "lammps-src"), N=n, mu=0.5 * friction, ranks=ranks, steps=steps,
             ext_wall_s=round(r["wall"], 3), rc=("timeout" if r["timed_out"] else r["rc"]),
             transport=" ".join(TRANSPORT) or "default(vader)", note="" if d else "no loop time")
    if d:
        rr.update(loop_wall_s=d["loop"], psteps_per_s=d["atoms"] * d["steps"] / d["loop"],
                  psteps_per_s_per_rank=d["atoms"] * d["steps"] / d["loop"] / ranks, pair_s=d.get("Pair", ""),
                  neigh_s=d.get("Neigh", ""), integrate_or_modify_s=d.get("Modify", ""), comm_s=d.get("Comm", ""),
                  output_s=d.get("Output", ""), other_s=d.get("Other", ""), rebuilds=d.get("builds", ""))
    if r["rss"]:
        rr["rss_max_mb"] = round(max(r["rss"]) / 1024, 1)
        rr["rss_sum_mb"] = round(sum(r["rss"]) / 1024, 1)
        rr["cpu_s_max"] = round(max(r["cpu"]), 2)
        rr["cpu_s_sum"] = round(sum(r["cpu"]), 2)
    return rr, r


def write_csv():
    # speed-up and efficiency against the same scene's and code's 1-rank run (loop wall time;
    # for weak scaling: psteps/s per rank relative to 1 rank)
    base = {}
    for r in ROWS:
        if r["ranks"] == 1 and r["loop_wall_s"] not in ("", None):
            base[(r["plan"], r["scene"].split(" N=")[0] if r["plan"] == "D" else r["scene"], r["code"])] = r
    for r in ROWS:
        key = (r["plan"], r["scene"].split(" N=")[0] if r["plan"] == "D" else r["scene"], r["code"])
        b = base.get(key) or base.get(("A", key[1], key[2]))
        if not b or r["loop_wall_s"] in ("", None) or not r["loop_wall_s"]:
            continue
        if r["plan"] == "D":
            if r["psteps_per_s_per_rank"] != "" and b["psteps_per_s_per_rank"] != "":
                r["efficiency"] = round(r["psteps_per_s_per_rank"] / b["psteps_per_s_per_rank"], 3)
        else:
            r["speedup"] = round(b["loop_wall_s"] / r["loop_wall_s"], 3)
            r["efficiency"] = round(r["speedup"] / r["ranks"], 3)
    tmp = os.path.join(OUT, "scaling.csv.tmp")
    with open(tmp, "w") as f:
        f.write(",".join(FIELDS) + "\n")
        for r in ROWS:
            f.write(",".join(str(r[k]).replace(",", ";") for k in FIELDS) + "\n")
    os.replace(tmp, os.path.join(OUT, "scaling.csv"))
    with open(os.path.join(OUT, "summaries.json"), "w") as f:
        json.dump(SUMMARIES, f, indent=1)


# ---------------------------------------------------------------------------- the plan

EST = {}  # (scene, code) -> wall seconds of its 1-rank run here


def estimate(scene, code, ranks, prior1):
    """Expected wall seconds of a run: the 1-rank run's (measured here, else prior1) / ranks
    for the step loop, plus start-up that grows with the rank count; and that 1-rank time."""
    t1 = EST.get((scene, code), prior1)
    return 1.5 + 0.15 * ranks + max(t1 - 1.5, 0.5) / ranks * 1.25, t1


def fits(est):
    left = BUDGET - elapsed()
    return est < left, left


def attempt(plan, scene, code, ranks, prior1, fn):
    """Runs fn(timeout) if its estimate fits; retries once over TCP if a shared-memory run
    fails fast (not a timeout)."""
    global TRANSPORT
    est, t1 = estimate(scene, code, ranks, prior1)
    ok, left = fits(est)
    if not ok:
        say(f"skip {plan} {scene} {code} {ranks} ranks: estimate {est:.0f}s, {left:.0f}s left")
        return None
    # a run slower than 1.5x the 1-rank run is a failure anyway
    timeout = min(max(4 * est, 1.5 * t1 + 5, 25.0), left)
    say(f"run {plan} {scene} {code} {ranks} ranks (estimate {est:.0f}s, timeout {timeout:.0f}s)")
    rr, r = fn(timeout)
    if r["rc"] != 0 and not r["timed_out"] and "tcp" not in " ".join(TRANSPORT) and r["wall"] < 30:
        ok, left = fits(est)
        if ok:
            say(f"  failed (rc {r['rc']}) on shared memory: again over TCP (kept if it works)")
            ROWS.append(rr)
            saved = TRANSPORT
            TRANSPORT = TRANSPORT + TCP
            rr, r = fn(min(max(4 * est, 1.5 * t1 + 5, 25.0), left))
            if r["rc"] != 0:
                TRANSPORT = saved
    ROWS.append(rr)
    write_csv()
    if ranks == 1 and rr["rc"] == 0:
        EST[(scene, code)] = r["wall"]
    say(f"  -> rc {rr['rc']}, wall {r['wall']:.2f}s, loop {rr['loop_wall_s']}, psteps/s {rr['psteps_per_s']}, "
        f"rss max {rr['rss_max_mb']} MB")
    return rr


def tiny_lammps(binary, rdir, ranks, transport):
    """A 1,000-particle, 100-step gas in LAMMPS `binary` (of the bundle): (it ran, its exit code)."""
    rl = os.path.join(rdir, binary)
    os.makedirs(rl, exist_ok=True)
    app = exe(os.path.join(BIN, binary)) + ["-in", os.path.join(CB, "peers/in.gas"), "-log", os.path.join(rl, "log.lammps"),
                                            "-screen", "none", "-var", "nx", "10", "-var", "ny", "10", "-var", "nz", "10",
                                            "-var", "friction", "1", "-var", "nsteps", "100"]
    r = run_mpi(ranks, app, rl, 15, transport)
    return r["rc"] == 0 and parse_lammps(os.path.join(rl, "log.lammps"))[0] is not None, r["rc"]


def preflight():
    """A 2-rank cassini and LAMMPS run of a tiny gas under each transport until one works."""
    global TRANSPORT
    ranks = min(2, MAXRANKS)
    variants = [["--use-hwthread-cpus"], [], ["--use-hwthread-cpus"] + TCP, TCP]
    for v in variants:
        rdir = os.path.join(WORK, "preflight-" + str(variants.index(v)))
        gas_case(rdir, (10, 10, 10), 1, 100)
        say("preflight: mpirun " + (" ".join(v) or "(no extra arguments)"))
        r = run_mpi(ranks, cassini_app(os.path.join(rdir, "case.toml"), os.path.join(rdir, "out")), rdir, 15, v)
        ok = r["rc"] == 0 and os.path.exists(os.path.join(rdir, "out/summary.json"))
        if ok:
            ok = tiny_lammps("lmp", rdir, ranks, v)[0]
        say(f"  -> {'works' if ok else 'fails'} (cassini {r['wall']:.1f}s)")
        if ok:
            TRANSPORT = v
            global LMP_SRC
            if os.path.exists(os.path.join(BIN, "lmp-src")):
                LMP_SRC, rc = tiny_lammps("lmp-src", rdir, ranks, v)
                say(f"  source-built LAMMPS (lmp-src): {'runs' if LMP_SRC else 'does not run here (rc %s)' % rc}")
            return True
    return False


def gas_strong(plan, friction, steps, prior_c, prior_l, ranks_list=(1, 2, 4, 8, 16), sets=(), lammps=True):
    dims = (80, 50, 50)
    scene = f"gas N=200000 mu={0.5 * friction}"
    for ranks in [p for p in ranks_list if p <= MAXRANKS]:
        rdir = os.path.join(WORK, f"{plan}-c{ranks}-f{friction}")
        n = gas_case(rdir, dims, friction, steps)
        attempt(plan, scene, "cassini", ranks, prior_c,
                lambda t: do_cassini(plan, scene, rdir, os.path.join(rdir, "case.toml"), ranks, sets, t, n, 0.5 * friction,
                                     f"{plan}-cassini-{ranks}-f{friction}"))
        if lammps:
            rdir_l = os.path.join(WORK, f"{plan}-l{ranks}")
            attempt(plan, scene, "lammps", ranks, prior_l,
                    lambda t: do_lammps(plan, scene, rdir_l, dims, friction, steps, ranks, t))
            if LMP_SRC:
                rdir_s = os.path.join(WORK, f"{plan}-s{ranks}")
                attempt(plan, scene, "lammps-src", ranks, prior_l,
                        lambda t: do_lammps(plan, scene, rdir_s, dims, friction, steps, ranks, t, "lmp-src"))


def ring(plan, name, case, ranks_list, sets, prior, n):
    for ranks in [p for p in ranks_list if p <= MAXRANKS]:
        rdir = os.path.join(WORK, f"{plan}-{name}-{ranks}")
        attempt(plan, name, "cassini", ranks, prior,
                lambda t: do_cassini(plan, name, rdir, os.path.join(CB, "cases", case), ranks, sets, t, n, "",
                                     f"{plan}-{name}-{ranks}"))


def weak(plan, steps, prior_c, prior_l):
    for ranks in [p for p in (1, 4, 16) if p <= MAXRANKS]:
        dims = (50 * ranks, 40, 25)
        scene = f"weak gas 50k/rank mu=0.5 N={50000 * ranks}"
        for code, prior in (("cassini", prior_c), ("lammps", prior_l)):
            rdir = os.path.join(WORK, f"{plan}-{code[0]}{ranks}")
            # the per-rank work is constant: the estimate is the 1-rank time, not divided
            key = "weak gas 50k/rank mu=0.5 N=50000"
            t1 = EST.get((key, code), prior)
            est = 1.5 + 0.3 * ranks + t1 * 1.3
            ok, left = fits(est)
            if not ok:
                say(f"skip {plan} {scene} {code} {ranks} ranks: estimate {est:.0f}s, {left:.0f}s left")
                continue
            if code == "cassini":
                n = gas_case(rdir, dims, 1, steps)
                fn = (lambda t, rdir=rdir, n=n: do_cassini(plan, scene, rdir, os.path.join(rdir, "case.toml"), ranks, (), t, n,
                                                           0.5, f"{plan}-cassini-{ranks}"))
            else:
                fn = (lambda t, rdir=rdir, dims=dims: do_lammps(plan, scene, rdir, dims, 1, steps, ranks, t))
            say(f"run {plan} {scene} {code} {ranks} ranks (estimate {est:.0f}s)")
            rr, r = fn(min(max(4 * est, 25.0), left))
            ROWS.append(rr)
            write_csv()
            if ranks == 1 and rr["rc"] == 0:
                EST[(key, code)] = r["wall"]
            say(f"  -> rc {rr['rc']}, wall {r['wall']:.2f}s, loop {rr['loop_wall_s']}, psteps/s {rr['psteps_per_s']}")


def main():
    shutil.rmtree(WORK, ignore_errors=True)
    os.makedirs(WORK, exist_ok=True)
    say(f"scaling.py: budget {BUDGET:.0f}s, max ranks {MAXRANKS}, scale {SCALE}, plans {''.join(sorted(ONLY))}, "
        f"loader mode {LOADER}")
    if not preflight():
        say("no transport works: see the preflight's output above")
        write_csv()
        return 1
    say(f"transport: {' '.join(TRANSPORT) or 'default'}")
    # Step counts and simulated times; the priors (1-rank wall seconds) come from the home
    # machine and only decide skips until this machine's own 1-rank run replaces them.
    gas_steps = max(int(round(600 * SCALE)), 10)
    for plan in os.environ.get("SCALING_ORDER", "CARBEDFGHIP"):
        if plan in ONLY:
            PLANS[plan](gas_steps)
    write_csv()
    say(f"done: {len(ROWS)} runs")
    return 0


def plan_A(gas_steps):
    if True:
        gas_strong("A", 1, gas_steps, 9.0, 16.0)


def plan_B(gas_steps):
    if True:
        # 0.4 orbit: 163,360 contact steps of 0.1 s; ~16 CPU-s on one home-machine core
        T0 = 40840.0
        end = 0.4 * T0 * SCALE
        ring("B", "propeller", "propeller", (1, 2, 4, 8, 16),
             [f"time.end={end!r}", "output.dump_every=0", "output.progress_every=1000"], 18.0, 30000)


def plan_C(gas_steps):
    if True:
        T0 = 2 * 3.141592653589793 / 1.3144e-4
        end = 0.2 * T0 * SCALE          # 4,780 steps of 2 s
        ring("C", "gravity-wakes", "gravity-wakes", (1, 2, 4, 16),
             [f"time.end={end!r}", "output.snapshot_every=0", "output.progress_every=1000"], 3.0, 1492)
        L = 800.0
        end = 0.05 * T0 * SCALE         # 1,195 steps
        ring("C", "gravity-wakes-800m", "gravity-wakes", (1, 2, 4, 8, 16),
             [f"domain.lo=[{-L / 2}, {-L / 2}, -50.0]", f"domain.hi=[{L / 2}, {L / 2}, 50.0]", "particles.count=23872",
              "self_gravity.grid=[256, 256, 40]", f"time.end={end!r}", "output.snapshot_every=0",
              "output.progress_every=1000"], 8.0, 23872)


def plan_D(gas_steps):
    if True:
        weak("D", max(int(round(1000 * SCALE)), 10), 3.5, 5.0)


def plan_E(gas_steps):
    if True:
        gas_strong("E", 0, gas_steps, 6.5, 13.0)


def plan_F(gas_steps):
    if True:
        gas_strong("F", 1, gas_steps, EST.get(("gas N=200000 mu=0.5", "cassini"), 9.0), 0, (4, 8, 16),
                   ("domain.decomposition=metis",), lammps=False)


def plan_R(gas_steps):
    for friction in (1, 0):
        scene = f"gas N=200000 mu={0.5 * friction}"
        gas_strong("R", friction, gas_steps, EST.get((scene, "cassini"), 9.0), 0, (4, 8, 16),
                   ("domain.decomposition=grid",), lammps=False)


def plan_G(gas_steps):
    if True:
        gas_strong("G", 1, gas_steps, EST.get(("gas N=200000 mu=0.5", "cassini"), 9.0),
                   EST.get(("gas N=200000 mu=0.5", "lammps"), 16.0))



def plan_H(gas_steps):
    if True:
        # propeller weak scaling: the patch stretched azimuthally x P, 30,000 particles per rank
        T0 = 40840.0
        end = 0.2 * T0 * SCALE
        for P in (1, 4, 16):
            if P > MAXRANKS:
                continue
            L = 9000.0 * P
            sets = [f"domain.lo=[{-L}, -1000.0, -10.0]", f"domain.hi=[{L}, 1000.0, 10.0]",
                    f"particles.count={30000 * P}", f"time.end={end!r}", "output.dump_every=0",
                    "output.progress_every=1000"]
            ring("H", f"propeller-weak-P{P}", "propeller", (P,), sets, 12.0 * P, 30000 * P)
        for P in (1, 16):
            if P > MAXRANKS:
                continue
            L = 9000.0 * P
            sets = [f"domain.lo=[{-L}, -1000.0, -10.0]", f"domain.hi=[{L}, 1000.0, 10.0]",
                    f"particles.count={30000 * P}", f"time.end={0.05 * T0 * SCALE!r}", "output.dump_every=0",
                    "output.progress_every=1000", "time.integrator=\"verlet\""]
            ring("H", f"propeller-weak-plain-P{P}", "propeller", (P,), sets, 12.0 * P, 30000 * P)


def plan_I(gas_steps):
    if True:
        # a 2M-particle gas on 8 and 16 ranks, both codes
        dims = (160, 125, 100)
        for ranks in (8, 16):
            if ranks > MAXRANKS:
                continue
            scene = "gas N=2000000 mu=0.5"
            rdir = os.path.join(WORK, f"I-c{ranks}")
            n = gas_case(rdir, dims, 1, 300)
            attempt("I", scene, "cassini", ranks, 60.0,
                    lambda t, rdir=rdir, n=n, ranks=ranks: do_cassini("I", scene, rdir, os.path.join(rdir, "case.toml"), ranks, (), t, n, 0.5, f"I-cassini-{ranks}"))
            rdir_l = os.path.join(WORK, f"I-l{ranks}")
            attempt("I", scene, "lammps", ranks, 100.0,
                    lambda t, rdir_l=rdir_l, ranks=ranks: do_lammps("I", scene, rdir_l, dims, 1, 300, ranks, t))


def plan_P(gas_steps):
    # strong scaling of a 120,000-particle propeller patch (cases/propeller stretched 4x in x)
    T0 = 40840.0
    L = 36000.0
    sets = [f"domain.lo=[{-L}, -1000.0, -10.0]", f"domain.hi=[{L}, 1000.0, 10.0]", "particles.count=120000",
            f"time.end={0.1 * T0 * SCALE!r}", "output.dump_every=0", "output.progress_every=1000"]
    ring("P", "propeller-120k", "propeller", (1, 2, 4, 8, 16), sets, 20.0, 120000)


PLANS = {k: globals()["plan_" + k] for k in "ABCDEFGHIPR"}


if __name__ == "__main__":    sys.exit(main())

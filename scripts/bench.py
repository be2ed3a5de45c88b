"""Drives scripts/bench: identical gas scene in cassini and LAMMPS, medians of repeats."""
import math, os, re, shutil, statistics, subprocess, sys, tempfile
sys.path.insert(0, os.path.join(os.path.dirname(os.path.realpath(__file__)), os.pardir, "python"))
from cassini_tools import Run

REPEATS = int(sys.argv[1]) if __name__ == "__main__" and len(sys.argv) > 1 else 3
BASE = os.environ.get("CASSINI_BASE")  # an older binary to time beside build/cassini
# LAMMPS built from Debian's source with cassini's flags (scripts/lammps-source; scripts/bench
# sets it): timed beside Debian's binary, "src" columns. LAMMPS_SRC_SUFFIX="omp" adds -sf omp -pk omp 1.
LAMMPS_SRC = os.environ.get("LAMMPS_SRC")
SRC_ARGS = ["-sf", "omp", "-pk", "omp", "1"] if os.environ.get("LAMMPS_SRC_SUFFIX") == "omp" else []
STEPS = 1000
LAMMPS_IN = os.path.abspath(os.path.join(os.path.dirname(__file__), "../../shared/peers/lammps/in.gas"))
if not os.path.exists(LAMMPS_IN):
    LAMMPS_IN = "/work/shared/peers/lammps/in.gas"
ENV = dict(os.environ, OMPI_MCA_btl_vader_single_copy_mechanism="none")
MPI = ["mpirun", "--oversubscribe"] + (["--allow-run-as-root"] if os.getuid() == 0 else [])
SIZES = {50000: (50, 40, 25), 200000: (80, 50, 50), 1000: (10, 10, 10)}  # 1000: the baseline run

# The LAMMPS scene in LJ units: d = 1, density 1, kn = 2000, e = 0.9, dt = t_c/50.
m = math.pi / 6
meff = m / 2
kn, en = 2000.0, 0.9
lne = math.log(en)
gn = -2 * lne * math.sqrt(kn / meff) / math.sqrt(math.pi**2 + lne**2)
tc = math.pi / math.sqrt(kn / meff - 0.25 * gn * gn)
spacing = (0.30 / (math.pi / 6)) ** (-1 / 3)


def case_text(n, friction):
    nx, ny, nz = SIZES[n]
    mu = 0.5 if friction else 0.0
    # LAMMPS: gamma_t = gamma_n / 2 (in.gas), k_t = 2/7 k_n
    return f"""
seed = 4928459
modules = ["contact"]
[domain]
lo = [0.0, 0.0, 0.0]
hi = [{nx * spacing}, {ny * spacing}, {nz * spacing}]
[[species]]
density = 1.0
radius = 0.5
t_c = {tc!r}
e = {en}
mu_s = {mu}
mu_d = {mu}
kt_ratio = {2 / 7!r}
gammat_ratio = 0.5
[contact]
skin = 0.1
[particles]
init = "lattice"
count = {n}
jitter = {0.08 * 2 / (spacing - 1.0)!r}
velocity_sigma = {math.sqrt(1.0 / m)!r}
[time]
n_c = 50
end = {STEPS * tc / 50!r}
[output]
progress_every = 1000
observe_every = {200 * tc / 50!r}   # a row every 200 steps, as in.gas's thermo
[guards]
max_overlap = 0.6   # this soft LJ-unit scene reaches ~25 % overlaps in head-on impacts
"""


def timed(ranks, command):
    """mpirun of command under /usr/bin/time, each rank's report in its own file (two ranks
    writing theirs to one stderr can interleave and lose a line); returns (command, reader)."""
    d = tempfile.mkdtemp()
    wrap = ["sh", "-c", '/usr/bin/time -v -o "$0/rank.${OMPI_COMM_WORLD_RANK:-0}" "$@"', d]
    def peak_bytes():
        vals = []
        for r in range(ranks):
            text = open(os.path.join(d, f"rank.{r}")).read()
            vals.append(int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", text).group(1)))
        shutil.rmtree(d)
        return sum(vals) * 1024
    return MPI + ["-n", str(ranks)] + wrap + command, peak_bytes


def run_cassini(n, friction, ranks, tmp, binary="build/cassini"):
    path = os.path.join(tmp, f"gas_{n}_{friction}")
    os.makedirs(path, exist_ok=True)
    with open(os.path.join(path, "case.toml"), "w") as f:
        f.write(case_text(n, friction))
    out = os.path.join(tmp, f"out_{n}_{friction}_{ranks}")
    cmd, peak_bytes = timed(ranks, [os.path.abspath(binary), path, "--out", out, "--force"])
    r = subprocess.run(cmd, capture_output=True, text=True, env=ENV)
    if r.returncode != 0:
        sys.exit("cassini failed:\n" + r.stdout + r.stderr)
    s = Run(out).summary
    stages = {k: v["mean"] for k, v in s.get("stage_seconds", {}).items()}
    return s["particle_steps_per_second"] / ranks, peak_bytes(), stages


def run_lammps(n, friction, ranks, binary="lmp", extra=()):
    nx, ny, nz = SIZES[n]
    cmd, peak_bytes = timed(ranks, [binary, *extra, "-in", LAMMPS_IN, "-log", "none", "-screen", "none", "-var", "nx", str(nx),
                                    "-var", "ny", str(ny), "-var", "nz", str(nz), "-var", "friction", str(friction)])
    # -screen none hides the loop time; read it from the log instead.
    with tempfile.TemporaryDirectory() as d:
        cmd[cmd.index("-log") + 1] = os.path.join(d, "log.lammps")
        r = subprocess.run(cmd, capture_output=True, text=True, env=ENV)
        log = open(os.path.join(d, "log.lammps")).read()
    t = float(re.search(r"Loop time of ([0-9.eE+-]+) on", log).group(1))
    return n * STEPS / t / ranks, peak_bytes()


def main():
    print(f"granular gas phi=0.3, t_c={tc:.5f}, dt=t_c/50, {STEPS} steps, {REPEATS} repeats (medians)")
    print("memory per particle: gross = peak resident set of all ranks / N (with the MPI runtime);")
    print("net = (that - the same code's peak for a 1,000-particle run) / (N - 1,000)")
    print(f"{'N':>7} {'mu':>4} {'ranks':>5} | {'cassini p-steps/s/core':>22} {'B/p gross':>9} {'net':>5} | "
          f"{'LAMMPS p-steps/s/core':>21} {'B/p gross':>9} {'net':>5} | ratio")
    ratios1 = []
    breakdown = {}
    with tempfile.TemporaryDirectory() as tmp:
        base = {}
        for ranks in (1, 2):  # each code's footprint without particles to speak of
            for friction in (0, 1):
                base[("c", ranks, friction)] = statistics.median(run_cassini(1000, friction, ranks, tmp)[1] for _ in range(REPEATS))
                base[("l", ranks, friction)] = statistics.median(run_lammps(1000, friction, ranks)[1] for _ in range(REPEATS))
        for n in (50000, 200000):
            for friction in (0, 1):
                for ranks in (1, 2):
                    c, l, b, ls_src = [], [], [], []
                    for _ in range(REPEATS):  # back to back, so both see the same machine load
                        if BASE:
                            b.append(run_cassini(n, friction, ranks, tmp, BASE)[0])
                        c.append(run_cassini(n, friction, ranks, tmp))
                        l.append(run_lammps(n, friction, ranks))
                        if LAMMPS_SRC:
                            ls_src.append(run_lammps(n, friction, ranks, LAMMPS_SRC, SRC_ARGS))
                    cs, cm = statistics.median(x[0] for x in c), statistics.median(x[1] for x in c)
                    ls, lm = statistics.median(x[0] for x in l), statistics.median(x[1] for x in l)
                    cnet = (cm - base[("c", ranks, friction)]) / (n - 1000)
                    lnet = (lm - base[("l", ranks, friction)]) / (n - 1000)
                    print(f"{n:>7} {0.5 * friction:>4} {ranks:>5} | {cs:>22.3e} {cm / n:>9.0f} {cnet:>5.0f} | "
                          f"{ls:>21.3e} {lm / n:>9.0f} {lnet:>5.0f} | {cs / ls:.2f}"
                          + (f" | base {statistics.median(b):.3e}, ratio {statistics.median(b) / ls:.2f}, new/base "
                             f"{cs / statistics.median(b):.3f}" if b else "")
                          + (f" | LAMMPS src {statistics.median(x[0] for x in ls_src):.3e} p-steps/s/core, "
                             f"{statistics.median(x[1] for x in ls_src) / n:.0f} B/p gross, ratio "
                             f"{cs / statistics.median(x[0] for x in ls_src):.2f}" if ls_src else ""), flush=True)
                    if ranks == 1:
                        ratios1.append(cs / ls)
                        single = (n, friction, cs, ls)
                        runs = sorted(c, key=lambda x: x[0])
                        breakdown[(n, friction)] = runs[len(runs) // 2][2]
                    else:
                        print(f"{'':>19}2-rank parallel efficiency: cassini {cs / single[2]:.2f}, LAMMPS {ls / single[3]:.2f}")
    print("cassini, 1 rank, time per stage (% of the step loop, the median run):")
    names = ["pair", "neighbour", "integrate", "comm", "modules", "output", "other"]
    print(f"{'N':>7} {'mu':>4} | " + " ".join(f"{k:>9}" for k in names))
    for (n, friction), st in breakdown.items():
        total = sum(st.values()) or 1.0
        print(f"{n:>7} {0.5 * friction:>4} | " + " ".join(f"{100 * st.get(k, 0) / total:>8.1f}%" for k in names))
    print(f"ratio cassini/lammps: {statistics.median(ratios1):.2f}")


if __name__ == "__main__":
    main()

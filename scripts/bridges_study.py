"""Drives scripts/bridges-study: a ring gas whose impacts follow the Bridges law.
A. steady sigma against v_c, and the same patch with a constant e equal to the Bridges e at a
   typical impact speed (u = 2 sigma_y): the two must give about the same sigma if each impact
   takes the law's e;
B. hot and cold starts reach the same sigma: the law gives the ring a thermal equilibrium set
   by v_c, whatever the start."""
import math, os, statistics, subprocess, sys, tempfile, time
from concurrent.futures import ThreadPoolExecutor
sys.path.insert(0, os.path.join(os.path.dirname(os.path.realpath(__file__)), os.pardir, "python"))
from cassini_tools import Hill, Run

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
T0 = Hill({}).period  # one orbit (hill's default Saturn and orbit)
OMEGA = 2 * math.pi / T0
A = 2.0
VC = 7.7e-5  # Bridges et al. (1984)
LANES = int(os.environ.get("STUDY_LANES", "2"))
ORBITS = float(os.environ.get("STUDY_ORBITS", "16"))
SEEDS = [int(s) for s in os.environ.get("STUDY_SEEDS", "1 2").split()]
OUT = os.path.join(ROOT, "docs/contact-laws")


def gas(vc, seed, hot, e=None):
    side = 1000.0
    n = round(0.1 * side * side / (math.pi * A * A))
    out = os.path.join(tempfile.gettempdir(), "bridges-study", f"{vc}_{seed}_{hot}_{e}")
    law = [f"species.0.e={e}"] if e else ["species.0.restitution=\"bridges\"", f"species.0.v_c={vc}"]
    over = law + ["species.0.t_c=4.0", "time.n_c=10",
            f"particles.count={n}", f"domain.lo=[{-side / 2}, {-side / 2}, -10.0]",
            f"domain.hi=[{side / 2}, {side / 2}, 10.0]", f"time.end={ORBITS * T0}", f"seed={seed}",
            "output.observe_every=408.4", "output.dump_every=0"]
    if hot:
        over += ["particles.velocity_sigma=0.02", "particles.dispersion=0.0"]
    # The case's constant e is replaced through a copy of the case without it.
    case_dir = os.path.join(tempfile.gettempdir(), "bridges-study", "case")
    os.makedirs(case_dir, exist_ok=True)
    text = open(os.path.join(ROOT, "cases/ring-section/case.toml")).read().replace("\ne = 0.25\n", "\n")
    open(os.path.join(case_dir, "case.toml"), "w").write(text)
    cmd = [os.environ.get("CASSINI", os.path.join(ROOT, "build/cassini")), case_dir, "--out", out, "--force"]
    for o in over:
        cmd += ["--set", o]
    t = time.time()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    rows = Run(out).observable_rows()
    return n, rows, time.time() - t


MASS = 500.0 * 4.0 / 3.0 * math.pi * A ** 3  # the ring-section species


def sigma(row):
    """Radial velocity dispersion (m/s) about the box's mean radial velocity (T_yy is <v_y^2>
    per unit mass). A hot start's random velocities also leave coherent box-scale epicycles
    (bulk motion, which collisions hardly damp): they count here, see part B."""
    mean_vy = float(row["py"]) / (float(row["particles"]) * MASS)
    return math.sqrt(float(row["T_yy"]) - mean_vy ** 2)


def late_mean(rows):
    late = [r for r in rows if float(r["time"]) > 0.5 * ORBITS * T0]
    return statistics.mean(sigma(r) for r in late)


def pm(xs):
    m = statistics.mean(xs)
    return m, (statistics.stdev(xs) / math.sqrt(len(xs)) if len(xs) > 1 else 0.0)


def main():
    factors = (1, 4, 16, 64)
    jobs = [(f * VC, s, False) for f in factors for s in SEEDS] + [(VC, s, True) for s in SEEDS]
    with ThreadPoolExecutor(LANES) as ex:
        res = dict(zip(jobs, ex.map(lambda j: gas(*j), jobs)))
    # C: a constant e equal to the Bridges e at u = 2 sigma_y of each v_c
    e_typ = {f: min(1.0, (2 * statistics.mean(late_mean(res[(f * VC, s, False)][1]) for s in SEEDS) / (f * VC)) ** -0.234)
             for f in factors}
    cjobs = [(f * VC, s, False, round(e_typ[f], 3)) for f in factors for s in SEEDS]
    with ThreadPoolExecutor(LANES) as ex:
        cres = dict(zip(cjobs, ex.map(lambda j: gas(*j), cjobs)))
    lines = ["**A. Steady radial velocity dispersion against v_c** (tau 0.1, 1 km patch, t_c = 4 s, N_c = 10, "
             f"multi-rate; means over orbits {ORBITS / 2:g}-{ORBITS:g}; seeds {', '.join(map(str, SEEDS))}; "
             "± = standard error over seeds)", "",
             "| v_c (m/s) | v_c / (a Omega) | sigma_y (m/s) | sigma_y / (a Omega) | sigma_y / v_c | e at u = 2 sigma_y | constant e = that: sigma_y / (a Omega) | wall s per run |",
             "|---|---|---|---|---|---|---|---|"]
    for f in factors:
        vc = f * VC
        sig = [late_mean(res[(vc, s, False)][1]) for s in SEEDS]
        m, se = pm(sig)
        wall = statistics.mean(res[(vc, s, False)][2] for s in SEEDS)
        e2 = round(e_typ[f], 3)
        cm_, cse_ = pm([late_mean(cres[(vc, s, False, e2)][1]) for s in SEEDS])
        lines.append(f"| {vc:.3g} | {vc / (A * OMEGA):.3f} | {m:.3e} ± {se:.1e} | {m / (A * OMEGA):.2f} | "
                     f"{m / vc:.2f} ± {se / vc:.2f} | {e2:.3f} | {cm_ / (A * OMEGA):.2f} ± {cse_ / (A * OMEGA):.2f} | {wall:.0f} |")
    lines += ["", "**B. Hot and cold starts** (v_c = 7.7e-5 m/s; hot: Gaussian 0.02 m/s per component, "
              f"{0.02 / (A * OMEGA):.0f} a Omega; cold: 1 % of the shear)", "",
              "| orbit | sigma_y / (a Omega), cold | hot |", "|---|---|---|"]
    cold = [res[(VC, s, False)][1] for s in SEEDS]
    hot = [res[(VC, s, True)][1] for s in SEEDS]

    def orbit_mean(runs, k):  # mean over orbit k (the coherent epicycles oscillate at 2 Omega)
        vals = [sigma(r) for rows in runs for r in rows if k < float(r["time"]) / T0 <= k + 1]
        return statistics.mean(vals) / (A * OMEGA)
    for k in range(int(ORBITS)):
        lines.append(f"| {k + 1} | {orbit_mean(cold, k):.2f} | {orbit_mean(hot, k):.2f} |")
    hm, hse = pm([late_mean(r) for r in hot])
    cm, cse = pm([late_mean(r) for r in cold])
    lines += ["", f"Second-half means: cold {cm / (A * OMEGA):.3f} ± {cse / (A * OMEGA):.3f}, "
              f"hot {hm / (A * OMEGA):.3f} ± {hse / (A * OMEGA):.3f} (a Omega)."]
    body = "\n".join(lines) + "\n"
    os.makedirs(OUT, exist_ok=True)
    with open(os.path.join(OUT, "bridges-study.md"), "w") as f:
        f.write("<!-- made by: scripts/bridges-study -->\n" + body)
    print(body)


if __name__ == "__main__":
    main()

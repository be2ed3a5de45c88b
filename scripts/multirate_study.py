"""Drives scripts/multirate-study: the multi-rate Hill integrator against the plain scheme.
A. steady ring gas: velocity dispersion and collision frequency, tau 0.01 / 0.1, e 0.25 / 0.5 / 0.9
B. cooling of a hot ring gas (Haff's law in the Hill frame, before the shear heats it back)
C. the propeller after one orbit (cases/propeller as shipped): both thesis criteria
Writes docs/multirate/study.md (tables) and prints them."""
import json, math, os, statistics, subprocess, sys, tempfile
from concurrent.futures import ThreadPoolExecutor
sys.path.insert(0, os.path.join(os.path.dirname(os.path.realpath(__file__)), os.pardir, "python"))
from cassini_tools import Hill, Run

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
T0 = Hill({}).period  # one orbit (hill's default Saturn and orbit)
OMEGA = 2 * math.pi / T0
A = 2.0
LANES = int(os.environ.get("STUDY_LANES", "2"))
ORBITS = float(os.environ.get("STUDY_ORBITS", "4"))
SEEDS = [int(s) for s in os.environ.get("STUDY_SEEDS", "1 2").split()]
OUT = os.path.join(ROOT, "docs/multirate")


def run(case, overrides, tag):
    out = os.path.join(tempfile.gettempdir(), "multirate-study", tag)
    cmd = [os.path.join(ROOT, "build/cassini"), case, "--out", out, "--force", "--set", "output.dump_every=0"]
    for o in overrides:
        cmd += ["--set", o]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    rows, summary = Run(out).observable_rows(), Run(out).summary
    return out, rows, summary


def gas(tau, e, scheme, seed, orbits, hot=False):
    side = 1000.0 if tau >= 0.05 else 2000.0
    n = round(tau * side * side / (math.pi * A * A))
    over = [f"time.integrator=\"{scheme}\"", f"species.0.e={e}", "species.0.t_c=4.0", "time.n_c=10",
            f"particles.count={n}", f"domain.lo=[{-side / 2}, {-side / 2}, -10.0]",
            f"domain.hi=[{side / 2}, {side / 2}, 10.0]", f"time.end={orbits * T0}", f"seed={seed}",
            "output.observe_every=408.4"]
    if hot:
        over += ["particles.velocity_sigma=0.02", "particles.dispersion=0.0"]
    _, rows, summary = run(os.path.join(ROOT, "cases/ring-section"), over, f"gas_{tau}_{e}_{scheme}_{seed}_{hot}")
    return n, rows, summary


def dispersion(row):  # radial velocity dispersion in units of a Omega (T_yy is per unit mass)
    return math.sqrt(float(row["T_yy"])) / (A * OMEGA)


def steady(n, rows, orbits):
    """Means over the second half of the run: sigma_y / (a Omega), collisions per particle per orbit."""
    late = [r for r in rows if float(r["time"]) > 0.5 * orbits * T0]
    sig = statistics.mean(dispersion(r) for r in late)
    coll = sum(float(r["collisions"]) for r in late)
    span = float(late[-1]["time"]) - float(rows[rows.index(late[0]) - 1]["time"])
    return sig, coll / n / (span / T0)


def part_a():
    jobs = [(tau, e, s, seed) for tau in (0.01, 0.1) for e in (0.25, 0.5, 0.9) for s in ("verlet", "multirate")
            for seed in SEEDS]
    with ThreadPoolExecutor(LANES) as ex:
        res = list(ex.map(lambda j: (j, gas(j[0], j[1], j[2], j[3], ORBITS)), jobs))
    table = {}
    for (tau, e, s, seed), (n, rows, summary) in res:
        table.setdefault((tau, e), {}).setdefault(s, []).append(steady(n, rows, ORBITS) + (summary["wall_seconds"],))
    lines = [f"| tau | e | sigma_y/(a Omega) plain | multi-rate | collisions/particle/orbit plain | multi-rate | "
             f"wall s plain | multi-rate |", "|---|---|---|---|---|---|---|---|"]
    for (tau, e), d in sorted(table.items()):
        def ms(s, k):
            v = [x[k] for x in d[s]]
            return f"{statistics.mean(v):.3f}" + (f" ± {statistics.stdev(v) / math.sqrt(len(v)):.3f}" if len(v) > 1 else "")
        lines.append(f"| {tau} | {e} | {ms('verlet', 0)} | {ms('multirate', 0)} | {ms('verlet', 1)} | {ms('multirate', 1)} | "
                     f"{statistics.mean(x[2] for x in d['verlet']):.1f} | {statistics.mean(x[2] for x in d['multirate']):.1f} |")
    return lines


def part_b():
    res = {}
    with ThreadPoolExecutor(LANES) as ex:
        for s, r in zip(("verlet", "multirate"),
                        ex.map(lambda s: gas(0.1, 0.5, s, SEEDS[0], 0.2, hot=True), ("verlet", "multirate"))):
            res[s] = r
    lines = ["| t / T0 | sigma_y/(a Omega) plain | multi-rate | ratio |", "|---|---|---|---|"]
    for rp, rm in list(zip(res["verlet"][1], res["multirate"][1]))[::2]:
        a, b = dispersion(rp), dispersion(rm)
        lines.append(f"| {float(rp['time']) / T0:.3f} | {a:.3f} | {b:.3f} | {b / a:.4f} |")
    return lines


def part_c():
    def one(job):
        s, seed = job
        out, _, summary = run(os.path.join(ROOT, "cases/propeller"),
                              [f"time.integrator=\"{s}\"", f"seed={seed}", "output.snapshot_every=100",
                               "output.snapshot_from=39840"], f"propeller_{s}_{seed}")
        subprocess.run(["/usr/bin/python3", os.path.join(ROOT, "scripts/propeller_analysis.py"), out], check=True,
                       stdout=subprocess.DEVNULL)
        c = json.load(open(os.path.join(out, "criteria.json")))
        return job, c, summary
    jobs = [(s, seed) for s in ("verlet", "multirate") for seed in SEEDS]
    with ThreadPoolExecutor(LANES) as ex:
        res = list(ex.map(one, jobs))
    lines = ["| scheme | seed | Sigma contrast | v_H / dv_y | wall s | contact-step fraction | wakes | missed |",
             "|---|---|---|---|---|---|---|---|"]
    for (s, seed), c, summary in res:
        m = summary.get("multirate", {})
        lines.append(f"| {s} | {seed} | {c['contrast']:.3f} | {c['v_H'] / c['dv_y']:.3f} | {summary['wall_seconds']:.0f} | "
                     f"{m.get('contact_step_fraction', '')} | {m.get('wakes', '')} | {m.get('missed_moonlet_contacts', '')} |")
    return lines


def main():
    parts = sys.argv[1:] or ["a", "b", "c"]
    os.makedirs(OUT, exist_ok=True)
    text = []
    if "a" in parts:
        text += [f"## A. Steady ring gas ({ORBITS:g} orbits, means over the second half; t_c = 4 s, N_c = 10; "
                 f"seeds {SEEDS}, ± = standard error over seeds)", ""] + part_a() + [""]
    if "b" in parts:
        text += ["## B. A hot ring gas cooling (tau 0.1, e = 0.5, start sigma 0.02 m/s per component)", ""] + part_b() + [""]
    if "c" in parts:
        text += ["## C. cases/propeller after one orbit (as shipped, one rank per run)", ""] + part_c() + [""]
    body = "\n".join(text)
    print(body)
    with open(os.path.join(OUT, "study-" + "".join(parts) + ".md"), "w") as f:
        f.write(f"<!-- made by: scripts/multirate-study {' '.join(parts)} -->\n" + body)


main()

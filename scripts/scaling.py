"""Drives scripts/scaling: a strong and a weak scaling plan of cassini at any rank counts.

Scenes (the bench's gas and the shipped propeller ring):
  gas-strong   the bench's gas, N = 200,000 (mu = 0.5), the same on every rank count
  gas-weak     50,000 particles per rank, the box stretched along x
  ring-strong  cases/propeller (30,000, multi-rate), a stretch of an orbit
  ring-weak    30,000 particles per rank, the patch stretched along x (same density)
For each run: wall time, particle-steps/s, speed-up and parallel efficiency against the
smallest rank count of the plan, peak resident memory per rank (largest), MPI collectives and
sends per step and rank (summary.json). Writes DIR/scaling.csv and DIR/scaling.png.

usage: scaling.py [--ranks 1,2,4,...] [--scenes gas-strong,...] [--steps N] [--orbits F] [--out DIR] [--force]
The launcher is scripts/mpirun unless CASSINI_LAUNCH is set, e.g. on a Slurm cluster
CASSINI_LAUNCH="srun --cpu-bind=cores -n {ranks}" (see scripts/cluster/).
"""
import argparse, csv, math, os, re, shlex, subprocess, sys, tempfile

HERE = os.path.dirname(os.path.realpath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, os.pardir, "python"))
import bench  # noqa: E402  (the gas scene's text)
from cassini_tools import Run  # noqa: E402

ROOT = os.path.abspath(os.path.join(HERE, os.pardir))
BIN = os.path.abspath(os.environ.get("CASSINI_BIN", os.path.join(ROOT, "build", "cassini")))
T0 = 40840.0  # cases/propeller's orbital period, s
FIELDS = ["scene", "kind", "ranks", "particles", "steps", "wall_s", "particle_steps_per_s", "speedup", "efficiency",
          "peak_mb_per_rank", "collectives_per_step", "sends_per_step", "bytes_sent_per_step"]


def launcher(ranks):
    custom = os.environ.get("CASSINI_LAUNCH")
    if custom:
        return shlex.split(custom.format(ranks=ranks))
    return [os.path.join(ROOT, "scripts", "mpirun"), "-n", str(ranks)]


def run(ranks, args, out):
    """One run under /usr/bin/time per rank; returns the row's measured part."""
    d = tempfile.mkdtemp()
    wrap = ["sh", "-c", '/usr/bin/time -v -o "$0/rank.${OMPI_COMM_WORLD_RANK:-${SLURM_PROCID:-0}}" "$@"', d]
    r = subprocess.run(launcher(ranks) + wrap + [BIN] + args + ["--out", out, "--force"], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"cassini failed on {ranks} rank(s):\n{r.stdout[-2000:]}{r.stderr[-2000:]}")
    peaks = []
    for name in os.listdir(d):
        text = open(os.path.join(d, name)).read()
        peaks.append(int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", text).group(1)) / 1024)
        os.remove(os.path.join(d, name))
    os.rmdir(d)
    s = Run(out).summary
    m = s.get("mpi_per_step_per_rank", {})
    return {"particles": s["particles"], "steps": s["steps"], "wall_s": s["wall_seconds"],
            "particle_steps_per_s": s["particle_steps_per_second"], "peak_mb_per_rank": round(max(peaks), 1),
            "collectives_per_step": round(m.get("collectives", 0.0), 3), "sends_per_step": round(m.get("send", {}).get("calls", 0.0), 3),
            "bytes_sent_per_step": round(m.get("send", {}).get("bytes", 0.0))}


def gas_case(tmp, n_cells, steps):
    n = n_cells[0] * n_cells[1] * n_cells[2]
    bench.SIZES[n] = n_cells
    bench.STEPS = steps
    path = os.path.join(tmp, f"gas{n}")
    os.makedirs(path, exist_ok=True)
    with open(os.path.join(path, "case.toml"), "w") as f:
        f.write(bench.case_text(n, True))
    return path


def plan(scene, ranks, tmp, steps, orbits):
    """(args, label) of a scene's run on `ranks` ranks."""
    if scene == "gas-strong":
        return [gas_case(tmp, (80, 50, 50), steps)]
    if scene == "gas-weak":
        return [gas_case(tmp, (40 * ranks, 50, 25), steps)]
    ring = [os.path.join(ROOT, "cases", "propeller"), "--set", f"time.end={orbits * T0!r}", "--set", "output.dump_every=0",
            "--set", "output.snapshot_every=0"]
    if scene == "ring-strong":
        return ring
    if scene == "ring-weak":
        L = 9000.0 * ranks
        return ring + ["--set", f"domain.lo=[{-L}, -1000.0, -10.0]", "--set", f"domain.hi=[{L}, 1000.0, 10.0]",
                       "--set", f"particles.count={30000 * ranks}"]
    sys.exit(f"scaling.py: unknown scene '{scene}' (gas-strong, gas-weak, ring-strong, ring-weak)")


def plot(rows, path):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("(no matplotlib: no figure)")
        return
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    for scene in dict.fromkeys(r["scene"] for r in rows):
        rs = [r for r in rows if r["scene"] == scene]
        x = [r["ranks"] for r in rs]
        ax[0 if rs[0]["kind"] == "strong" else 1].plot(x, [r["efficiency"] for r in rs], "o-", label=scene)
    for a, title in zip(ax, ("strong scaling", "weak scaling")):
        a.set_xscale("log", base=2)
        a.set_xlabel("ranks")
        a.set_ylabel("parallel efficiency")
        a.set_ylim(0, 1.2)
        a.axhline(1, color="0.7", lw=0.8)
        a.set_title(title)
        a.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"figure: {path}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ranks", default="1,2")
    ap.add_argument("--scenes", default="gas-strong,gas-weak,ring-strong,ring-weak")
    ap.add_argument("--steps", type=int, default=300, help="gas steps per run (default 300)")
    ap.add_argument("--orbits", type=float, default=0.02, help="ring orbits per run (default 0.02)")
    ap.add_argument("--out", default="runs/scaling")
    ap.add_argument("--force", action="store_true", help="replace the table and figure already in --out")
    a = ap.parse_args()
    for name in ("scaling.csv", "scaling.png"):
        if os.path.exists(os.path.join(a.out, name)) and not a.force:
            sys.exit(f"scaling.py: {os.path.join(a.out, name)} exists; give another --out, or --force to replace it")
    ranks = sorted(int(r) for r in a.ranks.split(","))
    os.makedirs(a.out, exist_ok=True)
    rows = []
    print(f"{'scene':>12} {'ranks':>5} {'particles':>9} {'wall s':>8} {'p-steps/s':>10} {'speed-up':>8} "
          f"{'eff.':>5} {'MB/rank':>8} {'coll./step':>10} {'sends/step':>10}")
    with tempfile.TemporaryDirectory() as tmp:
        for scene in a.scenes.split(","):
            kind = scene.split("-")[1]
            first = None
            for P in ranks:
                r = run(P, plan(scene, P, tmp, a.steps, a.orbits), os.path.join(tmp, f"{scene}-{P}"))
                r.update(scene=scene, kind=kind, ranks=P)
                if first is None:
                    first = r
                rate = r["particle_steps_per_s"] / first["particle_steps_per_s"]
                # strong: speed-up over the first rank count, efficiency per rank; weak: per-rank rate kept
                r["speedup"] = round(rate, 3) if kind == "strong" else ""
                r["efficiency"] = round(rate * first["ranks"] / P, 3)
                rows.append(r)
                print(f"{scene:>12} {P:>5} {r['particles']:>9} {r['wall_s']:>8.2f} {r['particle_steps_per_s']:>10.3e} "
                      f"{r['speedup'] or '':>8} {r['efficiency']:>5.2f} {r['peak_mb_per_rank']:>8.0f} "
                      f"{r['collectives_per_step']:>10} {r['sends_per_step']:>10}", flush=True)
    path = os.path.join(a.out, "scaling.csv")
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=FIELDS)
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k, "") for k in FIELDS})
    print(f"table: {path}")
    plot(rows, os.path.join(a.out, "scaling.png"))


if __name__ == "__main__":
    main()

"""Drives scripts/bench-instructions: instructions executed per step of the granular gas, by
stage, in cassini and in LAMMPS, counted by valgrind's cachegrind.

Wall times on a shared machine move by 10-20 % from run to run; instruction counts do not move
at all, so a change to a loop can be judged from one run. Each code runs the scene twice, for
FIRST and for FIRST + SPAN steps: the difference over SPAN is the cost of a step with set-up,
start-up and the last output taken out. Instructions are not time (memory stalls and the
instructions per cycle differ between loops): read them next to scripts/bench's times.

With RANKS = 2 each rank is counted on its own, and the run also gives the work side of the
parallel efficiency, which wall times on this shared machine cannot settle: the instructions of
one rank against those of the busier of two, with the MPI library's own instructions (its
polling while a rank waits, which depends on timing) counted apart and left out."""
import collections, os, re, subprocess, sys, tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench import ENV, LAMMPS_IN, MPI, SIZES, case_text, tc  # the same scene as scripts/bench

N = int(sys.argv[1]) if len(sys.argv) > 1 else 50000
RANKS = int(sys.argv[2]) if len(sys.argv) > 2 else 1
FIRST, SPAN = 100, 200
BINARY = os.path.abspath("build-x86-64-v3/cassini")

# Open MPI's own functions (progress engine, transports, collectives): busy polling while a rank
# waits lands here, so this stage measures waiting as much as work. Debian ships the transports
# stripped: their functions have no name ("???"), and neither code has other unnamed functions.
MPI_LIBRARY = ["opal_", "mca_", "ompi_", "PMPI_", "MPI_", "pmix", "ucp_", "uct_", "ucs_", "???"]
# Stages by function name (first match wins); what matches none is "other".
STAGES = {
    "cassini": [
        ("pair", ["ContactForces::evaluate"]),
        ("neighbour", ["NeighborList::", "ContactForces::post_rebuild", "ContactForces::build_mirrors",
                       "ContactForces::springs", "ContactForces::pre_rebuild", "StashKey", "permute_local"]),
        ("integrate", ["VelocityVerlet::"]),
        ("comm", ["HaloExchange::", "Decomposition::"]),
        ("memset/memcpy", ["memset", "memcpy", "memmove"]),
        ("MPI library", MPI_LIBRARY),
    ],
    "LAMMPS": [
        ("pair", ["LAMMPS_NS::Pair"]),
        ("neighbour", ["LAMMPS_NS::NPair", "LAMMPS_NS::NBin", "LAMMPS_NS::NStencil", "LAMMPS_NS::Neighbor::",
                       "LAMMPS_NS::FixNeighHistory"]),
        ("integrate", ["LAMMPS_NS::FixNVE"]),
        ("comm", ["LAMMPS_NS::Comm", "LAMMPS_NS::AtomVec", "LAMMPS_NS::Domain::pbc"]),
        ("memset/memcpy", ["memset", "memcpy", "memmove"]),
        ("MPI library", MPI_LIBRARY),
    ],
}
ORDER = ["pair", "neighbour", "integrate", "comm", "memset/memcpy", "other", "MPI library", "total"]


def by_stage(code, out_file):
    """Instructions per stage of one cachegrind run."""
    text = subprocess.run(["cg_annotate", "--show=Ir", "--threshold=0", "--auto=no", out_file],
                          capture_output=True, text=True, check=True).stdout
    counts = collections.Counter()
    for line in text.splitlines():
        m = re.match(r"^\s*([\d,]+)\s+\(\s*[\d.]+%\)\s+(\S.*)$", line)
        if not m or "PROGRAM TOTALS" in line:
            continue
        ir, name = int(m.group(1).replace(",", "")), m.group(2)
        stage = next((s for s, keys in STAGES[code] if any(k in name for k in keys)), "other")
        counts[stage] += ir
        counts["total"] += ir
    return counts


def cachegrind(command, tmp, tag, ranks):
    """Runs command on `ranks` ranks under cachegrind; the output file of each rank."""
    out = os.path.join(tmp, f"cg.{tag}")
    grind = ["valgrind", "--tool=cachegrind", "--cache-sim=no", f"--cachegrind-out-file={out}.%q{{OMPI_COMM_WORLD_RANK}}"]
    r = subprocess.run(MPI + ["-n", str(ranks)] + grind + command, capture_output=True, text=True, env=ENV)
    if r.returncode != 0:
        sys.exit(f"{command[0]} under valgrind failed:\n" + r.stdout[-2000:] + r.stderr[-2000:])
    return [f"{out}.{r}" for r in range(ranks)]


def cassini(friction, steps, tmp, ranks):
    case = os.path.join(tmp, f"gas_{N}_{friction}")
    os.makedirs(case, exist_ok=True)
    with open(os.path.join(case, "case.toml"), "w") as f:
        f.write(case_text(N, friction))
    cmd = [BINARY, case, "--set", f"time.end={steps * tc / 50!r}", "--out", os.path.join(tmp, "out"), "--force"]
    return [by_stage("cassini", f) for f in cachegrind(cmd, tmp, f"c{friction}_{steps}_{ranks}", ranks)]


def lammps(friction, steps, tmp, ranks):
    nx, ny, nz = SIZES[N]
    cmd = ["lmp", "-in", LAMMPS_IN, "-log", "none", "-screen", "none", "-var", "nx", str(nx), "-var", "ny", str(ny),
           "-var", "nz", str(nz), "-var", "friction", str(friction), "-var", "nsteps", str(steps)]
    return [by_stage("LAMMPS", f) for f in cachegrind(cmd, tmp, f"l{friction}_{steps}_{ranks}", ranks)]


def main():
    print(f"granular gas phi = 0.3, N = {N}, {RANKS} rank(s): instructions per step (cachegrind, steps {FIRST}-{FIRST + SPAN};")
    print(f"cassini built with -march=x86-64-v3 in build-x86-64-v3, LAMMPS as Debian ships it)")
    with tempfile.TemporaryDirectory() as tmp:
        for friction in (0, 1):
            per_rank, one_rank = {}, {}  # code -> [per stage per step] for each rank
            for name, run in (("cassini", cassini), ("LAMMPS", lammps)):
                for ranks, into in ((RANKS, per_rank), (1, one_rank)) if RANKS > 1 else ((1, per_rank),):
                    a, b = run(friction, FIRST, tmp, ranks), run(friction, FIRST + SPAN, tmp, ranks)
                    into[name] = [{s: (br[s] - ar[s]) / SPAN for s in ORDER} for ar, br in zip(a, b)]
            print(f"\nmu = {0.5 * friction}")
            if RANKS == 1:
                print(f"{'stage':>14} {'cassini':>12} {'LAMMPS':>12} {'LAMMPS/cassini':>15}")
                for s in ORDER:
                    c, l = per_rank["cassini"][0][s], per_rank["LAMMPS"][0][s]
                    ratio = f"{l / c:.2f}" if c > 0 else "-"
                    print(f"{s:>14} {c:>12.3e} {l:>12.3e} {ratio:>15}", flush=True)
                continue
            labels = [f"rank {r}" for r in range(RANKS)]
            print(f"{'stage':>14} " + " ".join(f"{'cassini ' + r:>15}" for r in labels) + " " +
                  " ".join(f"{'LAMMPS ' + r:>15}" for r in labels))
            for s in ORDER:
                print(f"{s:>14} " + " ".join(f"{x[s]:>15.3e}" for x in per_rank["cassini"]) + " " +
                      " ".join(f"{x[s]:>15.3e}" for x in per_rank["LAMMPS"]), flush=True)
            for name, rows in per_rank.items():
                work = [x["total"] - x["MPI library"] for x in rows]
                alone = one_rank[name][0]["total"] - one_rank[name][0]["MPI library"]
                print(f"{name}: work per step (instructions outside the MPI library) {alone:.3e} on 1 rank, "
                      f"{sum(work):.3e} on {RANKS} (x{sum(work) / alone:.3f}), balance max/mean "
                      f"{max(work) * RANKS / sum(work):.3f}; work efficiency 1-rank / ({RANKS} x busiest) "
                      f"{alone / (RANKS * max(work)):.3f}")


if __name__ == "__main__":
    main()

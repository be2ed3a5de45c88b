"""Drives scripts/memory-per-rank: peak resident memory per rank of the bench's 2M-particle gas
(mu = 0.5), started on 1 and on P ranks (a few steps; oversubscribed is fine: it measures memory),
and of a restart of that gas from a snapshot with its contact springs. No rank should hold the
whole system: the P-rank peak approaches an even share of the 1-rank peak plus the MPI runtime."""
import os, re, shutil, subprocess, sys, tempfile

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
import bench

RANKS = int(sys.argv[1]) if len(sys.argv) > 1 else 8
DIMS = (160, 125, 100)  # the many-core plan's 2M gas
N = DIMS[0] * DIMS[1] * DIMS[2]
STEPS = 5
BIN = os.path.abspath(os.environ.get("CASSINI_BIN", "build/cassini"))  # or an older binary, to compare


def peak_per_rank(ranks, args):
    """Largest and mean peak RSS over the ranks (MB) of `cassini args` on `ranks` ranks."""
    d = tempfile.mkdtemp()
    wrap = ["sh", "-c", '/usr/bin/time -v -o "$0/rank.${OMPI_COMM_WORLD_RANK:-0}" "$@"', d]
    r = subprocess.run(bench.MPI + ["-n", str(ranks)] + wrap + [BIN] + args, capture_output=True, text=True, env=bench.ENV)
    if r.returncode != 0:
        sys.exit("cassini failed:\n" + r.stdout[-2000:] + r.stderr[-2000:])
    vals = []
    for k in range(ranks):
        text = open(os.path.join(d, f"rank.{k}")).read()
        vals.append(int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", text).group(1)) / 1024)
    shutil.rmtree(d)
    return max(vals), sum(vals) / len(vals)


def main():
    bench.SIZES[N] = DIMS
    bench.SIZES[1000] = (10, 10, 10)
    bench.STEPS = STEPS
    with tempfile.TemporaryDirectory() as tmp:
        cases = {}
        for n in (N, 1000):
            cases[n] = os.path.join(tmp, f"gas{n}")
            os.makedirs(cases[n])
            with open(os.path.join(cases[n], "case.toml"), "w") as f:
                f.write(bench.case_text(n, True))
        print(f"granular gas, N = {N:,} (mu = 0.5, {STEPS} steps), peak resident memory per rank, MB")
        runtime, _ = peak_per_rank(RANKS, [cases[1000], "--out", os.path.join(tmp, "tiny"), "--force"])
        one, _ = peak_per_rank(1, [cases[N], "--out", os.path.join(tmp, "one"), "--force"])
        many, mean = peak_per_rank(RANKS, [cases[N], "--out", os.path.join(tmp, "many"), "--force"])
        print(f"{'':28} {'1 rank':>8} {f'{RANKS} ranks max':>14} {'mean':>7} {'max / 1-rank':>13}")
        print(f"{'start':28} {one:8.0f} {many:14.0f} {mean:7.0f} {many / one:13.3f}")
        print(f"{'even share + runtime':28} {'':8} {one / RANKS + runtime:14.0f} {'':7} {(one / RANKS + runtime) / one:13.3f}"
              f"   (runtime: a 1,000-particle run on {RANKS} ranks, {runtime:.0f} MB)")
        # A snapshot with the springs of every contact, restarted on 1 and on P ranks.
        end = STEPS * bench.tc / 50
        snap_dir = os.path.join(tmp, "snap")
        peak_per_rank(RANKS, [cases[N], "--out", snap_dir, "--force", "--set", f"output.snapshot_every={end!r}"])
        snap = sorted(f for f in os.listdir(snap_dir) if f.endswith(".h5md"))[-1]
        more = ["--set", f"time.end={2 * end!r}", "--restart", os.path.join(snap_dir, snap)]
        one_r, _ = peak_per_rank(1, [cases[N], "--out", os.path.join(tmp, "r1"), "--force"] + more)
        many_r, mean_r = peak_per_rank(RANKS, [cases[N], "--out", os.path.join(tmp, "rp"), "--force"] + more)
        print(f"{'restart (with springs)':28} {one_r:8.0f} {many_r:14.0f} {mean_r:7.0f} {many_r / one_r:13.3f}")


if __name__ == "__main__":
    main()

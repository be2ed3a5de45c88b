#!/usr/bin/python3
"""Cost of self-gravity against N: cases/gravity-wakes scaled up (box side L, N ~ L^2, the mesh
refined with it so the spacing stays 3.1 m), a short run each, one rank.

  scripts/gravity_cost.py [--sides 200,400,800] [--orbits 0.05] [--ranks 1[,2,4,...]] [--mesh-only]

Prints, per N and rank count: wall seconds per step, the mesh solve's and the pairs'
(interpolation and short range) shares, particle-steps per second, and the communication
volumes per step summed over ranks: halo bytes and messages (ghost updates, ghost builds,
migration), the mesh's bytes sent to other ranks per solve (deposit rows, transposes, field rows;
rank 0's) and its buffers per rank. The mesh solve is
O(G log G) on G grid nodes plus O(N) deposit and interpolation; the pairs are O(N) at fixed
surface density. Rank counts above the cores are oversubscribed: their volumes are real, their
times are not.
"""
import argparse, os, subprocess, sys, tempfile
sys.path.insert(0, os.path.join(os.path.dirname(os.path.realpath(__file__)), os.pardir, "python"))
from cassini_tools import Run

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sides", default="200,400,800")
    ap.add_argument("--orbits", type=float, default=0.05)
    ap.add_argument("--ranks", default="1", help="comma-separated rank counts")
    ap.add_argument("--mesh-only", action="store_true", help="self_gravity.short_range = false")
    a = ap.parse_args()
    exe = os.environ.get("CASSINI", os.path.join(ROOT, "build/cassini"))
    T0 = 2 * 3.141592653589793 / 1.3144e-4
    print(f"{'L m':>6} {'N':>8} {'grid':>14} {'ranks':>5} {'s/step':>9} {'mesh %':>7} {'pairs %':>8} "
          f"{'particle-steps/s':>17} {'halo B/step':>12} {'msgs/step':>9} {'mesh B/solve':>13} {'mesh B/rank':>12}")
    for L, ranks in [(float(x), int(r)) for x in a.sides.split(",") for r in a.ranks.split(",")]:
        n = round(1492 * (L / 200) ** 2)
        g = round(64 * L / 200)
        over = [f"domain.lo=[{-L / 2}, {-L / 2}, -50.0]", f"domain.hi=[{L / 2}, {L / 2}, 50.0]", f"particles.count={n}",
                f"self_gravity.grid=[{g}, {g}, 40]", f"time.end={a.orbits * T0}", "output.snapshot_every=0"]
        if a.mesh_only:
            over.append("self_gravity.short_range=false")
        with tempfile.TemporaryDirectory() as tmp:
            cmd = [exe, os.path.join(ROOT, "cases/gravity-wakes"), "--out", tmp + "/run"]
            if ranks > 1:
                cmd = [os.path.join(ROOT, "scripts/mpirun"), "-n", str(ranks)] + cmd
            for o in over:
                cmd += ["--set", o]
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
            s = Run(tmp + "/run").summary
        wall, steps, sg = s["wall_seconds"], s["steps"], s["self_gravity"]
        print(f"{L:6.0f} {n:8d} {str(sg['grid']):>14} {ranks:5d} {wall / steps:9.2e} {100 * sg['mesh_seconds'] / wall:7.1f} "
              f"{100 * sg['interpolation_and_pairs_seconds'] / wall:8.1f} {s['particle_steps_per_second']:17.3e} "
              f"{s['halo_bytes_per_step']:12.3e} {s['halo_messages_per_step']:9.2f} "
              f"{sg['bytes_moved_per_solve']:13.3e} {sg['mesh_bytes_per_rank']:12.3e}", flush=True)


if __name__ == "__main__":
    main()

"""Drives scripts/bench-ring: CPU per orbit of the ring patch in cassini (plain and multi-rate
schemes, one rank) and in REBOUND (../shared/peers/rebound/run.sh), one after the other.
CASSINI_BASE=/path/to/older/cassini also times that binary in the same repeats (a change's cost)."""
import os, re, resource, statistics, subprocess, sys, tempfile
sys.path.insert(0, os.path.join(os.path.dirname(os.path.realpath(__file__)), os.pardir, "python"))
from cassini_tools import Hill, Run

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
T0 = Hill({}).period  # one orbit of cases/propeller (hill's default Saturn and orbit)
PEER = os.path.abspath(os.path.join(ROOT, "../shared/peers/rebound/run.sh"))
if not os.path.exists(PEER):
    PEER = "/work/shared/peers/rebound/run.sh"


def child_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


BASE = os.environ.get("CASSINI_BASE")


def cassini(case, orbits, overrides, binary=os.path.join(ROOT, "build/cassini")):
    """CPU seconds per orbit (one rank) and the run's summary."""
    with tempfile.TemporaryDirectory() as out:
        cmd = [binary, case, "--out", out + "/run", "--set", f"time.end={orbits * T0}",
               "--set", "output.dump_every=0"]
        for o in overrides:
            cmd += ["--set", o]
        before = child_cpu()
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        cpu = child_cpu() - before
        summary = Run(out + "/run").summary
    return cpu / orbits, summary


def rebound(orbits, n, lx, ly):
    src = os.environ.get("REBOUND_SRC")
    if not src:
        return None
    env = dict(os.environ, RING_ORBITS=str(orbits), RING_N=str(n), RING_LX=str(lx), RING_LY=str(ly))
    out = subprocess.run(["bash", PEER], check=True, capture_output=True, text=True, env=env).stdout
    m = re.search(r"rebound_cpu_per_orbit:\s*([0-9.eE+-]+)", out)
    return float(m.group(1)) if m else None


def main():
    args = sys.argv[1:]
    repeats = int(args[0]) if args else 1  # 0: only the optical-depth scan
    orbits = float(args[1]) if len(args) > 1 else 1.0
    taus = [float(t) for t in args[2].split(",")] if len(args) > 2 else []
    rows = []
    # 1. cases/propeller as shipped (moonlet, tau 0.0105) and REBOUND's patch of the same ring.
    plain, multi, peer, base_plain, base_multi = [], [], [], [], []
    for r in range(repeats):
        if BASE:
            base_plain.append(cassini(os.path.join(ROOT, "cases/propeller"), orbits, ['time.integrator="verlet"', "contact.skin=0.8"], BASE)[0])
            base_multi.append(cassini(os.path.join(ROOT, "cases/propeller"), orbits, ['time.integrator="multirate"'], BASE)[0])
        plain.append(cassini(os.path.join(ROOT, "cases/propeller"), orbits, ['time.integrator="verlet"', "contact.skin=0.8"])[0])
        cpu, s = cassini(os.path.join(ROOT, "cases/propeller"), orbits, ['time.integrator="multirate"'])
        multi.append(cpu)
        mr = s.get("multirate", {})
        p = rebound(orbits, 30000, 2000, 18000)
        if p is not None:
            peer.append(p)
        print(f"repeat {r + 1}: cassini plain {plain[-1]:.1f}, multi-rate {multi[-1]:.1f}"
              f" (contact steps {mr.get('contact_step_fraction', 0):.4f}, wakes {mr.get('wakes')},"
              f" missed {mr.get('missed_moonlet_contacts')}), REBOUND {peer[-1] if peer else 'n/a'} CPU-s/orbit", flush=True)
    # 2. Orbit cost against optical depth, ring section without a moonlet.
    for tau in taus:
        o = min(orbits, 0.1)
        # a 1 km x 1 km patch: N from 800 (tau 0.01) to 40,000 (tau 0.5)
        n = int(tau * 1000 * 1000 / (3.141592653589793 * 4))  # down: random placement stops at 0.5
        over = [f"particles.count={n}", "domain.lo=[-500.0, -500.0, -10.0]", "domain.hi=[500.0, 500.0, 10.0]"]
        pl = cassini(os.path.join(ROOT, "cases/ring-section"), o, over + ['time.integrator="verlet"', "contact.skin=0.8", "time.n_c=10"])[0]
        mu, s = cassini(os.path.join(ROOT, "cases/ring-section"), o, over + ['time.integrator="multirate"', "time.n_c=10"])
        rb = rebound(o, n, 1000, 1000)
        rows.append((tau, n, pl, mu, s.get("multirate", {}).get("contact_step_fraction", 0), rb))
    print()
    if repeats:
        print(f"CPU-s per orbit, one rank, medians of {repeats} ({orbits} orbit runs):")
        print(f"  cassini plain (velocity Verlet, N_c = 10, skin 0.8 m): {statistics.median(plain):.1f}")
        print(f"  cassini multi-rate (as shipped):           {statistics.median(multi):.1f}")
        if BASE:
            print(f"  base binary ({BASE}): plain {statistics.median(base_plain):.1f}, multi-rate "
                  f"{statistics.median(base_multi):.1f}; new/base {statistics.median(plain) / statistics.median(base_plain):.3f}, "
                  f"{statistics.median(multi) / statistics.median(base_multi):.3f}")
    if peer:
        print(f"  REBOUND (SEI, dt = T0/1000, hard spheres): {statistics.median(peer):.1f}")
    if rows:
        print("\noptical depth scan (ring-section in a 1 km x 1 km patch, no moonlet, N_c = 10, 0.1-orbit runs), CPU-s per orbit:")
        print("  tau      N   plain  multi-rate  contact-step fraction  REBOUND")
        for tau, n, pl, mu, f, rb in rows:
            print(f"  {tau:<5} {n:6d} {pl:7.1f} {mu:11.1f} {f:22.4f}  {rb if rb is not None else 'n/a'}")
    if not repeats:
        return
    print(f"\nratio plain/multi-rate: {statistics.median(plain) / statistics.median(multi):.2f}")
    if peer:
        print(f"ratio multi-rate/REBOUND: {statistics.median(multi) / statistics.median(peer):.2f}")


if __name__ == "__main__":
    main()

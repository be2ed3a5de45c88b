"""Drives scripts/bench-ring: CPU per orbit of the ring patch, one rank, cassini and REBOUND one
after the other, two scenes, each the same in both codes:
  - the ring section (cases/ring-section at N_c = 10, no moonlet) against REBOUND's patch
    (../shared/peers/rebound/run.sh, started as the case files: RING_S0=0 RING_DISPFRAC=0.01);
  - the propeller (cases/propeller, plain and multi-rate schemes) against REBOUND's patch with the
    same moonlet (scripts/peers/rebound_propeller.c: its gravity and a hard fixed surface).
CASSINI_BASE=/path/to/older/cassini also times that binary in the same repeats (a change's cost);
PLAIN=0 leaves out the propeller's plain scheme (200 CPU-s a repeat)."""
import atexit, os, re, resource, shutil, statistics, subprocess, sys, tempfile
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
PLAIN = os.environ.get("PLAIN", "1") != "0"


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


def rebound(orbits, n, lx, ly, case_start=False):
    src = os.environ.get("REBOUND_SRC")
    if not src:
        return None
    env = dict(os.environ, RING_ORBITS=str(orbits), RING_N=str(n), RING_LX=str(lx), RING_LY=str(ly))
    if case_start:  # the case files' start: 1 % of the local shear speed
        env.update(RING_S0="0", RING_DISPFRAC="0.01")
    out = subprocess.run(["bash", PEER], check=True, capture_output=True, text=True, env=env).stdout
    m = re.search(r"rebound_cpu_per_orbit:\s*([0-9.eE+-]+)", out)
    return float(m.group(1)) if m else None


_propeller_driver = None


def rebound_propeller(orbits):
    """CPU seconds per orbit of REBOUND's propeller patch, and its RESULT line's fields."""
    global _propeller_driver
    src = os.environ.get("REBOUND_SRC")
    if not src:
        return None, {}
    if _propeller_driver is None:  # librebound and the driver, built once in a scratch directory
        work = tempfile.mkdtemp(prefix="rebound-propeller.")
        atexit.register(shutil.rmtree, work, True)
        lib = os.path.join(work, "rebound")
        os.makedirs(lib)
        if os.path.exists(os.path.join(src, "src", "rebound.h")):
            subprocess.run(["cp", "-r", os.path.join(src, "src"), os.path.join(src, "Makefile"), lib], check=True)
        else:
            subprocess.run(f"git --git-dir='{src}' archive HEAD | tar -x -C '{lib}'", shell=True, check=True)
        subprocess.run(["make", "-C", lib, "OPENGL=0", "SERVER=0", "OPENMP=0", "GITHASH=0000000000gitnotfound0000000000000000000",
                        "-j2"], check=True, capture_output=True)
        _propeller_driver = os.path.join(work, "propeller")
        subprocess.run(["cc", "-O3", "-std=c99", "-D_GNU_SOURCE", "-I" + os.path.join(lib, "src"),
                        os.path.join(ROOT, "scripts", "peers", "rebound_propeller.c"), "-L" + os.path.join(lib, "src"),
                        "-Wl,-rpath," + os.path.join(lib, "src"), "-lrebound", "-lm", "-o", _propeller_driver], check=True)
    out = subprocess.run([_propeller_driver, "30000", "0.25", str(orbits), "1"], check=True, capture_output=True, text=True).stdout
    fields = dict(kv.split("=", 1) for kv in out.split("RESULT", 1)[1].split() if "=" in kv)
    return float(fields["cpu_per_orbit"]), fields


def main():
    args = sys.argv[1:]
    repeats = int(args[0]) if args else 1  # 0: only the optical-depth scan
    orbits = float(args[1]) if len(args) > 1 else 1.0
    taus = [float(t) for t in args[2].split(",")] if len(args) > 2 else []
    rows = []
    # 1. cases/propeller as shipped (moonlet, tau 0.0105) and REBOUND's patch of the same ring.
    plain, multi, peer, base_plain, base_multi = [], [], [], [], []
    section, peer_section, base_section = [], [], []
    nan = float("nan")
    for r in range(repeats):
        # The ring section, the same scene in both codes: no moonlet, the propeller's N_c.
        if BASE:
            base_section.append(cassini(os.path.join(ROOT, "cases/ring-section"), orbits, ["time.n_c=10"], BASE)[0])
        section.append(cassini(os.path.join(ROOT, "cases/ring-section"), orbits, ["time.n_c=10"])[0])
        ps = rebound(orbits, 30000, 2000, 18000, case_start=True)
        if ps is not None:
            peer_section.append(ps)
        if BASE:
            base_plain.append(cassini(os.path.join(ROOT, "cases/propeller"), orbits, ['time.integrator="verlet"', "contact.skin=0.8"], BASE)[0]
                              if PLAIN else nan)
            base_multi.append(cassini(os.path.join(ROOT, "cases/propeller"), orbits, ['time.integrator="multirate"'], BASE)[0])
        plain.append(cassini(os.path.join(ROOT, "cases/propeller"), orbits, ['time.integrator="verlet"', "contact.skin=0.8"])[0]
                     if PLAIN else nan)
        cpu, s = cassini(os.path.join(ROOT, "cases/propeller"), orbits, ['time.integrator="multirate"'])
        multi.append(cpu)
        mr = s.get("multirate", {})
        p, pf = rebound_propeller(orbits)
        if p is not None:
            peer.append(p)
        print(f"repeat {r + 1}: ring section: cassini {section[-1]:.1f}, REBOUND {peer_section[-1] if peer_section else 'n/a'};"
              f" propeller: cassini plain {plain[-1]:.1f}, multi-rate {multi[-1]:.1f}"
              f" (contact steps {mr.get('contact_step_fraction', 0):.4f}, wakes {mr.get('wakes')},"
              f" missed {mr.get('missed_moonlet_contacts')}), REBOUND {peer[-1] if peer else 'n/a'}"
              f" ({pf.get('collisions', '?')} collisions, {pf.get('moonlet_impacts', '?')} moonlet impacts) CPU-s/orbit", flush=True)
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
        print(f"  ring section, no moonlet: cassini multi-rate {statistics.median(section):.1f}"
              + (f", REBOUND {statistics.median(peer_section):.1f}, ratio {statistics.median(section) / statistics.median(peer_section):.3f}"
                 if peer_section else ""))
        print(f"  propeller: cassini plain (velocity Verlet, N_c = 10, skin 0.8 m): {statistics.median(plain):.1f}")
        print(f"  propeller: cassini multi-rate (as shipped):           {statistics.median(multi):.1f}")
        if BASE:
            print(f"  base binary ({BASE}): ring section {statistics.median(base_section):.1f}, propeller plain "
                  f"{statistics.median(base_plain):.1f}, multi-rate {statistics.median(base_multi):.1f}; new/base "
                  f"{statistics.median(section) / statistics.median(base_section):.3f}, "
                  f"{statistics.median(plain) / statistics.median(base_plain):.3f}, "
                  f"{statistics.median(multi) / statistics.median(base_multi):.3f}")
    if peer:
        print(f"  propeller: REBOUND (SEI, dt = T0/1000, hard spheres, the moonlet's gravity and surface): {statistics.median(peer):.1f}")
    if rows:
        print("\noptical depth scan (ring-section in a 1 km x 1 km patch, no moonlet, N_c = 10, 0.1-orbit runs), CPU-s per orbit:")
        print("  tau      N   plain  multi-rate  contact-step fraction  REBOUND")
        for tau, n, pl, mu, f, rb in rows:
            print(f"  {tau:<5} {n:6d} {pl:7.1f} {mu:11.1f} {f:22.4f}  {rb if rb is not None else 'n/a'}")
    if not repeats:
        return
    print(f"\nratio plain/multi-rate: {statistics.median(plain) / statistics.median(multi):.2f}")
    if peer:
        print(f"ratio multi-rate/REBOUND (propeller): {statistics.median(multi) / statistics.median(peer):.2f}")
    if peer_section:
        print(f"ratio multi-rate/REBOUND (ring section): {statistics.median(section) / statistics.median(peer_section):.3f}")


if __name__ == "__main__":
    main()

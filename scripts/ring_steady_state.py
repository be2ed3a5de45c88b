"""The unperturbed ring's steady state (issue 44, item 1): the propeller's ring (optical depth
0.0105, radius 2 m, constant e, multi-rate, exact contact scheme, t_c = 1 s) without the moonlet,
planar and 3D (Saturn's vertical tide), from a hot and a cold start, run until it is stationary.

   /usr/bin/python3 scripts/ring_steady_state.py [--dims 2 3] [--e 0.25 0.5 ...] [--seeds 1 2 3]
                     [--box 1000] [--radius 2] [--segment 5] [--max-orbits 40 20] [--lanes 2] [--out DIR]
   /usr/bin/python3 scripts/ring_steady_state.py --table-only [...]   (analysis of what is there)

Each run advances in segments of --segment orbits (a restart from the last segment's snapshot:
bitwise the run it continues). After every round the criterion below is taken for each (dims,
e) group of 2 x seeds runs; a group that meets it, or runs away, stops.

Stationarity criterion, on the orbit means of sigma_y (the radial velocity dispersion about the
mean velocity: T_yy less the centre of mass's own epicycle) over the window = the second half of the run (at least 4 orbits):
  (a) the hot and the cold starts agree: |mean_hot - mean_cold| <= max(3 %, 2 standard errors);
  (b) no trend: a straight line through all runs' orbit means of the window changes by at most
      max(3 %, 2 standard errors) across the window.
The steady value is the window mean over every run; its error is the standard error over the
runs (independent seeds and starts: no autocorrelation enters). A group whose sigma_y passes
--cap (m/s) in any run is a runaway; one still failing at --max-orbits is "not stationary".

For 3D groups the table also gives the hot start's growth rate d ln(sigma_y) / dt over orbits 5-20
(--rate-window; the isotropic start's anisotropy relaxes first, over ~1/(collision rate)):
in the dilute regime (sigma >> Omega a) Goldreich & Tremaine's balance makes it change sign at
the critical e_cr(tau), ~0.63 for tau -> 0; above it sigma grows exponentially.

Writes series.csv (orbit means), steady.csv, summary.json and sigma.png into DIR (default
runs/ring-steady).
"""
import argparse, json, math, os, shutil, sys, time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
sys.path.insert(0, os.path.join(ROOT, "python"))
from cassini_tools import Hill, Run, launch, solver

HILL = Hill({})  # cases/ring-section and cases/propeller: hill's default Saturn and orbit
OMEGA0, T0 = HILL.omega0, HILL.period
V_HILL = HILL.hill_radius(1.27e10) * OMEGA0  # the propeller's moonlet: 35.2 mm/s
TAU = 30000 * math.pi * 2.0 ** 2 / (18000.0 * 2000.0)  # cases/propeller's ring

ap = argparse.ArgumentParser()
ap.add_argument("--dims", type=int, nargs="*", default=[2, 3])
ap.add_argument("--e", type=float, nargs="*", default=[0.25, 0.5, 0.7, 0.8, 0.9])
ap.add_argument("--e3d", type=float, nargs="*", default=None, help="e values of the 3D groups (default: --e)")
ap.add_argument("--seeds", type=int, nargs="*", default=[1, 2, 3])
ap.add_argument("--box", type=float, default=1000.0, help="square patch side (m)")
ap.add_argument("--radius", type=float, default=2.0,
                help="particle radius (m; the case's 2 m); the count scales to keep the optical depth")
ap.add_argument("--segment", type=int, default=5, help="orbits per segment")
ap.add_argument("--max-orbits", type=int, nargs=2, default=[40, 20], metavar=("PLANAR", "3D"),
                help="orbits after which a group still failing the criterion is reported as not stationary")
ap.add_argument("--cap", type=float, nargs=2, default=[0.12, 0.02], metavar=("PLANAR", "3D"),
                help="sigma_y (m/s) beyond which a group is a runaway")
ap.add_argument("--hot", type=float, nargs=2, default=[0.08, 0.003], metavar=("PLANAR", "3D"),
                help="hot start: Gaussian velocity dispersion per component (m/s)")
ap.add_argument("--cold", type=float, default=5e-4, help="cold start dispersion (m/s)")
ap.add_argument("--rate-window", type=float, nargs=2, default=[5.0, 20.0], metavar=("FROM", "TO"),
                help="orbits over which a 3D hot start's growth rate is fitted (after its anisotropy relaxed: "
                     "~5 orbits at ~0.2 collisions per particle and orbit)")
ap.add_argument("--lanes", type=int, default=2)
ap.add_argument("--table-only", action="store_true")
ap.add_argument("--out", default=os.path.join(ROOT, "runs", "ring-steady"))
a = ap.parse_args()
os.makedirs(a.out, exist_ok=True)
cassini = solver(ROOT)  # one rank per run
RADIUS = a.radius
PARTICLE_MASS = 4 / 3 * math.pi * RADIUS ** 3 * 500.0  # kg: cases/ring-section's density
count = round(TAU * a.box ** 2 / (math.pi * RADIUS ** 2))
DT = 0.1  # time.n_c = 10 at t_c = 1 s
# A segment is a whole number of steps, so that every segment's end is a snapshot step.
T_SEG = round(a.segment * T0 / DT) * DT
e_of = {2: a.e, 3: a.e3d if a.e3d is not None else a.e}


def name(dims, e, start, seed):
    return f"d{dims}_e{e}_{start}_s{seed}"


def system(dims, start, e, seed):
    """--set lines of the system (the same for every segment of a run)."""
    half = a.box / 2
    hot = a.hot[0] if dims == 2 else a.hot[1]
    sigma = hot if start == "hot" else a.cold
    s = [f"seed={seed}", f"species.0.e={e}", f"species.0.radius={RADIUS}",
         f"particles.count={count}", "particles.dispersion=0",
         f"particles.velocity_sigma={sigma}", "time.n_c=10"]
    if dims == 2:
        s += [f"domain.lo=[{-half}, {-half}, -10.0]", f"domain.hi=[{half}, {half}, 10.0]"]
    else:  # z open and tall: a particle leaving it is counted (escapees) and ends the group
        z = 4000.0
        layer = max(8.0, 2 * sigma / OMEGA0)
        s += ["domain.planar=false", "domain.boundary=[\"periodic\", \"lees_edwards\", \"open\"]",
              f"domain.lo=[{-half}, {-half}, {-z}]", f"domain.hi=[{half}, {half}, {z}]", f"particles.layer={layer}"]
    return s


def output(end):
    return [f"time.end={end:.1f}", f"output.observe_every={T0 / 20:.4f}", "output.dump_every=0",
            f"output.snapshot_every={T_SEG:.1f}", "output.progress_every=600"]


def segment_dirs(run):
    d = os.path.join(a.out, run)
    return sorted(x for x in (os.path.join(d, k) for k in os.listdir(d)) if os.path.isdir(x)) if os.path.isdir(d) else []


def advance(job):
    """Runs (or continues) one run up to `orbits`; returns the CPU seconds it took."""
    dims, e, start, seed, orbits = job
    run = name(dims, e, start, seed)
    # Finished segments; an interrupted one (summary status "interrupted") is redone.
    done = [d for d in segment_dirs(run) if os.path.exists(os.path.join(d, "summary.json"))
            and Run(d).summary.get("status") in ("completed", "stopped by a guard")]
    for d in segment_dirs(run)[len(done):]:
        shutil.rmtree(d)  # this study's own unfinished segment
    have = max((Run(d).summary.get("simulated_time", 0.0) for d in done), default=0.0)
    if done and Run(done[-1]).summary.get("status") == "stopped by a guard":
        return 0.0  # ended: judge() reports it
    end = orbits // a.segment * T_SEG
    if have >= end - 1:
        return 0.0
    seg = os.path.join(a.out, run, f"seg{len(done):03d}")
    os.makedirs(os.path.dirname(seg), exist_ok=True)
    if os.path.exists(seg):  # an interrupted segment of this study's own: it is redone
        shutil.rmtree(seg)
    restart = Run(done[-1]).frames()[-1].path if done else None
    seconds, stopped = launch(cassini + [os.path.join(ROOT, "cases", "ring-section", "case.toml")], seg,
                              system(dims, start, e, seed) + output(end), restart=restart, force=False, label=run)
    if not stopped and not Run(seg).frames():
        raise RuntimeError(f"{run}: {seg} ended without a snapshot to continue from")
    return seconds


def series(run):
    """Orbit means of sigma_y (and sigma_z) over a run's segments: rows (orbit, sigma_y, sigma_z,
    particles)."""
    rows = []
    for d in segment_dirs(run):
        if not os.path.exists(os.path.join(d, "summary.json")):
            continue
        o = Run(d).observables()
        for k in range(len(o["time"])):
            if not rows or o["time"][k] > rows[-1][0] + 1e-6:
                # T_ii is about the shear flow; the patch's centre of mass also moves (a start's
                # net momentum is an epicycle that collisions never damp, ~sigma0 / sqrt(N)):
                # the dispersion is about the mean velocity.
                mass = o["particles"][k] * PARTICLE_MASS
                rows.append((o["time"][k], o["T_yy"][k] - (o["py"][k] / mass) ** 2, o["T_zz"][k] - (o["pz"][k] / mass) ** 2,
                             o["particles"][k]))
    r = np.array(rows) if rows else np.zeros((0, 4))
    out = []
    # orbit k: rows in ((k-1) T0, k T0] (the row at k T0 itself may come with the next segment)
    for k in range(1, int(r[-1, 0] / T0 + 0.06) + 1 if len(r) else 0):
        m = (r[:, 0] > (k - 1) * T0 + 1e-6) & (r[:, 0] <= k * T0 + 1e-6)
        if m.any():
            out.append((k, math.sqrt(r[m, 1].mean()), math.sqrt(r[m, 2].mean()), r[m, 3].min()))
    return out, r


def judge(dims, e):
    """The criterion for one (dims, e) group: (state, detail dict)."""
    runs = {(start, s): series(name(dims, e, start, s)) for start in ("hot", "cold") for s in a.seeds}
    guard = [f"{k[0]} s{k[1]}" for k in runs for d in segment_dirs(name(dims, e, *k))[-1:]
             if os.path.exists(os.path.join(d, "summary.json")) and Run(d).summary.get("status") == "stopped by a guard"]
    n = min(len(v[0]) for v in runs.values())
    if n == 0:  # a run stopped by a guard before its first orbit mean (a start too hot for t_c) has none
        return ("stopped", {"why": f"stopped by a guard: {', '.join(guard)}"}) if guard else ("pending", {})
    peak = max(r[:, 1].max() for _, r in runs.values())
    lost = max(r[0, 3] - r[-1, 3] for _, r in runs.values())
    detail = dict(orbits=n)
    if dims == 3:  # the hot start's exponential rate over the --rate-window orbits (or what exists)
        rates = []
        for s in a.seeds:
            _, r = runs[("hot", s)]
            m = (r[:, 0] >= a.rate_window[0] * T0) & (r[:, 0] <= a.rate_window[1] * T0)
            if m.sum() > 3:
                rates.append(np.polyfit(r[m, 0] / T0, 0.5 * np.log(r[m, 1]), 1)[0])
        if rates:
            detail["hot_rate_per_orbit"] = (float(np.mean(rates)), float(np.std(rates, ddof=1) / math.sqrt(len(rates))) if len(rates) > 1 else float("nan"))
    cap = a.cap[0] if dims == 2 else a.cap[1]
    if math.sqrt(peak) > cap or lost > 0 or guard:
        detail["why"] = (f"sigma_y passed {cap} m/s" if math.sqrt(peak) > cap else
                         f"{lost:.0f} particles left through z" if lost > 0 else f"stopped by a guard: {', '.join(guard)}")
        return "runaway", detail
    w0 = n - max(4, n // 2)
    if w0 < 0:
        return "running", detail
    means = {k: np.mean([x[1] for x in v[0][w0:n]]) for k, v in runs.items()}
    hot = np.array([means[("hot", s)] for s in a.seeds])
    cold = np.array([means[("cold", s)] for s in a.seeds])
    allm = np.concatenate([hot, cold])
    mean = float(allm.mean())
    se = lambda v: float(np.std(v, ddof=1) / math.sqrt(len(v))) if len(v) > 1 else 0.0
    gap, gap_err = float(hot.mean() - cold.mean()), math.hypot(se(hot), se(cold))
    # trend: one line through every run's orbit means of the window, its change across the window
    xs = np.concatenate([np.arange(w0, n) + 1.0 for _ in runs])
    ys = np.concatenate([[x[1] for x in v[0][w0:n]] for v in runs.values()])
    slope = np.polyfit(xs, ys, 1)[0]
    per_run = [np.polyfit(np.arange(w0, n) + 1.0, [x[1] for x in v[0][w0:n]], 1)[0] for v in runs.values()]
    change, change_err = float(slope * (n - w0)), float(se(np.array(per_run)) * (n - w0))
    ok_gap = abs(gap) <= max(0.03 * mean, 2 * gap_err)
    ok_trend = abs(change) <= max(0.03 * mean, 2 * change_err)
    detail.update(window=(w0 + 1, n), sigma_y=mean, sigma_y_err=se(allm), hot=float(hot.mean()), cold=float(cold.mean()),
                  gap=gap, gap_err=gap_err, change=change, change_err=change_err,
                  sigma_z=float(np.mean([np.mean([x[2] for x in v[0][w0:n]]) for v in runs.values()])))
    return ("stationary" if ok_gap and ok_trend else "running"), detail


groups = [(d, e) for d in a.dims for e in e_of[d]]
state = {g: "pending" for g in groups}
cpu, t_start = 0.0, time.time()
if not a.table_only:
    orbits = 0
    limit = lambda dims: a.max_orbits[0] if dims == 2 else a.max_orbits[1]
    while any(state[g] in ("pending", "running") and orbits < limit(g[0]) for g in groups):
        orbits += a.segment
        jobs = [(d, e, st, s, orbits) for (d, e) in groups if state[(d, e)] in ("pending", "running") and orbits <= limit(d)
                for st in ("hot", "cold") for s in a.seeds]
        with ThreadPoolExecutor(a.lanes) as pool:
            cpu += sum(pool.map(advance, jobs))
        for g in groups:
            if state[g] in ("pending", "running") and orbits <= limit(g[0]):
                state[g], det = judge(*g)
                print(f"orbit {orbits:3d}  dims {g[0]} e {g[1]}: {state[g]}  "
                      + (f"sigma_y {det['sigma_y'] * 1e3:.2f} mm/s hot-cold {det['gap'] * 1e3:+.2f} trend {det['change'] * 1e3:+.2f}"
                         if "sigma_y" in det else det.get("why", "")), flush=True)
        print(f"  round to orbit {orbits}: {time.time() - t_start:.0f} s wall, {cpu:.0f} CPU-s", flush=True)

# Table of whatever is there.
table, all_series = [], []
for g in groups:
    st, det = judge(*g)
    if st == "running":
        st = "not stationary"
    table.append(dict(dims=g[0], e=g[1], state=st, **det))
    for start in ("hot", "cold"):
        for s in a.seeds:
            for k, sy, sz, npart in series(name(g[0], g[1], start, s))[0]:
                all_series.append((g[0], g[1], start, s, k, sy, sz, npart))
with open(os.path.join(a.out, "series.csv"), "w") as f:
    f.write("dims,e,start,seed,orbit,sigma_y,sigma_z,particles\n")
    for row in all_series:
        f.write(",".join(str(v) for v in row) + "\n")
with open(os.path.join(a.out, "steady.csv"), "w") as f:
    f.write("dims,e,state,orbits,window_from,window_to,sigma_y,sigma_y_err,hot,cold,trend,sigma_z,hot_rate_per_orbit,hot_rate_err\n")
    for t in table:
        w = t.get("window", ("", ""))
        rate = t.get("hot_rate_per_orbit", ("", ""))
        f.write(f"{t['dims']},{t['e']},{t['state']},{t.get('orbits', '')},{w[0]},{w[1]},{t.get('sigma_y', '')},"
                f"{t.get('sigma_y_err', '')},{t.get('hot', '')},{t.get('cold', '')},{t.get('change', '')},"
                f"{t.get('sigma_z', '')},{rate[0]},{rate[1]}\n")
def zero_crossing(points):
    """e where a quantity (value, error) changes sign, linear between scanned e; the range is
    where the curves of value - error and value + error cross (nan: outside the scanned e)."""
    pts = sorted(points)

    def cut(values):
        for (e0, v0), (e1, v1) in zip(values, values[1:]):
            if v0 * v1 <= 0 and v0 != v1:
                return e0 + (e1 - e0) * v0 / (v0 - v1)
        return float("nan")
    mid = cut([(e, v) for e, (v, err) in pts])
    if mid != mid:
        return None
    shifted = sorted(cut([(e, v + k * err) for e, (v, err) in pts]) for k in (-1, 1))
    return mid, shifted[0], shifted[1]


def v_hill_crossing():
    """Planar: e where the steady sigma_y equals v_H (linear between the stationary groups)."""
    pts = sorted((t["e"], (t["sigma_y"] - V_HILL, t["sigma_y_err"])) for t in table if t["dims"] == 2 and t["state"] == "stationary")
    return zero_crossing(pts)


e_cr = zero_crossing([(t["e"], t["hot_rate_per_orbit"]) for t in table if t["dims"] == 3 and "hot_rate_per_orbit" in t])
prev = {}
if os.path.exists(os.path.join(a.out, "summary.json")):
    prev = json.load(open(os.path.join(a.out, "summary.json")))
json.dump(dict(box_m=a.box, radius_m=RADIUS, particles=count, optical_depth=TAU, omega0=OMEGA0, v_hill=V_HILL, seeds=a.seeds,
               segment_orbits=a.segment, max_orbits=dict(planar=a.max_orbits[0], three_d=a.max_orbits[1]), cap=a.cap, hot=a.hot, cold=a.cold,
               cpu_seconds=prev.get("cpu_seconds", 0.0) + cpu, groups=table,
               e_critical_3d=e_cr, e_where_sigma_is_v_hill_planar=v_hill_crossing()),
          open(os.path.join(a.out, "summary.json"), "w"), indent=1, default=float)

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
fig, axes = plt.subplots(1, len(a.dims), figsize=(6 * len(a.dims), 4.5), squeeze=False)
for ax, d in zip(axes[0], a.dims):
    for i, e in enumerate(e_of[d]):
        c = f"C{i}"
        for start in ("hot", "cold"):
            for s in a.seeds:
                rows = [r for r in all_series if r[0] == d and r[1] == e and r[2] == start and r[3] == s]
                if rows:
                    ax.plot([r[4] for r in rows], [r[5] * 1e3 for r in rows], c, ls="-" if start == "hot" else "--", lw=0.8,
                            label=f"e = {e}" if start == "hot" and s == a.seeds[0] else None)
    ax.axhline(V_HILL * 1e3, color="k", lw=0.6, ls=":")
    ax.set_yscale("log")
    ax.set_xlabel("orbits")
    ax.set_ylabel("sigma_y (mm/s), orbit mean")
    ax.set_title(f"{'planar' if d == 2 else '3D'}, tau = {TAU:.4f}: hot (solid), cold (dashed); v_H (dotted)", fontsize=10)
    ax.legend(fontsize=8)
fig.tight_layout()
fig.savefig(os.path.join(a.out, "sigma.png"), dpi=110)
for t in table:
    print(t)
print(f"3D: hot growth rate changes sign at e = {e_cr}; planar: sigma_y = v_H at e = {v_hill_crossing()}")

"""Propellers in equilibrium (issue 17, items 2-3): cases/propeller run for many orbits under the
modified Lees-Edwards boundaries (and, for comparison, the plain ones), the thesis's two
criteria as time series, and their steady-state values against e with error bars.

   /usr/bin/python3 scripts/propeller_equilibrium.py run   [--e 0.25 0.5 ...] [--seeds 1 2 3]
                     [--orbits 6] [--plain-e 0.5 0.9] [--bridges-vc ...] [--lanes 2] [--out DIR]
   /usr/bin/python3 scripts/propeller_equilibrium.py table [--out DIR]   (analysis only)

Each run is one rank (lanes of one-rank runs suit a shared 2-core machine), snapshots every
T0/20; every half orbit the criteria are taken over that half orbit's frames (10 frames;
the thesis used 10 frames over 1,000 s) with scripts/propeller_analysis.py (LE1 only). Beside
them: the radial velocity dispersion far from the moonlet (LE1 upstream, |y| > 3 r_H) and in the feed
LE2 (the unperturbed ring). The steady state is the last two orbits (4 windows); a crossing
value of e comes with a bootstrap over seeds and windows. Writes series.csv, steady.csv,
summary.json and figures into DIR (default runs/propeller-equilibrium).
"""
import argparse, json, os, subprocess, sys, time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
sys.path.insert(0, os.path.join(ROOT, "python"))
from cassini_tools import Hill, Run, Snapshot, launch, solver

HILL = Hill({})  # cases/propeller: hill's default Saturn and orbit
OMEGA0, T0 = HILL.omega0, HILL.period
R_HILL = HILL.hill_radius(1.27e10)
V_HILL = R_HILL * OMEGA0

ap = argparse.ArgumentParser()
ap.add_argument("mode", choices=["run", "table"])
ap.add_argument("--e", type=float, nargs="*", default=[0.25, 0.5, 0.6, 0.7, 0.8, 0.9])
ap.add_argument("--seeds", type=int, nargs="*", default=[1, 2, 3])
ap.add_argument("--orbits", type=int, default=6)
ap.add_argument("--plain-e", type=float, nargs="*", default=[0.5, 0.9], help="plain Lees-Edwards runs beside (seed 1)")
ap.add_argument("--bridges-vc", type=float, nargs="*", default=[], help="Bridges-law runs at these v_c (m/s)")
ap.add_argument("--lanes", type=int, default=2)
ap.add_argument("--skip", nargs="*", default=[], help="run names not to start (e.g. running elsewhere)")
ap.add_argument("--only", nargs="*", default=None, help="just these runs, in this order (names as the run directories)")
ap.add_argument("--out", default=os.path.join(ROOT, "runs", "propeller-equilibrium"))
a = ap.parse_args()
os.makedirs(a.out, exist_ok=True)
cassini = solver(ROOT)  # one rank per run


def runs():
    out = []
    for s in a.seeds:  # seed by seed: a cut-short study still spans every e
        for e in a.e:
            out.append(dict(name=f"mle_e{e}_s{s}", boundary="modified", law=f"e={e}", e=e, seed=s))
        if s == a.seeds[0]:
            for e in a.plain_e:
                out.append(dict(name=f"plain_e{e}_s{s}", boundary="plain", law=f"e={e}", e=e, seed=s))
    for vc in a.bridges_vc:
        for s in a.seeds:
            out.append(dict(name=f"mle_bridges{vc}_s{s}", boundary="modified", law=f"bridges v_c={vc}", vc=vc, seed=s))
    return out


def simulate(r):
    d = os.path.join(a.out, r["name"])
    if os.path.exists(os.path.join(d, "summary.json")) or r["name"] in a.skip:
        return 0.0
    sets = [f"seed={r['seed']}", f"time.end={a.orbits * T0:.1f}", f"output.snapshot_every={T0 / 20:.4f}",
            "output.dump_every=0", "output.progress_every=60", f"domain.modified_lees_edwards={'true' if r['boundary'] == 'modified' else 'false'}"]
    case = os.path.join(ROOT, "cases", "propeller", "case.toml")
    if "vc" in r:  # the Bridges law takes no e: the case's e line gives way to it
        text = open(case).read()
        lines = [f'restitution = "bridges"\nv_c = {r["vc"]}' if l.startswith("e = ") else l for l in text.split("\n")]
        case = d + ".toml"
        open(case, "w").write("\n".join(lines))
    else:
        sets += [f"species.0.e={r['e']}"]
    return launch(cassini + [case], d, sets, label=r["name"])[0]


def dispersions(snap):
    """Radial velocity dispersion of LE1 upstream of the moonlet, away from it (|y| > 3 r_H,
    1-9 km before it: material that has not met it; downstream its wakes' coherent motion would
    count), and of LE2 (the unperturbed ring)."""
    s = Snapshot(snap, columns=["position", "velocity", "le_copy"])
    x, vy = s.position, s.velocity[:, 1]
    copy = s.le_copy.ravel() if "le_copy" in s.columns else np.zeros(len(vy), int)
    upstream = -x[:, 0] * np.sign(x[:, 1])
    far = (copy == 0) & (np.abs(x[:, 1]) > 3 * R_HILL) & (upstream > 1000)
    le2 = copy == 1
    return (float(np.std(vy[far])), float(np.std(vy[le2])) if le2.any() else float("nan"),
            int((copy == 0).sum()))


def analyse(r):
    d = os.path.join(a.out, r["name"])
    rows = []
    frames = Run(d).frames()
    last = max(f.time for f in frames)
    for k in range(1, 2 * a.orbits + 1):
        end = k * T0 / 2
        if end > last + 1:  # a run a guard stopped early has no later windows
            break
        res = os.path.join(d, f"criteria_{k:02d}")
        if not os.path.exists(os.path.join(res, "criteria.json")):
            subprocess.run(["/usr/bin/python3", os.path.join(ROOT, "scripts", "propeller_analysis.py"), d, "--end", str(end),
                            "--window", str(T0 / 2 - 1), "--out", res], check=True, stdout=subprocess.DEVNULL)
        c = json.load(open(os.path.join(res, "criteria.json")))
        snap = min(frames, key=lambda f: abs(f.time - c["time"])).path
        far, le2, n1 = dispersions(snap)
        rows.append(dict(run=r["name"], boundary=r["boundary"], law=r["law"], e=r.get("e", -1.0), seed=r["seed"],
                         orbit=c["time"] / T0, contrast=c["contrast"], dv_y=c["dv_y"], v_H=c["v_H"],
                         dv_y_far=far, dv_y_le2=le2, le1_particles=n1))
    return rows


planned = runs()
if a.only is not None:
    by_name = {r["name"]: r for r in planned}
    missing = [n for n in a.only if n not in by_name]
    if missing:
        sys.exit(f"--only: no such run in this set: {missing} (have {sorted(by_name)})")
    planned = [by_name[n] for n in a.only]
if a.mode == "run":
    t0 = time.time()
    with ThreadPoolExecutor(a.lanes) as pool:
        cpu = sum(pool.map(simulate, planned))
    json.dump({"cpu_seconds_of_runs": cpu, "wall_seconds": time.time() - t0}, open(os.path.join(a.out, "cost.json"), "w"))

series = [row for r in planned if os.path.exists(os.path.join(a.out, r["name"], "summary.json")) for row in analyse(r)]
keys = list(series[0].keys())
with open(os.path.join(a.out, "series.csv"), "w") as f:
    f.write(",".join(keys) + "\n")
    for row in series:
        f.write(",".join(str(row[k]) for k in keys) + "\n")

# Steady state: the windows of the last two orbits.
rng = np.random.default_rng(17)
steady = {}
for row in series:
    if row["orbit"] > a.orbits - 2 + 1e-6:
        steady.setdefault((row["boundary"], row["law"], row["e"]), {}).setdefault(row["seed"], []).append(row)


def mean_ci(groups, key, draws=2000):
    """Mean over seeds and windows with a bootstrap (seeds, then windows within each) 68 % interval."""
    seeds = list(groups.values())
    values = np.array([np.mean([w[key] for w in ws]) for ws in seeds])
    boot = []
    for _ in range(draws):
        pick = [seeds[i] for i in rng.integers(0, len(seeds), len(seeds))]
        boot.append(np.mean([np.mean([ws[j][key] for j in rng.integers(0, len(ws), len(ws))]) for ws in pick]))
    lo, hi = np.percentile(boot, [16, 84])
    return float(values.mean()), float(lo), float(hi)


table = []
for (boundary, law, e), groups in sorted(steady.items(), key=lambda kv: (kv[0][0], kv[0][1])):
    c = mean_ci(groups, "contrast")
    v = mean_ci(groups, "dv_y")
    far = mean_ci(groups, "dv_y_far")
    table.append(dict(boundary=boundary, law=law, e=e, seeds=len(groups), contrast=c, dv_y=v, dv_y_far=far,
                      v_H=V_HILL, propeller_by_contrast=c[0] > 2, propeller_by_velocity=V_HILL > v[0]))
with open(os.path.join(a.out, "steady.csv"), "w") as f:
    f.write("boundary,law,e,seeds,contrast,contrast_lo,contrast_hi,dv_y,dv_y_lo,dv_y_hi,dv_y_far,v_H\n")
    for t in table:
        f.write(f"{t['boundary']},{t['law']},{t['e']},{t['seeds']},{t['contrast'][0]:.3f},{t['contrast'][1]:.3f},"
                f"{t['contrast'][2]:.3f},{t['dv_y'][0]:.5f},{t['dv_y'][1]:.5f},{t['dv_y'][2]:.5f},{t['dv_y_far'][0]:.5f},{V_HILL:.5f}\n")


def crossing(key, threshold, below_is_propeller):
    """e where the seed-and-window-bootstrapped steady criterion crosses its threshold (linear
    interpolation between scanned e), with the 16-84 % range over bootstrap draws."""
    pts = sorted((t["e"], steady[(t["boundary"], t["law"], t["e"])]) for t in table
                 if t["boundary"] == "modified" and not t["law"].startswith("bridges"))
    if len(pts) < 2:
        return None
    out = []
    for _ in range(1000):
        es, vals = [], []
        for e, groups in pts:
            seeds = list(groups.values())
            pick = [seeds[i] for i in rng.integers(0, len(seeds), len(seeds))]
            vals.append(np.mean([np.mean([ws[j][key] for j in rng.integers(0, len(ws), len(ws))]) for ws in pick]))
            es.append(e)
        hit = None
        for i in range(len(es) - 1):
            f0, f1 = vals[i] - threshold, vals[i + 1] - threshold
            if f0 == 0 or f0 * f1 < 0:
                hit = es[i] + (es[i + 1] - es[i]) * f0 / (f0 - f1)
                break
        out.append(hit)
    found = [h for h in out if h is not None]
    if len(found) < len(out) / 2:
        return dict(crossing=None, draws_with_crossing=len(found) / len(out))
    lo, mid, hi = np.percentile(found, [16, 50, 84])
    return dict(crossing=float(mid), lo=float(lo), hi=float(hi), draws_with_crossing=len(found) / len(out))


summary = dict(T0=T0, v_H=V_HILL, r_H=R_HILL, steady_window_orbits=[a.orbits - 2, a.orbits],
               crossing_contrast=crossing("contrast", 2.0, False), crossing_velocity=crossing("dv_y", V_HILL, True),
               table=table)
cost = os.path.join(a.out, "cost.json")
if os.path.exists(cost):
    summary["cost"] = json.load(open(cost))
json.dump(summary, open(os.path.join(a.out, "summary.json"), "w"), indent=1)
print(json.dumps({k: summary[k] for k in ("crossing_contrast", "crossing_velocity")}, indent=1))
for t in table:
    print(f"{t['boundary']:8s} {t['law']:22s} seeds {t['seeds']}  contrast {t['contrast'][0]:.2f} [{t['contrast'][1]:.2f}, "
          f"{t['contrast'][2]:.2f}]  dv_y {t['dv_y'][0] * 1e3:.2f} mm/s [{t['dv_y'][1] * 1e3:.2f}, {t['dv_y'][2] * 1e3:.2f}]"
          f"  far {t['dv_y_far'][0] * 1e3:.2f}  (v_H {V_HILL * 1e3:.1f})")

# Figures: the criteria's time series per e, modified vs plain.
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
fig, ax = plt.subplots(1, 3, figsize=(15, 4))
colors = plt.cm.viridis(np.linspace(0, 0.9, max(1, len(a.e))))
for row_set in sorted({(r["boundary"], r["law"], r["e"]) for r in series}, key=str):
    rows = [r for r in series if (r["boundary"], r["law"], r["e"]) == row_set]
    style = "-" if row_set[0] == "modified" else "--"
    ci = a.e.index(row_set[2]) if row_set[2] in a.e else 0
    color = colors[ci] if not row_set[1].startswith("bridges") else "k"
    for seed in sorted({r["seed"] for r in rows}):
        rr = [r for r in rows if r["seed"] == seed]
        lab = f"{row_set[0]} {row_set[1]}" if seed == min(r["seed"] for r in rows) else None
        ax[0].plot([r["orbit"] for r in rr], [r["contrast"] for r in rr], style, color=color, label=lab, alpha=0.8)
        ax[1].plot([r["orbit"] for r in rr], [r["dv_y"] * 1e3 for r in rr], style, color=color, alpha=0.8)
        ax[2].plot([r["orbit"] for r in rr], [r["dv_y_far"] * 1e3 for r in rr], style, color=color, alpha=0.8)
ax[0].axhline(2, color="r", lw=0.8); ax[0].set_ylabel("Sigma_max / Sigma_min at x = 990 m"); ax[0].set_yscale("log")
ax[1].axhline(V_HILL * 1e3, color="r", lw=0.8); ax[1].set_ylabel("dv_y (mm/s), LE1"); ax[1].set_yscale("log")
ax[2].set_ylabel("dv_y upstream, |y| > 3 r_H (mm/s)"); ax[2].set_yscale("log")
for x in ax:
    x.set_xlabel("orbits")
ax[0].legend(fontsize=6)
plt.tight_layout()
plt.savefig(os.path.join(a.out, "series.png"), dpi=110)

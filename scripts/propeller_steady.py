"""Propellers at the ring's steady state (issue 44, item 2): cases/propeller under the modified
Lees-Edwards boundaries, started hot at the unperturbed ring's steady dispersion sigma(e) (from
scripts/ring_steady_state.py), with criteria that measure what the thesis means.

   /usr/bin/python3 scripts/propeller_steady.py [--e 0.5 0.7 0.8 0.9] [--seeds 1 2] [--orbits 3]
                     [--sigma 0.0011 0.023 0.035 0.056] [--ly 2000] [--lx 18000] [--radius 2] [--tc 1] [--lanes 2] [--ranks 1] [--table-only]
                     [--out DIR]

Criteria, per snapshot (every T0/10) after the first orbit (the propeller forms in ~1 orbit and
the ring is already at its steady state), then per run over half-orbit blocks, then over seeds:
  - the ring's dispersion sigma_ring: std of v_y of the feed LE2, the unperturbed ring (about its
    mean), against v_H = r_H Omega0 = 35.2 mm/s (the thesis's velocity criterion, with the ring's
    own dispersion as the thesis meant, not the moonlet's stirring);
  - the gap depth D = 1 - N_LE1(G) / N_LE2(G): G is where the gaps are, downstream (x sign(y) in
    1-5 km) at |y| in 1.5-2.5 r_H; LE2, the same ring without the moonlet, is the reference.
    Its null value (no moonlet) is measured on LE2 alone: D_null = 1 - N_LE2(G) / N_LE2(G'), G'
    the mirror region upstream, so a gap is "there" when D exceeds 3 x the null's scatter; the
    thesis's contrast 2 corresponds to D = 0.5;
  - the gap's radial position: centroid of the deficit 1 - Sigma_LE1(|y|) / Sigma_LE2(|y|)
    downstream, in r_H (Hill-frame theory: ~2 r_H, docs/propeller.md);
  - the thesis's dv_y (std of v_y over all of LE1), for comparison with earlier results.
Writes runs.csv, table.csv, summary.json, criteria.png into DIR (default runs/propeller-steady).
"""
import argparse, json, math, os, sys, time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
sys.path.insert(0, os.path.join(ROOT, "python"))
from cassini_tools import ContinuedRun, Hill, add_study_options, launch, solver

HILL = Hill({})
OMEGA0, T0 = HILL.omega0, HILL.period
R_HILL = HILL.hill_radius(1.27e10)
V_HILL = R_HILL * OMEGA0

ap = argparse.ArgumentParser()
ap.add_argument("--e", type=float, nargs="*", default=[0.5, 0.7, 0.8, 0.9])
ap.add_argument("--sigma", type=float, nargs="*", default=None,
                help="hot start per e (m/s per component); default: runs/ring-steady/steady.csv, planar")
ap.add_argument("--seeds", type=int, nargs="*", default=[1, 2])
ap.add_argument("--orbits", type=float, default=3.0)
ap.add_argument("--ly", type=float, default=2000.0,
                help="radial box width (m; the case's 2 km = 8.8 r_H); the count scales to keep the optical depth")
ap.add_argument("--lx", type=float, default=18000.0,
                help="azimuthal box length (m; the case's 18 km); the count scales to keep the optical depth")
ap.add_argument("--radius", type=float, default=2.0,
                help="particle radius (m; the case's 2 m); the count scales to keep the optical depth")
ap.add_argument("--tc", type=float, default=None,
                help="contact duration (s; the case's 1 s); 1 m particles at e >= 0.95 need 0.5 s")
add_study_options(ap, os.path.join(ROOT, "runs", "propeller-steady"))
a = ap.parse_args()
os.makedirs(a.out, exist_ok=True)
cassini = solver(ROOT, a.ranks)


def steady_sigma():
    if a.sigma is not None:
        return dict(zip(a.e, a.sigma))
    path = os.path.join(ROOT, "runs", "ring-steady", "steady.csv")
    import csv
    rows = [r for r in csv.DictReader(open(path)) if r["dims"] == "2" and r["sigma_y"]]
    have = {float(r["e"]): float(r["sigma_y"]) for r in rows}
    out = {}
    for e in a.e:
        if e not in have:
            sys.exit(f"{path}: no planar sigma_y at e = {e}; give --sigma")
        out[e] = have[e]
    return out


def name(e, seed):
    return f"e{e}_s{seed}"


def simulate(job):
    e, seed, sigma = job
    run = ContinuedRun(os.path.join(a.out, name(e, seed)))
    if run.finished(until=round(a.orbits * T0, 1)):  # completed, as far as --orbits asks
        return 0.0
    sets = [f"seed={seed}", f"species.0.e={e}", "domain.modified_lees_edwards=true", "particles.dispersion=0",
            f"particles.velocity_sigma={sigma}", f"time.end={a.orbits * T0:.1f}", f"output.snapshot_every={T0 / 10:.4f}",
            "output.dump_every=0", "output.progress_every=600"]
    if a.ly != 2000.0 or a.lx != 18000.0 or a.radius != 2.0:  # cases/propeller: 30,000 particles of 2 m in 18 km x 2 km
        sets += [f"domain.lo=[{-a.lx / 2}, {-a.ly / 2}, -10.0]", f"domain.hi=[{a.lx / 2}, {a.ly / 2}, 10.0]",
                 f"species.0.radius={a.radius}", f"particles.count={round(30000 * a.ly / 2000 * a.lx / 18000 * (2.0 / a.radius) ** 2)}"]
    if a.tc is not None:
        sets += [f"species.0.t_c={a.tc}"]
    out, restart = run.next()  # a run stopped part-way continues from its last snapshot
    return a.ranks * launch(cassini + [os.path.join(ROOT, "cases", "propeller", "case.toml")], out, sets,
                            restart=restart, label=f"{os.path.basename(out)} on {a.ranks} rank(s)")[0]


def measure(frame):
    s = frame.read(columns=["position", "velocity", "le_copy"])
    x, v, c = s.position, s.velocity, s.le_copy.ravel()
    one, two = c == 0, c == 1
    down = x[:, 0] * np.sign(x[:, 1])  # downstream distance (positive past the moonlet)
    ay = np.abs(x[:, 1])
    band = (ay > 1.5 * R_HILL) & (ay < 2.5 * R_HILL)
    G = band & (down > 1000) & (down < 5000)
    Gm = band & (down < -1000) & (down > -5000)
    n1, n2, n2m = (G & one).sum(), (G & two).sum(), (Gm & two).sum()
    edges = np.linspace(0, 0.44 * 2000, 23)
    h1, _ = np.histogram(ay[one & (down > 1000) & (down < 5000)], bins=edges)
    h2, _ = np.histogram(ay[two & (down > 1000) & (down < 5000)], bins=edges)
    return dict(time=s.time, sigma_ring=float(np.std(v[two, 1])), dv_y=float(np.std(v[one, 1])),
                depth=1 - n1 / n2, null=1 - n2 / n2m, h1=h1, h2=h2, edges=edges)


def le1_population(run):
    """(time, LE1's population, all particles) from every part's observables.h5md; a part still
    being written is left out."""
    import h5py
    t, n1, n = [], [], []
    for p in run.parts():
        try:
            with h5py.File(os.path.join(p, "observables.h5md"), "r") as f:
                t.append(f["observables/le1_particles/time"][:].ravel())
                n1.append(f["observables/le1_particles/value"][:].ravel())
                n.append(f["observables/particles/value"][:].ravel())
        except (OSError, KeyError):
            continue
    if not t:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    t, n1, n = np.concatenate(t), np.concatenate(n1), np.concatenate(n)
    _, first = np.unique(t, return_index=True)
    return t[first], n1[first], n[first]


def analyse(e, seed):
    rows = [measure(f) for f in ContinuedRun(os.path.join(a.out, name(e, seed))).frames(start=T0 + 1)]
    return rows


if not a.table_only:
    sig = steady_sigma()
    jobs = [(e, s, sig[e]) for s in a.seeds for e in a.e]
    t0 = time.time()
    with ThreadPoolExecutor(a.lanes) as pool:
        cpu = sum(pool.map(simulate, jobs))
    prev = json.load(open(os.path.join(a.out, "cost.json"))) if os.path.exists(os.path.join(a.out, "cost.json")) else {}
    json.dump({"cpu_seconds": prev.get("cpu_seconds", 0) + cpu, "hot_start_sigma": sig},
              open(os.path.join(a.out, "cost.json"), "w"))

# Per run: half-orbit block means; per e: mean over seeds' blocks, error from the spread of the
# per-seed means (seeds are independent) or, with one seed, of the blocks (longer than the
# ring's correlation time at these e, ~0.2 orbit).
per_run, table = [], []
for e in a.e:
    seeds = []
    for s in a.seeds:
        rows = analyse(e, s)  # a run still going (or stopped part-way) is analysed as far as it got
        if not rows:
            continue
        blocks = {}
        for r in rows:
            blocks.setdefault(int((r["time"] - 1e-6) / (T0 / 2)), []).append(r)
        bm = {k: {q: np.mean([r[q] for r in b]) for q in ("sigma_ring", "dv_y", "depth", "null")} for k, b in blocks.items()}
        h1 = sum(r["h1"] for r in rows)
        h2 = sum(r["h2"] for r in rows)
        edges = rows[0]["edges"]
        y = 0.5 * (edges[1:] + edges[:-1])
        deficit = np.clip(1 - h1 / np.maximum(h2, 1), 0, None)
        centroid = float(np.sum(y * deficit) / np.sum(deficit)) / R_HILL if deficit.sum() > 0 else float("nan")
        t_obs, n1, n_all = le1_population(ContinuedRun(os.path.join(a.out, name(e, s))))
        late = t_obs >= T0
        pop = n1[late] / (n_all[late] - n1[late]) if late.any() else np.array([np.nan])
        run = dict(e=e, seed=s, frames=len(rows), blocks=len(bm), gap_centroid_rH=centroid,
                   le1_over_le2_min=float(pop.min()), le1_over_le2_max=float(pop.max()), le1_over_le2_last=float(pop[-1]),
                   **{q: float(np.mean([b[q] for b in bm.values()])) for q in ("sigma_ring", "dv_y", "depth", "null")},
                   null_sd=float(np.std([r["null"] for r in rows], ddof=1)),
                   depth_block_sd=float(np.std([b["depth"] for b in bm.values()], ddof=1)) if len(bm) > 1 else float("nan"),
                   last_time=rows[-1]["time"])
        per_run.append(run)
        seeds.append(run)
    if not seeds:
        continue

    def mean_err(q):
        v = np.array([r[q] for r in seeds])
        if len(v) > 1:
            return float(v.mean()), float(v.std(ddof=1) / math.sqrt(len(v)))
        return float(v.mean()), float(seeds[0].get("depth_block_sd", float("nan")) / math.sqrt(max(1, seeds[0]["blocks"]))) if q == "depth" else float("nan")
    table.append(dict(e=e, seeds=len(seeds), **{q: mean_err(q) for q in ("sigma_ring", "dv_y", "depth", "null", "gap_centroid_rH")},
                      null_sd=float(np.mean([r["null_sd"] for r in seeds]))))

with open(os.path.join(a.out, "runs.csv"), "w") as f:
    keys = ["e", "seed", "frames", "last_time", "sigma_ring", "dv_y", "depth", "null", "null_sd", "depth_block_sd", "gap_centroid_rH",
            "le1_over_le2_min", "le1_over_le2_max", "le1_over_le2_last"]
    f.write(",".join(keys) + "\n")
    for r in per_run:
        f.write(",".join(str(r[k]) for k in keys) + "\n")
with open(os.path.join(a.out, "table.csv"), "w") as f:
    f.write("e,seeds,sigma_ring,sigma_ring_err,v_H_over_sigma_ring,depth,depth_err,null,null_sd,gap_centroid_rH,dv_y_thesis\n")
    for t in table:
        f.write(f"{t['e']},{t['seeds']},{t['sigma_ring'][0]:.5f},{t['sigma_ring'][1]:.5f},{V_HILL / t['sigma_ring'][0]:.3f},"
                f"{t['depth'][0]:.4f},{t['depth'][1]:.4f},{t['null'][0]:.4f},{t['null_sd']:.4f},{t['gap_centroid_rH'][0]:.3f},"
                f"{t['dv_y'][0]:.5f}\n")


def crossing(key, level):
    """e where the seed mean of `key` crosses `level`, linear between scanned e; with the range
    from the mean +- its error at each e (seed scatter; stationarity is in the blocks)."""
    pts = sorted((t["e"], t[key][0], t[key][1]) for t in table)
    for (e0, v0, s0), (e1, v1, s1) in zip(pts, pts[1:]):
        if (v0 - level) * (v1 - level) <= 0 and v0 != v1:
            mid = e0 + (e1 - e0) * (v0 - level) / (v0 - v1)
            ends = []
            for d0, d1 in ((s0, s1), (-s0, -s1), (s0, -s1), (-s0, s1)):
                w0, w1 = v0 + d0, v1 + d1
                if (w0 - level) * (w1 - level) <= 0 and w0 != w1:
                    ends.append(e0 + (e1 - e0) * (w0 - level) / (w0 - w1))
            return mid, (min(ends) if ends else float("nan")), (max(ends) if ends else float("nan"))
    return None


summary = dict(v_H=V_HILL, r_H=R_HILL, table=table, per_run=per_run,
               velocity_crossing=crossing("sigma_ring", V_HILL), depth_half_crossing=crossing("depth", 0.5))
json.dump(summary, open(os.path.join(a.out, "summary.json"), "w"), indent=1, default=float)
print(json.dumps({k: summary[k] for k in ("velocity_crossing", "depth_half_crossing")}, default=float))
for t in table:
    print(t)

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
if table:
    es = [t["e"] for t in table]
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    err = lambda v: float(np.nan_to_num(v))  # one seed: no seed scatter to draw
    ax[0].errorbar(es, [t["sigma_ring"][0] * 1e3 for t in table], [err(t["sigma_ring"][1]) * 1e3 for t in table], marker="o",
                   label="ring (LE2) sigma_y")
    ax[0].plot(es, [t["dv_y"][0] * 1e3 for t in table], "s--", label="thesis dv_y (all of LE1)")
    ax[0].axhline(V_HILL * 1e3, color="k", ls=":", label="v_H")
    ax[0].set_xlabel("e")
    ax[0].set_ylabel("mm/s")
    ax[0].legend()
    ax[1].errorbar(es, [t["depth"][0] for t in table], [err(t["depth"][1]) for t in table], marker="o", label="gap depth D")
    ax[1].errorbar(es, [t["null"][0] for t in table], [3 * t["null_sd"] for t in table], marker="x", ls="", label="null (no moonlet), 3 sd")
    ax[1].axhline(0.5, color="k", ls=":", label="D = 0.5 (contrast 2)")
    ax[1].set_xlabel("e")
    ax[1].legend()
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "criteria.png"), dpi=110)

#!/usr/bin/python3
"""Propellers in a self-gravitating ring (issue 44, item 5): when do the wakes erase a propeller?

   /usr/bin/python3 scripts/propeller_gravity.py [--ratio 2 1 0.5] [--seeds 2019] [--orbits 1.5]
                     [--from 1.0] [--to ORBITS] [--ly-rh 8] [--a-min 2] [--lanes 2] [--ranks 1] [--table-only] [--out DIR]
                     [--earlier TABLE ...] [--checks TABLE=LABEL ...]

Michikoshi & Kokubo's question: a moonlet of Hill radius r_H opens a propeller when r_H exceeds
the Toomre critical wavelength lambda_cr = 4 pi^2 G Sigma / Omega0^2; below that, do the wakes
fill the gaps? Here r_H = 60 m is fixed and Sigma is set for r_H / lambda_cr = --ratio
(lambda_cr = 30, 60, 120 m: Sigma = 197, 393, 787 kg/m^2).

The ring is cases/gravity-wakes' (Bridges restitution, 400 kg/m^3, dN/da ~ a^-3, 3D with
Saturn's vertical tide) with radii 2-4 m instead of 1-4 m (3.3x fewer particles for the same
Sigma; lambda_cr stays >= 3.7 of the largest diameters; --a-min 1 for the resolution check); the moonlet has the particles' density
(R = 46 m). Box: 60 r_H azimuthally, --ly-rh r_H radially, +-100 m in z (open), modified
Lees-Edwards boundaries (LE2, the moonlet-free copy, is the unperturbed self-gravitating ring
and the reference), the multi-rate integrator, the mesh at 5 m (split 12.5 m). The start is
cold enough (Toomre Q ~ 0.7) that the wakes form within the first orbit.

Criteria over the snapshots from --from orbits on (every T0 / 20):
  - gap depth D = 1 - M_LE1(G) / M_LE2(G) (mass), G downstream (x sign(y) in 5-25 r_H) at
    |y| in 1.5-2.5 r_H; its null D_null = 1 - M_LE2(G) / M_LE2(G'), G' the mirror region
    upstream; "a gap" when D exceeds 3 x the null's frame-to-frame scatter;
  - the radial profile of the deficit 1 - Sigma_LE1(|y|) / Sigma_LE2(|y|) downstream and its
    centroid (r_H);
  - the wakes: the unperturbed copy's dominant wavelength (radial cuts, 2D FFT of Sigma) against
    lambda_cr, and Toomre's Q of LE2;
  - the gap's visibility against the wakes' own contrast, per pixel size (r_H / 4 to 2 r_H): the
    gap pixels' mean deficit over the unperturbed ring's pixel-to-pixel scatter, with the part of
    that scatter the simulation's few particles per pixel make (Poisson) removed, so that what is
    left is the wakes' (a real ring has ~1e6 times the particles); and the fraction of gap pixels
    darker than the unperturbed ring's median pixel (null: LE2's own gap pixels, 0.5);
  - the propeller's height: the mass-weighted rms z of LE1 in the gap region (1-3 r_H radially)
    per 1 r_H of downstream distance, its maximum against Hoffmann, Seiss, Salo & Spahn's N-body
    boxes (maximal propeller heights ~0.6-0.8 r_H) and LE2's (the unperturbed ring's).
Writes runs.csv, table.csv, maps.png into DIR (default runs/propeller-gravity) and cost.json.
"""
import argparse, csv, json, math, os, sys
from concurrent.futures import ThreadPoolExecutor

import numpy as np

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
sys.path.insert(0, os.path.join(ROOT, "python"))
from cassini_tools import G, ContinuedRun, add_study_options, launch, solver

SATURN, R0 = 5.68e26, 1.2995e8         # cases/gravity-wakes
OMEGA0 = math.sqrt(G * SATURN / R0 ** 3)
T0 = 2 * math.pi / OMEGA0
R_HILL = 60.0
M_MOON = 3 * SATURN * (R_HILL / R0) ** 3
RHO = 400.0
R_MOON = (3 * M_MOON / (4 * math.pi * RHO)) ** (1 / 3)

ap = argparse.ArgumentParser()
ap.add_argument("--ratio", type=float, nargs="*", default=[2.0, 1.0, 0.5], help="r_H / lambda_cr")
ap.add_argument("--seeds", type=int, nargs="*", default=[2019])
ap.add_argument("--orbits", type=float, default=1.5)
ap.add_argument("--from", dest="start", type=float, default=1.0, help="orbits: the analysis window's start")
ap.add_argument("--to", dest="end", type=float, default=None, help="orbits: the analysis window's end (default: the run's)")
ap.add_argument("--ly-rh", type=float, default=8.0, help="radial box width in r_H")
ap.add_argument("--a-min", type=float, default=2.0, help="smallest particle radius (m); the largest is 4 m")
ap.add_argument("--checks", nargs="*", default=[], metavar="TABLE=LABEL",
                help="runs.csv tables of check runs (a wider box, finer particles), drawn apart on criteria.png "
                     "and kept out of the seed statistics, e.g. docs/propeller/gravity/table-ly20-1.0-1.5.csv='20 r_H box'")
ap.add_argument("--earlier", nargs="*", default=[],
                help="runs.csv tables of earlier runs (e.g. docs/propeller/gravity/table-1.0-1.5.csv): their rows of other seeds "
                     "join the seed statistics")
add_study_options(ap, os.path.join(ROOT, "runs", "propeller-gravity"))
a = ap.parse_args()
os.makedirs(a.out, exist_ok=True)
cassini = solver(ROOT, a.ranks)
LX, LY = 60 * R_HILL, a.ly_rh * R_HILL
A_MIN, A_MAX = a.a_min, 4.0
MEAN_A3 = (A_MAX - A_MIN) / (0.5 * (A_MIN ** -2 - A_MAX ** -2))  # dN/da ~ a^-3
MEAN_MASS = 4 / 3 * math.pi * RHO * MEAN_A3


def sigma_for(ratio):
    lam = R_HILL / ratio
    return lam * OMEGA0 ** 2 / (4 * math.pi ** 2 * G)


def name(ratio, seed):
    return f"ratio{ratio:g}_s{seed}"


def frames_of(ratio, seed, start, end=None):
    return ContinuedRun(os.path.join(a.out, name(ratio, seed))).frames(start=start, end=end)


def simulate(job):
    ratio, seed = job
    run = ContinuedRun(os.path.join(a.out, name(ratio, seed)))
    if run.finished(until=round(a.orbits * T0, 1)):  # completed, as far as --orbits asks
        return 0.0
    sigma = sigma_for(ratio)
    count = round(sigma * LX * LY / MEAN_MASS)
    q_start = 0.7  # Toomre Q of the start: 3.36 G Sigma Q / Omega0 per radial component
    sets = ['modules=["contact","hill","self-gravity","moonlet"]', f"seed={seed}",
            f"moonlet.mass={M_MOON:.6g}", f"moonlet.radius={R_MOON:.4f}",
            f"domain.lo=[{-LX / 2}, {-LY / 2}, -100.0]", f"domain.hi=[{LX / 2}, {LY / 2}, 100.0]",
            "domain.modified_lees_edwards=true", 'time.integrator="multirate"', "self_gravity.every=1",
            f"self_gravity.grid=[{round(LX / 5)}, {round(LY / 5)}, 80]",
            f"species.0.radius_min={A_MIN}", f"species.0.radius_max={A_MAX}", f"particles.count={count}",
            f"particles.velocity_sigma={3.36 * G * sigma * q_start / OMEGA0:.4g}",
            "species.0.t_c=8.0",  # the moonlet's impacts, ~0.03 m/s: peak overlaps v t_c / pi < 5 % of 2 m
            "contact.skin=3.0",  # the moonlet flings particles at ~its escape speed: 1 m rebuilt every ~30 s
            f"time.end={a.orbits * T0:.1f}", f"output.snapshot_every={T0 / 20:.4f}",
            f"output.observe_every={T0 / 100:.4f}", "output.dump_every=0", "output.progress_every=600"]
    out, restart = run.next()  # a run killed part-way continues from its last snapshot
    seconds, _ = launch(cassini + [os.path.join(ROOT, "cases", "gravity-wakes", "case.toml")], out, sets,
                        restart=restart, label=f"{os.path.basename(out)} on {a.ranks} rank(s)")
    return a.ranks * seconds


if not a.table_only:
    jobs = [(r, s) for s in a.seeds for r in sorted(a.ratio)]  # the densest (costliest) ring first
    with ThreadPoolExecutor(a.lanes) as pool:
        cpu = sum(pool.map(simulate, jobs))
    prev = json.load(open(os.path.join(a.out, "cost.json"))) if os.path.exists(os.path.join(a.out, "cost.json")) else {}
    json.dump({"cpu_seconds": prev.get("cpu_seconds", 0) + cpu}, open(os.path.join(a.out, "cost.json"), "w"))

# ---- analysis ----------------------------------------------------------------------------------
sys.path.insert(0, os.path.join(ROOT, "scripts"))
from gravity_wakes import wake  # noqa: E402  (the wakes' wave vector, as for cases/gravity-wakes)

Y_EDGES = np.linspace(0, LY / 2, int(round(a.ly_rh * 4)) + 1)  # |y| bins of r_H / 8
PIXELS = (0.25, 0.5, 1.0, 2.0)  # the visibility's pixel sizes, in r_H


def pixel_maps(down, ay, side, m, scale):
    """Mass per square pixel of `scale` r_H in (downstream distance, |y|, arm): each arm's
    downstream gap is the same pixels, and a pixel row is centred on |y| = 2 r_H (the gap)."""
    u_edges = np.arange(-30, 30 + 1e-9, scale)
    w_edges = np.arange(2 - scale / 2 - scale * math.floor((2 - scale / 2) / scale), a.ly_rh / 2 + 1e-9, scale)
    h, _ = np.histogramdd(np.column_stack([down, ay, side]), bins=[u_edges, w_edges, [-2, 0, 2]], weights=m)
    u_mid, w_mid = 0.5 * (u_edges[1:] + u_edges[:-1]), 0.5 * (w_edges[1:] + w_edges[:-1])
    gap = (u_mid[:, None] > 5) & (u_mid[:, None] < 25) & (np.abs(w_mid[None, :] - 2) < max(scale, 1) / 2)
    return h, np.broadcast_to(gap[:, :, None], h.shape)


def visibility(down, ay, side, m, one, two):
    """The gap against the wakes' own contrast, per pixel size: D_pix = 1 - <M_LE1(gap pixels)> /
    <M_LE2(all pixels)>, the unperturbed ring's pixel-to-pixel scatter CV = sd / mean of M_LE2,
    the part of it that the particles' own shot noise explains (a Poisson scatter of particles
    with LE2's masses: CV_shot^2 = <m^2> / (<m> <M>)), and the rest, the wakes': CV_wake^2 =
    CV^2 - CV_shot^2. A real ring has ~1e6 times the particles per pixel, so what an image would
    see is D_pix / CV_wake; D_pix / CV is this simulation's own map. Null: LE2's gap pixels."""
    out = {}
    m2 = m[two]
    for scale in PIXELS:
        h1, gap = pixel_maps(down[one], ay[one], side[one], m[one], scale)
        h2, _ = pixel_maps(down[two], ay[two], side[two], m2, scale)
        mean2 = h2.mean()
        cv = h2.std() / mean2
        cv_shot2 = np.mean(m2 ** 2) / (np.mean(m2) * mean2)
        out[scale] = dict(d=1 - h1[gap].mean() / mean2, d_null=1 - h2[gap].mean() / mean2, cv=cv,
                          cv_wake=math.sqrt(max(cv ** 2 - cv_shot2, 0.0)),
                          dark=float(np.mean(h1[gap] < np.median(h2))), dark_null=float(np.mean(h2[gap] < np.median(h2))))
    return out


Z_EDGES = np.arange(-30, 31, 1.0)  # downstream distance (r_H) for the height profile


def measure(frame):
    s = frame.read(columns=["position", "velocity", "mass", "radius", "le_copy"])
    x, v, m, c = s.position, s.velocity, s.mass.ravel(), s.le_copy.ravel()
    one, two = c == 0, c == 1
    down = x[:, 0] * np.sign(x[:, 1]) / R_HILL  # downstream distance in r_H (positive past the moonlet)
    ay = np.abs(x[:, 1]) / R_HILL
    band = (ay > 1.5) & (ay < 2.5)
    gap, mirror = band & (down > 5) & (down < 25), band & (down < -5) & (down > -25)
    m1, m2, m2m = m[gap & one].sum(), m[gap & two].sum(), m[mirror & two].sum()
    ds = (down > 5) & (down < 25)
    h1, _ = np.histogram(ay[one & ds] * R_HILL, bins=Y_EDGES, weights=m[one & ds])
    h2, _ = np.histogram(ay[two & ds] * R_HILL, bins=Y_EDGES, weights=m[two & ds])
    # The propeller's height: rms z near the moonlet (1-4 r_H radially, 2-10 r_H downstream)
    near = (ay > 1) & (ay < 4) & (down > 2) & (down < 10)
    z_rms = lambda sel: float(np.sqrt(np.average(x[sel, 2] ** 2, weights=m[sel]))) if sel.any() else float("nan")
    # ... and its profile downstream (1 r_H bins), gap region 1-3 r_H: sums of m z^2 and m
    gapz = (ay > 1) & (ay < 3)
    zsum = {k: (np.histogram(down[sel], bins=Z_EDGES, weights=m[sel] * x[sel, 2] ** 2)[0],
                np.histogram(down[sel], bins=Z_EDGES, weights=m[sel])[0]) for k, sel in (("z1", gapz & one), ("z2", gapz & two))}
    unperturbed = {"position": x[two], "mass": m[two], "radius": s.radius.ravel()[two], "offset": s.offset,
                   "L": s.lengths, "lo": s.origin}
    _, lam, pitch = wake(unperturbed, cells=(int(LX / 10), int(LY / 5)))
    mid = np.mean(m[two] * v[two, 1]) / np.mean(m[two])
    sigma_y = math.sqrt(np.average((v[two, 1] - mid) ** 2, weights=m[two]))
    Sigma = m[two].sum() / (LX * LY)
    return dict(time=s.time, depth=1 - m1 / m2, null=1 - m2 / m2m, h1=h1, h2=h2,
                vis=visibility(down, ay, np.sign(x[:, 1]), m, one, two),
                # where LE1's population differs from LE2's: (M_LE1 - M_LE2) / M_LE2 by region
                where={k: (m[sel & one].sum() - m[sel & two].sum()) / m[two].sum() for k, sel in
                       (("upstream", down < -2), ("near", np.abs(down) <= 2), ("downstream", down > 2))},
                z1=z_rms(near & one), z2=z_rms(near & two), z1_max=float(np.abs(x[near & one, 2]).max()) if (near & one).any() else float("nan"),
                wavelength=lam, pitch=pitch, Q=sigma_y * OMEGA0 / (3.36 * G * Sigma), Sigma=Sigma,
                n1=int(one.sum()), n2=int(two.sum()), zsum=zsum)


rows_out, table, series = [], [], []
y_mid = 0.5 * (Y_EDGES[1:] + Y_EDGES[:-1])
profiles = {}
for ratio in sorted(a.ratio, reverse=True):
    per_seed = []
    for seed in a.seeds:
        frames = frames_of(ratio, seed, (a.start - 0.025) * T0, None if a.end is None else (a.end + 0.025) * T0)  # snapshots fall on steps
        if not frames:
            continue
        rs = [measure(f) for f in frames]
        series += [(ratio, seed, r["time"] / T0, r["depth"], r["null"], r["wavelength"] / (4 * math.pi ** 2 * G * r["Sigma"] / OMEGA0 ** 2),
                    r["Q"], r["z1"] / R_HILL, r["z2"] / R_HILL) for r in rs]
        h1, h2 = sum(r["h1"] for r in rs), sum(r["h2"] for r in rs)
        deficit = 1 - h1 / np.maximum(h2, 1e-300)
        profiles[(ratio, seed)] = deficit
        pos = np.clip(deficit, 0, None)
        lam_cr = 4 * math.pi ** 2 * G * np.mean([r["Sigma"] for r in rs]) / OMEGA0 ** 2
        run = dict(ratio=ratio, seed=seed, frames=len(rs), t_from=rs[0]["time"] / T0, t_to=rs[-1]["time"] / T0,
                   lambda_cr=lam_cr, rH_over_lambda_cr=R_HILL / lam_cr,
                   depth=float(np.mean([r["depth"] for r in rs])), depth_sd=float(np.std([r["depth"] for r in rs], ddof=1)) if len(rs) > 1 else float("nan"),
                   null=float(np.mean([r["null"] for r in rs])), null_sd=float(np.std([r["null"] for r in rs], ddof=1)) if len(rs) > 1 else float("nan"),
                   centroid_rH=float(np.sum(y_mid * pos) / np.sum(pos) / R_HILL) if pos.sum() > 0 else float("nan"),
                   # the same within |y| < 4 r_H, the narrowest box's half-width: comparable across box widths
                   centroid4_rH=float(np.sum((y_mid * pos)[y_mid < 4 * R_HILL]) / np.sum(pos[y_mid < 4 * R_HILL]) / R_HILL)
                   if pos[y_mid < 4 * R_HILL].sum() > 0 else float("nan"),
                   wavelength=float(np.mean([r["wavelength"] for r in rs])), pitch=float(np.mean([r["pitch"] for r in rs])),
                   Q=float(np.mean([r["Q"] for r in rs])),
                   z_le1_rH=float(np.nanmean([r["z1"] for r in rs])) / R_HILL, z_le2_rH=float(np.nanmean([r["z2"] for r in rs])) / R_HILL,
                   z_le1_max_rH=float(np.nanmax([r["z1_max"] for r in rs])) / R_HILL,
                   le1_over_le2=float(np.mean([r["n1"] / r["n2"] for r in rs])),
                   **{f"le1_excess_{k}": float(np.mean([r["where"][k] for r in rs])) for k in ("upstream", "near", "downstream")})
        zp = {k: np.sqrt(sum(r["zsum"][k][0] for r in rs) / np.maximum(sum(r["zsum"][k][1] for r in rs), 1e-300)) / R_HILL
              for k in ("z1", "z2")}
        down_mid = 0.5 * (Z_EDGES[1:] + Z_EDGES[:-1])
        after = down_mid > 0
        run["height_max_rH"] = float(zp["z1"][after].max())
        run["height_at_rH"] = float(down_mid[after][np.argmax(zp["z1"][after])])
        run["height_far_rH"] = float(np.median(zp["z2"]))
        run["height_profile"] = " ".join(f"{z:.2f}" for z in zp["z1"][after][:25])  # rms z / r_H at 0.5, 1.5, ... r_H downstream
        half = 1 - h1.reshape(-1, 4).sum(axis=1) / np.maximum(h2.reshape(-1, 4).sum(axis=1), 1e-300)  # bins of r_H / 2
        run["deficit_profile"] = " ".join(f"{d:+.2f}" for d in half)
        run["gap"] = bool(run["depth"] > 3 * run["null_sd"])
        for scale in PIXELS:  # the visibility: frame means of the gap's and the wakes' contrast
            v = {k: float(np.mean([r["vis"][scale][k] for r in rs])) for k in rs[0]["vis"][scale]}
            run[f"vis{scale:g}"] = v["d"] / v["cv_wake"] if v["cv_wake"] > 0 else float("inf")
            run[f"vis_null{scale:g}"] = v["d_null"] / v["cv_wake"] if v["cv_wake"] > 0 else float("nan")
            run.update({f"{k}{scale:g}": v[k] for k in ("d", "cv", "cv_wake", "dark", "dark_null")})
        rows_out.append(run)
        per_seed.append(run)
    if per_seed:
        table.append(per_seed)

keys = ["ratio", "seed", "frames", "t_from", "t_to", "lambda_cr", "rH_over_lambda_cr", "depth", "depth_sd", "null", "null_sd", "gap",
        "centroid_rH", "wavelength", "pitch", "Q", "z_le1_rH", "z_le2_rH", "z_le1_max_rH", "height_max_rH", "height_at_rH", "height_far_rH", "le1_over_le2",
        "le1_excess_upstream", "le1_excess_near", "le1_excess_downstream"] + [
    f"{k}{p:g}" for p in PIXELS for k in ("vis", "vis_null", "d", "cv", "cv_wake", "dark", "dark_null")]
with open(os.path.join(a.out, "runs.csv"), "w") as f:
    f.write(",".join(keys) + "\n")
    for r in rows_out:
        f.write(",".join(f"{r[k]:.4g}" if isinstance(r[k], float) else str(r[k]) for k in keys) + "\n")
with open(os.path.join(a.out, "series.csv"), "w") as f:  # per snapshot: how the gap and the wakes develop
    f.write("ratio,seed,orbits,depth,null,wavelength_over_lambda_cr,Q,z_rms_le1_rH,z_rms_le2_rH\n")
    for row in series:
        f.write(",".join(f"{v:.4g}" for v in row) + "\n")
for r in rows_out:
    print(f"r_H/lambda_cr {r['rH_over_lambda_cr']:.2f} (lambda_cr {r['lambda_cr']:.0f} m) seed {r['seed']}: orbits {r['t_from']:.2f}-{r['t_to']:.2f} "
          f"({r['frames']} frames); gap depth D = {r['depth']:.3f} (frame sd {r['depth_sd']:.3f}), null {r['null']:+.3f} "
          f"(sd {r['null_sd']:.3f}) -> {'gap' if r['gap'] else 'no gap'}; deficit centroid {r['centroid_rH']:.2f} r_H; "
          f"wakes {r['wavelength']:.0f} m = {r['wavelength'] / r['lambda_cr']:.2f} lambda_cr, pitch {r['pitch']:.0f} deg, Q {r['Q']:.2f}; "
          f"rms z near the moonlet {r['z_le1_rH']:.3f} r_H (unperturbed {r['z_le2_rH']:.3f}), max |z| {r['z_le1_max_rH']:.2f} r_H; "
          f"height (rms z at 1-3 r_H) peaks at {r['height_max_rH']:.3f} r_H, {r['height_at_rH']:.1f} r_H downstream (unperturbed {r['height_far_rH']:.3f}); "
          f"LE1/LE2 {r['le1_over_le2']:.3f} (LE1 - LE2 upstream / within 2 r_H / downstream: {r['le1_excess_upstream']:+.3f} / "
          f"{r['le1_excess_near']:+.3f} / {r['le1_excess_downstream']:+.3f})")
    print(f"    deficit 1 - Sigma_LE1/Sigma_LE2, 5-25 r_H downstream, at |y| = 0.25, 0.75, ... r_H: {r['deficit_profile']}; "
          f"its centroid within |y| < 4 r_H {r['centroid4_rH']:.2f} r_H")
    print(f"    height: LE1's rms z (r_H) at 1-3 r_H radially, 0.5, 1.5, ... r_H downstream: {r['height_profile']}")
    for p in PIXELS:
        print(f"    pixels {p:g} r_H: gap deficit {r[f'd{p:g}']:.2f}, unperturbed scatter CV {r[f'cv{p:g}']:.2f} "
              f"(wakes' part {r[f'cv_wake{p:g}']:.2f}) -> visibility D/CV_wake {r[f'vis{p:g}']:.2f} (null {r[f'vis_null{p:g}']:+.2f}), "
              f"D/CV {r[f'd{p:g}'] / r[f'cv{p:g}']:.2f}; gap pixels darker than the ring's median {r[f'dark{p:g}']:.2f} (null {r[f'dark_null{p:g}']:.2f})")

# Across seeds, per ratio (this window's runs and --earlier rows of other seeds): the mean and
# the seeds' standard deviation of each criterion, the error bar that frame scatter is not.
pooled = {(r["ratio"], r["seed"]): r for r in rows_out}
for path in a.earlier:
    with open(path) as f:
        for row in csv.DictReader(f):
            key = (float(row["ratio"]), int(row["seed"]))
            if key not in pooled and abs(float(row["t_from"]) - a.start) < 0.05 and (a.end is None or abs(float(row["t_to"]) - a.end) < 0.1):
                pooled[key] = {k: float(row[k]) for k in ("rH_over_lambda_cr", "depth", "null", "vis0.25", "vis1", "wavelength",
                                                          "lambda_cr", "Q", "height_max_rH", "centroid_rH")}
for ratio in sorted({k[0] for k in pooled}, reverse=True):
    rs = [pooled[k] for k in sorted(pooled) if k[0] == ratio]
    if len(rs) < 2:
        continue
    def stat(f):
        v = np.array([f(r) for r in rs])
        return f"{v.mean():.3f} +- {v.std(ddof=1):.3f}"
    print(f"r_H/lambda_cr {ratio:g}, {len(rs)} seeds ({', '.join(str(k[1]) for k in sorted(pooled) if k[0] == ratio)}), mean +- seed sd: "
          f"D {stat(lambda r: r['depth'])}; visibility at r_H/4 {stat(lambda r: r['vis0.25'])}; "
          f"wakes / lambda_cr {stat(lambda r: r['wavelength'] / r['lambda_cr'])}; Q {stat(lambda r: r['Q'])}; "
          f"height {stat(lambda r: r['height_max_rH'])} r_H; deficit centroid {stat(lambda r: r['centroid_rH'])} r_H")

# Each criterion against r_H / lambda_cr: every seed a dot, the mean and the seeds' sd a bar.
if len(pooled) > 1:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    panels = [("gap depth D (mass)", lambda r: r["depth"], "null"), ("visibility D_pix / CV_wake", lambda r: r["vis0.25"], None),
              ("wakes / lambda_cr", lambda r: r["wavelength"] / r["lambda_cr"], None), ("height: peak rms z / r_H", lambda r: r["height_max_rH"], None)]
    fig, ax = plt.subplots(1, len(panels), figsize=(14, 3.4))
    ratios = sorted({k[0] for k in pooled})
    for a_, (label, f, null) in zip(ax, panels):
        for ratio in ratios:
            rs = [pooled[k] for k in sorted(pooled) if k[0] == ratio]
            v = np.array([f(r) for r in rs])
            a_.plot([ratio] * len(v), v, "o", color="0.6", ms=4)
            a_.errorbar([ratio], [v.mean()], yerr=[v.std(ddof=1) if len(v) > 1 else 0], fmt="s", color="k", capsize=4)
            if null:
                a_.plot([ratio] * len(rs), [r[null] for r in rs], "x", color="tab:red", ms=5)
            if label.startswith("visibility"):
                a_.plot([ratio] * len(rs), [r["vis1"] for r in rs], "^", color="tab:blue", ms=4)
        a_.set_xscale("log", base=2)
        a_.set_xticks(ratios, [f"{r:g}" for r in ratios])
        a_.set_xlabel("r_H / lambda_cr")
        a_.set_title(label, fontsize=9)
    # Check runs: each table its own marker, a little to the right of its ratio.
    for n, spec in enumerate(a.checks):
        path, _, label = spec.partition("=")
        try:
            with open(path) as f:
                rows = [{k: float(row[k]) for k in ("ratio", "depth", "vis0.25", "wavelength", "lambda_cr", "height_max_rH")}
                        for row in csv.DictReader(f)]
        except (OSError, KeyError, ValueError) as e:
            sys.exit(f"propeller_gravity.py: --checks {spec!r}: expected TABLE[=LABEL] with TABLE a runs.csv written by "
                     f"this script (columns ratio, depth, vis0.25, wavelength, lambda_cr, height_max_rH): {e!r}")
        marker = "DPv*"[n % 4]
        for a_, (_, f_, _) in zip(ax, panels):
            a_.plot([r["ratio"] * 1.08 ** (n + 1) for r in rows], [f_(r) for r in rows], marker, color=f"C{n + 1}",
                    ms=6, mfc="none", label=label or path)
    if a.checks:
        ax[0].legend(fontsize=7, loc="center left")
    ax[0].text(0.02, 0.02, "x: null (no moonlet)", transform=ax[0].transAxes, fontsize=7, color="tab:red")
    ax[1].axhline(1, color="k", lw=0.5)
    ax[1].set_yscale("log")
    ax[1].text(0.02, 0.92, "pixels r_H/4 (o, bar); r_H (triangles)", transform=ax[1].transAxes, fontsize=7)
    ax[2].axhline(1, color="k", lw=0.5)
    ax[3].axhspan(0.6, 0.8, color="tab:green", alpha=0.2, label="Hoffmann et al.")
    ax[3].set_ylim(0, 0.9)
    ax[3].legend(fontsize=7)
    fig.suptitle(f"orbits {a.start:g}-{a.end if a.end is not None else a.orbits:g}, {len(pooled)} runs: seeds (dots), mean +- seeds' sd (bars)", fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "criteria.png"), dpi=90)

if rows_out:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    runs = [r for r in rows_out if r["seed"] == a.seeds[0]]
    fig, ax = plt.subplots(len(runs) + 2, 1, figsize=(11, 2.2 * len(runs) + 6), squeeze=False)
    for i, r in enumerate(runs):
        last = frames_of(r["ratio"], r["seed"], 0)[-1].read(columns=["position", "mass", "le_copy"], copy=0)
        x = last.position
        h, _, _ = np.histogram2d(x[:, 0] / R_HILL, x[:, 1] / R_HILL, bins=[int(LX / 20), int(LY / 10)],
                                 range=[[-LX / 2 / R_HILL, LX / 2 / R_HILL], [-LY / 2 / R_HILL, LY / 2 / R_HILL]], weights=last.mass.ravel())
        ax[i, 0].imshow(h.T / h.mean(), origin="lower", extent=[-LX / 2 / R_HILL, LX / 2 / R_HILL, -LY / 2 / R_HILL, LY / 2 / R_HILL],
                        aspect="auto", cmap="gray", vmin=0, vmax=2.5)
        ax[i, 0].set_title(f"r_H / lambda_cr = {r['rH_over_lambda_cr']:.2f}: LE1 at {last.time / T0:.2f} orbits", fontsize=9)
        ax[i, 0].set_ylabel("y / r_H")
    ax[len(runs) - 1, 0].set_xlabel("x / r_H")
    for r in runs:
        ax[-2, 0].plot(y_mid / R_HILL, profiles[(r["ratio"], r["seed"])], "o-", label=f"r_H / lambda_cr = {r['rH_over_lambda_cr']:.2f}")
    ax[-2, 0].axhline(0, color="k", lw=0.5)
    ax[-2, 0].set_xlabel("|y| / r_H (5-25 r_H downstream)")
    ax[-2, 0].set_ylabel("deficit 1 - Sigma_LE1 / Sigma_LE2")
    ax[-2, 0].legend(fontsize=8)
    for r in runs:
        rows = [row for row in series if row[0] == r["ratio"] and row[1] == r["seed"]]
        ax[-1, 0].plot([row[2] for row in rows], [row[3] for row in rows], "o-", ms=3, label=f"D, r_H / lambda_cr = {r['rH_over_lambda_cr']:.2f}")
        ax[-1, 0].plot([row[2] for row in rows], [row[4] for row in rows], ":", color=ax[-1, 0].lines[-1].get_color(), label="null")
    ax[-1, 0].set_xlabel("orbits (the analysis window)")
    ax[-1, 0].set_ylabel("gap depth D")
    ax[-1, 0].legend(fontsize=7, ncol=3)
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "maps.png"), dpi=90)

#!/usr/bin/python3
"""scripts/clog_hazard.py against ensembles whose law is known (written as ensemble CSVs).

1. Geometric s (a constant hazard p = 0.04 per passing bead: <s> = 24), ensembles of 400 runs,
   a third of them stopped early at a random time limit (censored, as runs at the time limit
   are). Over 100 such ensembles the stationary estimate's 95 % interval holds 24 in 88-100 %
   of them (95 % +- 3 binomial standard deviations) and the estimates average to 24 within 2 %
   (3 standard errors of that average); the flat-hazard test rejects fewer than 5 of them at
   p < 0.01.
2. A rising hazard h(s) = 0.005 (1 + s/4) (runs age, as the clogging runs do): the flat-hazard
   test rejects it (p < 1e-4) and the plain mean of s is far below 1/h(0).
3. A run stopped by a guard, whose front never passed, or that clogged before its front passed
   (a pile behind an early clog can fill the approach) is left out.
4. Continuous mode (--avalanches 2): runs whose first avalanche follows another law (s = 60
   always, as from an empty channel) and whose later ones are geometric (<s> = 9), each run's
   last avalanche open at its time limit (censored). From the second avalanche on, the estimate
   holds 9 in its 95 % interval and has a flat hazard; with the first avalanches included the
   interval misses 9; the open avalanches are counted as exposure, not dropped or taken as clogs.
Seeded: the draws, hence the verdicts, are the same on every machine.
"""
import csv
import importlib.util
import math
import os
import random
import sys
import tempfile

spec = importlib.util.spec_from_file_location("clog_hazard", os.path.join(sys.argv[1], "scripts", "clog_hazard.py"))
ch = importlib.util.module_from_spec(spec)
spec.loader.exec_module(ch)

HEADER = ["run", "seed", "D_over_d", "clogged", "escapees", "clog_time", "simulated_time", "inserted",
          "max_overlap_over_radius", "wall_seconds", "front_time", "escapees_after_front", "avalanches",
          "avalanche_starts", "longest_pause", "ended"]


def write(path, runs):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(HEADER)
        for k, (s, clogged, ended, front) in enumerate(runs):
            end = 0.3 + 0.01 * s  # a steady flux of 100 beads per second from the front on
            w.writerow([k, k + 1, 1.7, int(clogged), s, end if clogged else "", end, "", 0, 0, "0.3" if front else "",
                        s if front else "", "", "", 0, ended])


def draw(rng, hazard, limit):
    """Beads that pass before the clog (or the limit): s, clogged."""
    s = 0
    while s < limit:
        if rng.random() < hazard(s):
            return s, True
        s += 1
    return s, False


failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


rng = random.Random(20261125)
with tempfile.TemporaryDirectory() as d:
    p = 0.04
    runs = []
    for k in range(400):
        limit = rng.randint(5, 60) if k % 3 == 0 else 10**9
        s, c = draw(rng, lambda s: p, limit)
        runs.append((s, c, "clogged" if c else "time limit", True))
    runs.append((5, False, "guard: overlap", True))      # left out
    runs.append((0, False, "time limit", False))         # no front: left out
    path = os.path.join(d, "geometric.csv")
    write(path, runs)
    with open(path, "a") as f:  # clogged at 0.2 s, before its front passed at 0.3 s: left out
        f.write("402,403,1.7,1,0,0.2,1.2,,0,0,0.3,0,,,0,clogged\n")
    loaded = ch.load([path])
    check(len(loaded) == 400, f"guard-stopped, front-less and early-clogged runs left out ({len(loaded)} of 403 kept)")
    truth = (1 - p) / p
    estimates, covered, rejected = [], 0, 0
    for k in range(100):
        r = random.Random(1000 + k)
        runs = [draw(r, lambda s: p, r.randint(5, 60) if j % 3 == 0 else 10**9) for j in range(400)]
        est, lo, hi, _, _ = ch.stationary(runs, 0)
        estimates.append(est)
        covered += lo < truth < hi
        s_sorted = sorted(s for s, _ in runs)
        bins = sorted({0} | {s_sorted[len(s_sorted) * q // 8] for q in range(1, 8)})
        rejected += ch.flat_hazard(runs, bins, 0)[2] < 0.01
    mean = sum(estimates) / len(estimates)
    print(f"     geometric: 95 % interval covers <s> = {truth:.0f} in {covered} of 100 ensembles; mean estimate "
          f"{mean:.2f}; flat hazard rejected at p < 0.01 in {rejected}")
    check(88 <= covered <= 100, "the 95 % interval covers the true <s> at its nominal rate")
    check(abs(mean - truth) < 0.02 * truth, "the estimate is unbiased (censored runs counted exactly)")
    check(rejected < 5, "a constant hazard is rejected at about the test's false-alarm rate")

    rising = [draw(rng, lambda s: 0.005 * (1 + s / 4), 10**9) for _ in range(400)]
    path = os.path.join(d, "rising.csv")
    write(path, [(s, c, "clogged", True) for s, c in rising])
    loaded = ch.load([path])
    s_sorted = sorted(s for s, _ in loaded)
    bins = sorted({0} | {s_sorted[len(s_sorted) * k // 8] for k in range(1, 8)})
    chi2, dof, pval = ch.flat_hazard(loaded, bins, 0)
    mean = sum(s for s, _ in loaded) / len(loaded)
    print(f"     rising: flat hazard chi^2 = {chi2:.1f} / {dof}, p = {pval:.3g}; mean s {mean:.1f} against 1/h(0) = 200")
    check(pval < 1e-4, "a rising hazard is rejected")
    check(mean < 100, "ageing runs clog long before 1/h(0)")

    # Continuous mode: the first avalanche is another law's, the rest geometric, the last open.
    p = 0.1
    truth = (1 - p) / p
    path = os.path.join(d, "continuous.csv")
    cols = HEADER + ["count_time", "escapees_after_count", "recovery_clogs", "open_avalanche", "open_avalanche_start",
                     "phi_beyond_clear", "avalanche_clogs"]
    opened = 0
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for k in range(300):
            sizes, starts, clogs, t = [60], [0.0], [0.6], 0.7
            for _ in range(rng.randint(1, 10)):
                s, _ = draw(rng, lambda s: p, 10**9)
                sizes.append(s)
                starts.append(t)
                clogs.append(t + 0.01 * s)
                t += 0.01 * s + 0.1
            s_open, clogged = draw(rng, lambda s: p, rng.randint(1, 30))
            opened += not clogged
            row = dict(run=k, seed=k + 1, D_over_d=1.5, clogged=0, escapees=sum(sizes) + s_open, clog_time="",
                       simulated_time=t + 0.01 * s_open, avalanches=" ".join(map(str, sizes)),
                       avalanche_starts=" ".join(map(str, starts)), avalanche_clogs=" ".join(map(str, clogs)),
                       open_avalanche=s_open if not clogged else "", open_avalanche_start=t if not clogged else "",
                       ended="time limit")
            w.writerow([row.get(c, "") for c in cols])
    later = ch.load([path], first=2)
    est, lo, hi, _, clogs = ch.stationary(later, 0)
    s_sorted = sorted(s for s, _ in later)
    bins = sorted({0} | {s_sorted[len(s_sorted) * q // 8] for q in range(1, 8)})
    pval = ch.flat_hazard(later, bins, 0)[2]
    est1, lo1, hi1, _, _ = ch.stationary(ch.load([path], first=1), 0)
    censored = sum(1 for _, c in later if not c)
    print(f"     continuous: from the 2nd avalanche {est:.2f} ({lo:.2f} - {hi:.2f}) over {clogs} clogs and {censored} open "
          f"avalanches, flat hazard p = {pval:.2f}; with the 1st {est1:.2f} ({lo1:.2f} - {hi1:.2f}); truth {truth:.0f}")
    check(lo < truth < hi, "continuous mode: the avalanches from the second on estimate the stationary <s>")
    check(pval > 0.01, "continuous mode: their hazard is flat")
    check(not lo1 < truth < hi1, "continuous mode: the first avalanches (another law) would bias it")
    check(censored == opened > 0, "continuous mode: open avalanches count as censored exposure")
    times = ch.records([path], first=2)
    check(all(abs((t1 - t0) - 0.01 * s) < 1e-9 for t0, t1, s, c in times if c), "continuous mode: each avalanche timed from its count's start to its clog")

    # Wilson-Hilferty quantiles against tabulated chi-square values (Abramowitz & Stegun 26.8).
    for k, q, x in [(2, 0.975, 7.378), (10, 0.025, 3.247), (40, 0.975, 59.342)]:
        got = ch.chi2_quantile(k, q)
        check(abs(got - x) < 0.02 * x, f"chi^2_{k}({q}) = {got:.3f} against {x}")

sys.exit(1 if failures else 0)

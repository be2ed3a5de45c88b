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

    # Wilson-Hilferty quantiles against tabulated chi-square values (Abramowitz & Stegun 26.8).
    for k, q, x in [(2, 0.975, 7.378), (10, 0.025, 3.247), (40, 0.975, 59.342)]:
        got = ch.chi2_quantile(k, q)
        check(abs(got - x) < 0.02 * x, f"chi^2_{k}({q}) = {got:.3f} against {x}")

sys.exit(1 if failures else 0)

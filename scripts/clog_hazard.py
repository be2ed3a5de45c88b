#!/usr/bin/python3
"""Is clogging memoryless? The hazard per passing bead, and the stationary <s> (issue 19).

    /usr/bin/python3 scripts/clog_hazard.py ENSEMBLE.csv [more.csv ...] [--bins 0,5,10,20] [--burn-in S0]
                                            [--time 0,0.3,0.4,0.6,1] [--count | --avalanches K]

Reads ensemble CSVs (cassini --ensemble) and pools their runs. s is counted from the front
(escapees_after_front), or with --count from clog.count_from (escapees_after_count); runs in
which counting never started, or that clogged before it did, are left out (left truncation), as
are runs a guard stopped.

If clogging were a Poisson process in the beads that pass (constant probability p per passing
bead, the statistics Marin et al. 2018 report), s would be geometric: the hazard h(s) = P(clog
at the (s+1)-th attempt | s passed) would be flat, and <s> = (1 - p) / p. This prints:
 - h(s) per bin of s: clogs in the bin over attempts in the bin (passes through it + clogs),
   with its Poisson error;
 - the stationary estimate beyond a burn-in of S0 beads (runs that reached S0 enter the count
   there: left truncation): <s>_stat = passes beyond S0 / clogs beyond S0, the maximum-
   likelihood estimate of (1 - p)/p for a constant hazard, with a 95 % interval (exact Poisson
   interval on the number of clogs, chi-square quantiles by Wilson-Hilferty). Runs that ended
   without a clog (time limit) count with the passes they had: censoring is handled exactly.
 - Pearson's chi-square of a flat hazard beyond S0 over the bins, and its p-value;
 - the plain mean of s over runs that clogged (what single runs report) for comparison;
 - with --avalanches K (continuous mode, clog.mode = "continuous"): every counted avalanche from
   the K-th of its run on is a sample (K = 2 leaves out the first, which starts from the empty
   channel), timed from its count's start to its clog; a run's open avalanche (the time limit
   came while it counted) is censored;
 - with --time: the hazard per second of flow in bins of time since the start (clogs in the bin
   over the run-seconds at risk in it, exact from clog_time), and per passing bead (the same
   over the passes in the bin, each run's passes spread evenly between its front and its end:
   an approximation where the flux changes), and <s> from each bin's start on (passes over clogs
   from then: the stationary estimate if the hazard is flat from there). A hazard that still
   rises when the last runs clog
   means the runs never reached a stationary state: their <s> is that of the transient.
"""
import os
import math
import sys
sys.path.insert(0, os.path.join(os.path.dirname(os.path.realpath(__file__)), os.pardir, "python"))
from cassini_tools import read_ensemble


def chi2_quantile(k, q):
    """Wilson-Hilferty: within ~1 % of the exact quantile for k >= 2."""
    if k <= 0:
        return 0.0
    z = math.sqrt(2) * inverse_erf(2 * q - 1)
    c = 2.0 / (9 * k)
    return k * max(1 - c + z * math.sqrt(c), 0.0) ** 3


def chi2_survival(x, k):
    if k <= 0:
        return float("nan")
    c = 2.0 / (9 * k)
    z = ((x / k) ** (1.0 / 3) - (1 - c)) / math.sqrt(c)
    return 0.5 * math.erfc(z / math.sqrt(2))


def inverse_erf(y):
    # Newton on erf(x) = y from a good start (|y| < 1).
    x = 0.0
    for _ in range(60):
        err = math.erf(x) - y
        x -= err / (2 / math.sqrt(math.pi) * math.exp(-x * x))
    return x


def avalanche_records(paths, first):
    """(start, end, s, clogged) per continuous-mode avalanche, from the first-th (1-based) of each
    run on; the open avalanche of a run that reached its time limit is censored."""
    out = []
    for path in paths:
        for r in read_ensemble(path, raw=True):
            if r["ended"].startswith("guard"):
                continue
            sizes = [int(float(x)) for x in r.get("avalanches", "").split()]
            starts = [float(x) for x in r.get("avalanche_starts", "").split()]
            clogs = [float(x) for x in (r.get("avalanche_clogs") or "").split()]
            for k in range(first - 1, len(sizes)):
                out.append((starts[k], clogs[k] if k < len(clogs) else float("nan"), sizes[k], True))
            if (r.get("open_avalanche") or "") != "" and len(sizes) + 1 >= first:
                out.append((float(r["open_avalanche_start"]), float(r["simulated_time"]), int(float(r["open_avalanche"])), False))
    return out


def records(paths, count=False, first=None):
    """(start, end, s, clogged) per run: s counted from the start of counting (the front, or
    clog.count_from with count=True) to the run's clog (its standstill's start) or its end; with
    first (continuous mode), per avalanche (avalanche_records)."""
    if first is not None:
        return avalanche_records(paths, first)
    t_key, s_key = ("count_time", "escapees_after_count") if count else ("front_time", "escapees_after_front")
    out = []
    for path in paths:
        for r in read_ensemble(path, raw=True):
            if r["ended"].startswith("guard") or r.get(s_key, "") == "":
                continue  # stopped by a guard, or counting never started
            clogged = r["clogged"] == "1"
            start = float(r[t_key])
            end = float(r["clog_time"]) if clogged else float(r["simulated_time"])
            if clogged and end < start:
                continue  # clogged before counting started (older CSVs still count these as s = 0)
            out.append((start, end, int(float(r[s_key])), clogged))
    return out


def load(paths, count=False, first=None):
    return [(s, c) for _, _, s, c in records(paths, count, first)]


def attempts_in(runs, a, b):
    """Passes through [a, b) and clogs at s in [a, b), pooled over runs."""
    passes = sum(max(0, min(s, b) - a) for s, _ in runs)
    clogs = sum(1 for s, c in runs if c and a <= s < b)
    return passes, clogs


def stationary(runs, s0):
    passes, clogs = attempts_in(runs, s0, 10**12)
    if clogs == 0:
        # No clog beyond S0: only a lower bound (95 %: fewer than 3.0 expected clogs).
        return float("inf"), passes / 3.0, float("inf"), passes, clogs
    lo_rate = chi2_quantile(2 * clogs, 0.025) / 2 / (passes + clogs)
    hi_rate = chi2_quantile(2 * clogs + 2, 0.975) / 2 / (passes + clogs)
    return passes / clogs, max(0.0, (1 - hi_rate) / hi_rate), (1 - lo_rate) / lo_rate if lo_rate > 0 else float("inf"), passes, clogs


def hazard_table(runs, bins):
    """(from, to, attempts, clogs) per bin of s that has attempts."""
    edges = bins + [10**12]
    rows = []
    for a, b in zip(edges[:-1], edges[1:]):
        passes, clogs = attempts_in(runs, a, b)
        if passes + clogs > 0:
            rows.append((a, b, passes + clogs, clogs))
    return rows


def flat_hazard(runs, bins, s0):
    """Pearson's chi^2 of one hazard for every bin from s0 on: (chi2, degrees of freedom, p)."""
    passes, clogs = attempts_in(runs, s0, 10**12)
    tail = [(n, c) for a, _, n, c in hazard_table(runs, bins) if a >= s0]
    if clogs == 0 or len(tail) < 2:
        return float("nan"), 0, float("nan")
    p = clogs / (passes + clogs)
    chi2 = sum((c - p * n) ** 2 / (p * n) for n, c in tail)
    return chi2, len(tail) - 1, chi2_survival(chi2, len(tail) - 1)


def report(runs, bins, s0, what="runs"):
    clogged = [s for s, c in runs if c]
    mean = sum(clogged) / len(clogged) if clogged else float("nan")
    sd = math.sqrt(sum((s - mean) ** 2 for s in clogged) / (len(clogged) - 1)) if len(clogged) > 1 else float("nan")
    print(f"{len(runs)} {what}, {len(clogged)} clogged; mean s of the clogged runs {mean:.2f} +- "
          f"{sd / math.sqrt(len(clogged)) if len(clogged) > 1 else float('nan'):.2f} (sigma / mean "
          f"{sd / mean if mean > 0 else float('nan'):.2f}; "
          f"a geometric law has ~1); P(s = 0) {sum(1 for s in clogged if s == 0) / max(len(runs), 1):.3f}")
    print("\n| s from | to | attempts | clogs | hazard per bead | 1 / hazard |")
    print("|---|---|---|---|---|---|")
    for a, b, n, clogs in hazard_table(runs, bins):
        h = clogs / n
        print(f"| {a} | {'end' if b == 10**12 else b} | {n} | {clogs} | {h:.3g} +- {math.sqrt(clogs) / n:.2g} | "
              f"{(1 / h if h > 0 else float('inf')):.1f} |")
    est, lo, hi, passes, clogs = stationary(runs, s0)
    print(f"\nbeyond a burn-in of {s0} beads: {clogs} clogs in {passes} passes: stationary <s> = {est:.1f} "
          f"(95 %: {lo:.1f} - {hi:.1f})")
    chi2, dof, p = flat_hazard(runs, bins, s0)
    if dof > 0:
        print(f"flat hazard beyond {s0}: chi^2 = {chi2:.1f} over {dof} degrees of freedom, p = {p:.3g}")


def from_time(runs, t):
    """Passes and clogs from time t on over runs (start, end, s, clogged), each run's passes
    spread evenly over its time: passes / clogs is the stationary <s> if the hazard is flat from t."""
    clogs = sum(1 for _, t1, _, c in runs if c and t1 >= t)
    passes = sum(s * max(0.0, t1 - max(t, t0)) / (t1 - t0) for t0, t1, s, _ in runs if t1 > t0)
    return passes, clogs


def time_table(paths, edges, count=False, first=None):
    runs = [(t0, max(t1, t0), float(s), c) for t0, t1, s, c in records(paths, count, first)]
    if first is not None:  # avalanches: time since each count's start
        if any(math.isnan(t1) for _, t1, _, _ in runs):
            sys.exit("--time with --avalanches needs the avalanche_clogs column (ensembles from 2026-11-25 on)")
        runs = [(0.0, t1 - t0, s, c) for t0, t1, s, c in runs]
    print("\n| t from (s) | to | runs at risk | clogs | hazard per second | passes | hazard per bead | 1 / hazard per bead | "
          "<s> from t on |")
    print("|---|---|---|---|---|---|---|---|---|")
    for a, b in zip(edges[:-1], edges[1:]):
        exposure = sum(max(0.0, min(b, t1) - max(a, t0)) for t0, t1, _, _ in runs)
        at_risk = sum(1 for t0, t1, _, _ in runs if t1 > a and t0 < b)
        clogs = sum(1 for _, t1, _, c in runs if c and a <= t1 < b)
        passes = sum(s * max(0.0, min(b, t1) - max(a, t0)) / (t1 - t0) for t0, t1, s, _ in runs if t1 > t0)
        if at_risk == 0:
            continue
        later, later_clogs = from_time(runs, a)
        per_s = clogs / exposure if exposure > 0 else float("nan")
        per_bead = clogs / (passes + clogs) if passes + clogs > 0 else float("nan")
        tail = f"{later / later_clogs:.1f} +- {later / later_clogs / math.sqrt(later_clogs):.1f}" if later_clogs else "-"
        print(f"| {a} | {b} | {at_risk} | {clogs} | {per_s:.3g} +- {math.sqrt(clogs) / exposure if exposure > 0 else 0:.2g} | "
              f"{passes:.0f} | {per_bead:.3g} +- {math.sqrt(clogs) / (passes + clogs) if passes + clogs > 0 else 0:.2g} | "
              f"{(1 / per_bead if per_bead > 0 else float('inf')):.1f} | {tail} |")


def main():
    argv = list(sys.argv[1:])
    bins, s0 = None, 0
    if "--bins" in argv:
        k = argv.index("--bins")
        bins = [int(x) for x in argv[k + 1].split(",")]
        del argv[k:k + 2]
    if "--burn-in" in argv:
        k = argv.index("--burn-in")
        s0 = int(argv[k + 1])
        del argv[k:k + 2]
    times, count = None, "--count" in argv
    if count:
        argv.remove("--count")
    if "--time" in argv:
        k = argv.index("--time")
        times = [float(x) for x in argv[k + 1].split(",")]
        del argv[k:k + 2]
    first = None
    if "--avalanches" in argv:
        k = argv.index("--avalanches")
        first = int(argv[k + 1])
        del argv[k:k + 2]
        if count or first < 1:
            sys.exit("--avalanches K takes K >= 1, and not with --count")
    if not argv:
        sys.exit(__doc__)
    runs = load(argv, count, first)
    if not runs:
        sys.exit(("no avalanches" if first else "no runs with a front") + " in " + ", ".join(argv))
    if bins is None:  # quantiles of s, about 8 bins
        s = sorted(x for x, _ in runs)
        bins = sorted({0} | {s[len(s) * k // 8] for k in range(1, 8)})
    report(runs, sorted(set(bins) | {s0}), s0, "avalanches" if first else "runs")
    if times:
        time_table(argv, times, count, first)


if __name__ == "__main__":
    main()

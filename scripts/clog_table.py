#!/usr/bin/python3
"""The table of a clogging study whose ensembles lie in <point>/Dd_<r>/ensemble.csv
(scripts/clog-depth-study: H_<h>; scripts/clog-friction-study: mu<mu>_mur<mu_r>).

    /usr/bin/python3 scripts/clog_table.py [--from T] DIR [more DIRs with the same layout]

For every <point>/Dd_<r>/ensemble.csv under the directories (pooled where several hold the same
point): runs and clogs, the mean s of the runs that clogged (counted from the front, what single
runs report), the censored estimate from the front (passes over clogs, every run counted: runs
that reached the time limit count with the beads they passed), and the stationary <s> from
clog.count_from (the studies set 1 s) with its 95 % interval (scripts/clog_hazard.py's estimator),
<s> from T seconds on by time (default 0.9 s; each run's passes spread evenly over its time,
clog_hazard.py --time: the stationary estimate for ensembles whose runs mostly clog before
count_from), and the median wall seconds per run.
"""
import glob
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
from clog_hazard import from_time, records, stationary  # noqa: E402
from cassini_tools import read_ensemble  # noqa: E402  (clog_hazard put python/ on the path)


def fmt(x):
    return "inf" if x == float("inf") else f"{x:,.0f}" if x >= 100 else f"{x:.1f}"


def estimate(runs):
    """Censored <s> with its 95 % interval, or a lower bound where nothing clogged."""
    if not runs:
        return "no run got there"
    e = stationary([(x, c) for _, _, x, c in runs], 0)
    if e[4] == 0:
        return f"> {fmt(e[1])} (no clog in {e[3]:,} passes)"
    return f"{fmt(e[0])} ({fmt(e[1])}-{fmt(e[2])}), {e[4]} clogs"


def main():
    dirs = sys.argv[1:]
    since = 0.9
    if "--from" in dirs:
        k = dirs.index("--from")
        since = float(dirs[k + 1])
        del dirs[k:k + 2]
    if not dirs:
        sys.exit(__doc__)
    points = {}
    for d in dirs:
        for path in glob.glob(os.path.join(d, "*", "Dd_*", "ensemble.csv")):
            label = path.split(os.sep)[-3]
            r = float(path.split(os.sep)[-2][3:])
            points.setdefault((label, r), []).append(path)
    print("| point | D/d | runs (clogged) | mean s of the clogged runs | censored <s> from the front | "
          f"stationary <s> from count_from (95 %) | <s> from {since:g} s by time | wall s per run (median) |")
    print("|---|---|---|---|---|---|---|---|")
    for (label, r), paths in sorted(points.items()):
        front = records(paths)
        s = [x for _, _, x, c in front if c]
        mean = f"{statistics.mean(s):.1f} +- {statistics.stdev(s) / len(s) ** 0.5:.1f}" if len(s) > 1 else "-"
        passes, clogs = from_time([(t0, max(t1, t0), x, c) for t0, t1, x, c in front], since)
        by_time = f"{passes / clogs:,.1f} +- {passes / clogs / clogs ** 0.5:,.1f} ({clogs} clogs)" if clogs else "-"
        wall = [float(row["wall_seconds"]) for p in paths for row in read_ensemble(p, raw=True)]
        print(f"| {label} | {r:g} | {len(front)} ({len(s)}) | {mean} | {estimate(front)} | "
              f"{estimate(records(paths, count=True))} | {by_time} | {statistics.median(wall):.0f} |")


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""The channel-depth study's table (scripts/clog-depth-study; docs/clogging.md "Channel depth").

    /usr/bin/python3 scripts/clog_depth.py [DIR=runs/clog-depth] [more DIRs with the same layout]

For every H_<h>/Dd_<r>/ensemble.csv under the directories (pooled where several hold the same
point): runs and clogs, the mean s of the runs that clogged (counted from the front, what single
runs report), the censored estimate from the front (passes over clogs, every run counted: runs
that reached the time limit count with the beads they passed), and the stationary <s> from
t = 1 s (clog.count_from) with its 95 % interval (scripts/clog_hazard.py's estimator).
"""
import glob
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
from clog_hazard import records, stationary  # noqa: E402


def fmt(x):
    return "inf" if x == float("inf") else f"{x:,.0f}" if x >= 100 else f"{x:.1f}"


def main():
    dirs = sys.argv[1:] or ["runs/clog-depth"]
    points = {}
    for d in dirs:
        for path in glob.glob(os.path.join(d, "H_*", "Dd_*", "ensemble.csv")):
            h = float(path.split(os.sep)[-3][2:])
            r = float(path.split(os.sep)[-2][3:])
            points.setdefault((h, r), []).append(path)
    print("| H/D | D/d | runs (clogged) | mean s of the clogged runs | censored <s> from the front | stationary <s> from 1 s (95 %) |")
    print("|---|---|---|---|---|---|")
    for (h, r), paths in sorted(points.items()):
        front = records(paths)
        s = [x for _, _, x, c in front if c]
        mean = f"{statistics.mean(s):.1f} +- {statistics.stdev(s) / len(s) ** 0.5:.1f}" if len(s) > 1 else "-"
        def estimate(runs):
            e = stationary([(x, c) for _, _, x, c in runs], 0)
            if not runs:
                return "no run got there"
            if e[4] == 0:  # no clog: a lower bound (95 %)
                return f"> {fmt(e[1])} (no clog in {e[3]:,} passes)"
            return f"{fmt(e[0])} ({fmt(e[1])}-{fmt(e[2])}), {e[4]} clogs"
        counted = records(paths, count=True)
        print(f"| {h:g} | {r:g} | {len(front)} ({len(s)}) | {mean} | {estimate(front)} | {estimate(counted)} |")


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""Table of a clogging physics study (scripts/clog-physics-study): one row per variant.

    /usr/bin/python3 scripts/clog_physics.py runs/clog-physics/Dd_1.7 [more dirs]

<s> is over every run that ended (clogged, or at the time limit with its escapees so far);
runs stopped by a guard are counted apart and left out. The ratio to `base` has the
propagated standard error. `longest pause` is the longest standstill at the neck that a
passage ended, over all runs: the clog window must exceed it (docs/clogging.md).
"""
import math
import os
import sys
sys.path.insert(0, os.path.join(os.path.dirname(os.path.realpath(__file__)), os.pardir, "python"))
from cassini_tools import read_ensemble


def load(path):
    rows = read_ensemble(path, raw=True)
    ok = [r for r in rows if not r["ended"].startswith("guard")]
    s = [float(r["escapees"]) for r in ok]
    n = len(s)
    m = sum(s) / n if n else float("nan")
    sd = math.sqrt(sum((x - m) ** 2 for x in s) / (n - 1)) if n > 1 else float("nan")
    pauses = [float(r["longest_pause"]) for r in rows if r.get("longest_pause")]
    clog = [float(r["clog_time"]) for r in ok if r["clog_time"]]
    return {
        "runs": len(rows), "ok": n, "clogged": sum(r["clogged"] == "1" for r in rows),
        "guard": len(rows) - n, "mean": m, "se": sd / math.sqrt(n) if n > 1 else float("nan"),
        "cv": sd / m if n > 1 and m > 0 else float("nan"),
        "median": sorted(s)[n // 2] if n else float("nan"),
        "p0": sum(x == 0 for x in s) / n if n else float("nan"),
        "clog_time": sum(clog) / len(clog) if clog else float("nan"),
        "overlap": max(float(r["max_overlap_over_radius"]) for r in rows),
        "pause": max(pauses) if pauses else float("nan"),
        "wall": sum(float(r["wall_seconds"]) for r in rows) / len(rows),
        "s": s,
    }


def plot(res, out, title):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker
    base = res["base"]
    names = [v for v in res if v != "base" and res[v]["ok"] > 1]
    q = [res[v]["mean"] / base["mean"] for v in names]
    e = [qq * math.hypot(res[v]["se"] / res[v]["mean"], base["se"] / base["mean"]) for qq, v in zip(q, names)]
    fig, ax = plt.subplots(figsize=(5, 0.3 * len(names) + 1.2))
    ax.errorbar(q, range(len(names)), xerr=e, fmt="o")
    ax.axvline(1, color="gray", lw=0.8)
    ax.set_yticks(range(len(names)), names)
    ax.set_xscale("log")
    ax.xaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
    ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_xlabel("<s> / <s>(base)")
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    print("wrote", out)


def main():
    out = None
    if "--plot" in sys.argv:
        k = sys.argv.index("--plot")
        out = sys.argv[k + 1]
        del sys.argv[k:k + 2]
    for d in sys.argv[1:]:
        variants = sorted(v for v in os.listdir(d) if os.path.exists(os.path.join(d, v, "ensemble.csv")))
        res = {v: load(os.path.join(d, v, "ensemble.csv")) for v in variants}
        base = res.get("base")
        print(f"\n{d}\n")
        print("| variant | runs | clogged | guard-stopped | <s> | std. error | <s> / base | sigma / <s> | median | "
              "mean clog time (s) | max overlap / a | longest pause (s) | wall s per run |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        order = ["base"] + [v for v in variants if v != "base"]
        for v in order:
            if v not in res:
                continue
            r = res[v]
            ratio = ""
            if base and v != "base" and base["mean"] > 0:
                q = r["mean"] / base["mean"]
                e = q * math.hypot(r["se"] / r["mean"], base["se"] / base["mean"])
                ratio = f"{q:.2f} +- {e:.2f}"
            print(f"| {v} | {r['runs']} | {r['clogged']} | {r['guard']} | {r['mean']:.1f} | {r['se']:.1f} | {ratio} | "
                  f"{r['cv']:.2f} | {r['median']:.0f} | {r['clog_time']:.2f} | {r['overlap']:.3f} | {r['pause']:.3f} | "
                  f"{r['wall']:.1f} |")
        if out:
            plot(res, out, d)


if __name__ == "__main__":
    main()

"""Side by side (not a test): two cassini binaries on the bench's 50k gas with friction (1 rank),
runs alternating so both see the same machine load; medians of particle-steps/s.
  /usr/bin/python3 scripts/bench_pair.py OLD_BINARY NEW_BINARY [repeats] [friction 0|1]"""
import os, statistics, subprocess, sys, tempfile
sys.path.insert(0, os.path.dirname(__file__))
import bench
sys.path.insert(0, os.path.join(os.path.dirname(os.path.realpath(__file__)), os.pardir, "python"))
from cassini_tools import Run

old, new = sys.argv[1], sys.argv[2]
repeats = int(sys.argv[3]) if len(sys.argv) > 3 else 5
friction = int(sys.argv[4]) if len(sys.argv) > 4 else 1
rates = {old: [], new: []}
with tempfile.TemporaryDirectory() as tmp:
    path = os.path.join(tmp, "gas")
    os.makedirs(path)
    with open(os.path.join(path, "case.toml"), "w") as f:
        f.write(bench.case_text(50000, friction))
    for r in range(repeats):
        for binary in (old, new) if r % 2 == 0 else (new, old):
            out = os.path.join(tmp, "out")
            subprocess.run([binary, path, "--out", out, "--force"], check=True, capture_output=True, env=bench.ENV)
            rates[binary].append(Run(out).summary["particle_steps_per_second"])
for b in (old, new):
    print(f"{b}: median {statistics.median(rates[b]):.4e} p-steps/s  runs {' '.join(f'{x:.3e}' for x in rates[b])}")
print(f"new / old: {statistics.median(rates[new]) / statistics.median(rates[old]):.3f}")

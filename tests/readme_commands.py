#!/usr/bin/python3
"""The README runs as written: every ```sh block of README.md, in order, in a scratch copy.

usage: readme_commands.py REPO BUILD_DIR SCRATCH [MPIEXEC]

The scratch directory gets a copy of the repository's files (not build/ or runs/) and a link
build -> BUILD_DIR, so the commands use the binaries under test and write nothing into the
source tree. Each block runs under `bash -euo pipefail`; the first failure fails the test with
the block, its output and its exit code. Prints the number of blocks and commands run.
"""
import os
import re
import shutil
import subprocess
import sys
import time

repo, build, scratch = (os.path.abspath(a) for a in sys.argv[1:4])
text = open(os.path.join(repo, "README.md")).read()
blocks = re.findall(r"^```sh\n(.*?)^```", text, flags=re.S | re.M)
if not blocks:
    sys.exit("README.md has no ```sh blocks")

shutil.rmtree(scratch, ignore_errors=True)
shutil.copytree(repo, scratch, symlinks=True,
                ignore=lambda d, names: [n for n in names if d == repo and n in ("build", "runs", ".git")])
os.symlink(build, os.path.join(scratch, "build"))

commands = 0
for k, block in enumerate(blocks, 1):
    lines = [l for l in block.replace("\\\n", " ").splitlines() if l.strip() and not l.strip().startswith("#")]
    commands += len(lines)
    t0 = time.time()
    p = subprocess.run(["bash", "-euo", "pipefail", "-c", block], cwd=scratch, capture_output=True, text=True)
    print(f"block {k}/{len(blocks)}: {len(lines)} command(s), exit {p.returncode}, {time.time() - t0:.1f} s")
    if p.returncode != 0:
        print(block)
        print(p.stdout[-3000:])
        print(p.stderr[-3000:])
        sys.exit(f"README block {k} failed")
print(f"README: {len(blocks)} blocks, {commands} commands ran as written")

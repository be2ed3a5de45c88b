#!/usr/bin/python3
"""Every HDF5 file cassini writes, walked against the H5MD 1.1 specification.

H5MD 1.1 (https://www.nongnu.org/h5md/h5md.html) fixes: the h5md group (version [1, 1],
author@name, creator@name and @version, optional modules/<name>@version); for each particle
group a box with @dimension (a scalar integer D) and @boundary (a string array of length D,
each "periodic" or "none") and edges ([D] or [D][D], or a time-dependent element of them);
time-dependent elements {step, time?, value} with step integer [T], time real [T] and value
[T][...]; the units module's `unit` attributes are strings of SI symbols with integer powers.
Shared step/time datasets must be hard links (the same object), not copies.

Runs a granular gas (2 ranks, snapshots and observables), a sheared ring section (Lees-Edwards
elements), and cassini-cg (plain HDF5 fields, not H5MD: only its units are checked), then walks
every file. A violation prints the file and the path.

usage: h5md_conformance.py CASSINI CASSINI_CG SOURCE_DIR WORK MPIEXEC [MPI flags...]
"""
import os
import re
import shutil
import subprocess
import sys

import h5py
import numpy as np

cassini, cg, source, work = (os.path.abspath(a) for a in sys.argv[1:5])
mpi = [sys.argv[5], "-n", "2", *sys.argv[6:]]
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
problems = []
UNIT = re.compile(r"^[A-Za-z]+(-?\d+)?( [A-Za-z]+(-?\d+)?)*$")


def bad(path, what):
    problems.append(f"{path}: {what}")


def text(v):
    return v.decode() if isinstance(v, bytes) else str(v)


def check_unit(where, obj):
    if "unit" in obj.attrs:
        u = obj.attrs["unit"]
        if not (isinstance(u, str) and UNIT.match(u)):
            bad(where, f"unit {u!r} is not a (variable-length) string of SI symbols with integer powers")


def check_element(name, g, units_module):
    """A time-dependent element: step [T] integer, time [T] real (optional), value [T][...]."""
    if "value" not in g or "step" not in g:
        bad(name, "a time-dependent element needs step and value")
        return
    step, value = g["step"], g["value"]
    if not np.issubdtype(step.dtype, np.integer) or step.ndim != 1:
        bad(name + "/step", f"expected an integer [T] dataset, got {step.dtype} {step.shape}")
    if value.shape[:1] != step.shape[:1]:
        bad(name + "/value", f"first axis {value.shape[:1]} is not step's {step.shape}")
    if "time" in g:
        t = g["time"]
        if not np.issubdtype(t.dtype, np.floating) or t.shape != step.shape:
            bad(name + "/time", f"expected a real dataset shaped like step, got {t.dtype} {t.shape}")
        if units_module and "unit" not in t.attrs:
            bad(name + "/time", "no unit (the units module is declared)")
        check_unit(name + "/time", t)
    check_unit(name + "/value", value)


def walk_elements(prefix, group, units_module, skip=()):
    for key, obj in group.items():
        path = f"{prefix}/{key}"
        if key in skip:
            continue
        if isinstance(obj, h5py.Group):
            if "value" in obj:
                check_element(path, obj, units_module)
            else:
                walk_elements(path, obj, units_module)
        else:
            check_unit(path, obj)


def check_h5md(path):
    with h5py.File(path, "r") as f:
        if "h5md" not in f:
            bad(path, "no h5md group")
            return
        h = f["h5md"]
        if list(h.attrs.get("version", [])) != [1, 1]:
            bad(path, f"h5md@version is {h.attrs.get('version')!r}, expected [1, 1]")
        if "author" not in h or "name" not in h["author"].attrs:
            bad(path, "h5md/author@name missing")
        if "creator" not in h or not all(k in h["creator"].attrs for k in ("name", "version")):
            bad(path, "h5md/creator@name and @version required")
        for mod in h.get("modules", {}).values():
            if "version" not in mod.attrs:
                bad(path, f"h5md/modules/{mod.name} has no version")
        units_module = "modules" in h and "units" in h["modules"]
        for gname, g in f.get("particles", {}).items():
            where = f"{path}:/particles/{gname}"
            if "box" not in g:
                bad(where, "no box")
                continue
            box = g["box"]
            dim = box.attrs.get("dimension")
            if dim is None or np.ndim(dim) != 0 or int(dim) not in (1, 2, 3):
                bad(where + "/box", f"@dimension must be a scalar integer 1..3, got {dim!r}")
                continue
            bnd = box.attrs.get("boundary")
            if bnd is None or np.ndim(bnd) != 1 or len(bnd) != int(dim) or any(text(b) not in ("periodic", "none") for b in bnd):
                bad(where + "/box", f"@boundary must be {int(dim)} strings 'periodic' or 'none', got {bnd!r}")
            if "edges" in box:
                e = box["edges"]
                if isinstance(e, h5py.Group):
                    check_element(where + "/box/edges", e, units_module)
                    if e["value"].shape[1:] not in ((int(dim),), (int(dim), int(dim))):
                        bad(where + "/box/edges", f"value shaped {e['value'].shape}")
            walk_elements(where, g, units_module, skip=("box",))
            # Elements of one frame share its clock: hard links, not copies.
            clocks = {k: v for k, v in g.items() if isinstance(v, h5py.Group) and "step" in v}
            if len(clocks) > 1:
                first = next(iter(clocks.values()))
                for k, v in clocks.items():
                    if v["step"] != first["step"] or v["time"] != first["time"]:
                        bad(where + "/" + k, "step/time are copies, not links to the frame's clock")
                if "edges" in box and isinstance(box["edges"], h5py.Group) and box["edges"]["step"] != first["step"]:
                    bad(where + "/box/edges", "step is a copy, not a link to the frame's clock")
        if "observables" in f:
            walk_elements(f"{path}:/observables", f["observables"], units_module)
            if units_module and "kinetic_energy" in f["observables"] and \
                    "unit" not in f["observables/kinetic_energy/value"].attrs:
                bad(path, "observables/kinetic_energy/value has no unit")


def run(args, cwd=work):
    p = subprocess.run([*mpi, *args], cwd=cwd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"FAIL: {' '.join(args)} exited {p.returncode}\n{p.stdout[-2000:]}{p.stderr[-2000:]}")


run([cassini, f"{source}/cases/gas", "--out", "gas", "--set", "time.end=2e-5", "--set", "output.snapshot_every=1e-5"])
run([cassini, f"{source}/cases/ring-section", "--out", "ring", "--set", "particles.count=2000", "--set", "time.end=20",
     "--set", "output.snapshot_every=10", "--set", "output.observe_every=5"])
run([cg, "gas", "--grid", "10x8x8", "--out", "fields.h5"])

files = [os.path.join(d, n) for d in ("gas", "ring") for n in sorted(os.listdir(os.path.join(work, d)))
         if n.endswith(".h5md")]
for p in files:
    check_h5md(os.path.join(work, p))
with h5py.File(os.path.join(work, "ring", sorted(n for n in os.listdir(os.path.join(work, "ring"))
                                                  if n.startswith("snap_") and n.endswith(".h5md"))[-1]), "r") as f:
    if "particles/grains/lees_edwards/offset" not in f:
        problems.append("ring: no lees_edwards element in a sheared snapshot (the walk would miss it)")
with h5py.File(os.path.join(work, "fields.h5"), "r") as f:
    for k, d in f.items():
        check_unit("fields.h5:/" + k, d)
        if k != "description" and "unit" not in d.attrs:
            problems.append(f"fields.h5:/{k}: no unit")

print(f"{len(files)} H5MD files and fields.h5 walked")
for p in problems:
    print("FAIL " + p)
sys.exit(1 if problems else 0)

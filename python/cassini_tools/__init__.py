"""Reading cassini runs from Python: the one reader every script in scripts/ uses.

Needs h5py and numpy (Debian's /usr/bin/python3 has them). Put this folder's parent on the path:

    import sys; sys.path.insert(0, "/path/to/cassini/python")
    from cassini_tools import Run

    run = Run("runs/x")                 # a directory cassini wrote (--out)
    run.summary["status"]               # summary.json as a dict
    run.case["seed"]                    # the resolved case.toml as a dict
    obs = run.observables()             # {"time": array, "kinetic_energy": array, ...}
    for frame in run.frames():          # complete snapshots, in step order
        snap = frame.read()             # snap.position, snap.velocity, snap.id, ... (numpy)
    hill = run.hill()                   # Omega0, T0, shear rate, Hill radius of a moonlet

For studies: launch(command, out, sets, restart=...) runs cassini with its log in out.log, and
ContinuedRun(path) continues a run stopped part-way (path-part1, ...) and reads its parts as one.

Units are SI throughout. Every failure is a RunError naming the file and what was wrong.
"""
import csv
import glob
import json
import math
import os
import re
import subprocess
import time
import tomllib

import numpy as np

# The solver's constants (src/core/Config.hpp, src/physics/ring/HillFrame.hpp).
G = 6.674e-11               # m^3 kg^-1 s^-2
SATURN_MASS = 5.68e26       # kg: hill.saturn_mass's default
ORBIT_RADIUS = 1.17e8       # m: hill.orbit_radius's default


class RunError(Exception):
    """A run, file or frame that cannot be read; the message names it."""


def text(value):
    """An HDF5 string attribute as str, whether stored fixed-length (bytes) or variable-length."""
    if isinstance(value, bytes):
        return value.decode()
    if isinstance(value, np.ndarray) and value.dtype.kind in "SO":
        return ",".join(text(v) for v in value)
    return str(value)


def _h5py():
    try:
        import h5py
    except ImportError as e:  # the pyenv python first on PATH has none
        raise RunError("h5py is missing: run with Debian's /usr/bin/python3 (python3-h5py)") from e
    return h5py


def add_study_options(parser, out, lanes=2):
    """The options every study script in scripts/ takes: --lanes (runs at once), --ranks (per
    run), --table-only, --out (default `out`)."""
    parser.add_argument("--lanes", type=int, default=lanes, help="runs at once")
    parser.add_argument("--ranks", type=int, default=1,
                        help="ranks per run; a run stopped part-way continues from its last snapshot, bitwise, in DIR/NAME-partK")
    parser.add_argument("--table-only", action="store_true", help="analyse what is there, run nothing")
    parser.add_argument("--out", default=out)


def solver(root, ranks=1):
    """The launcher and binary a study runs: scripts/mpirun -n RANKS and $CASSINI (default
    ROOT/build/cassini)."""
    return [os.path.join(root, "scripts", "mpirun"), "-n", str(ranks),
            os.environ.get("CASSINI", os.path.join(root, "build", "cassini"))]


def launch(command, out, sets=(), restart=None, force=True, label=None):
    """Runs cassini for a study: `command` is the launcher, binary and case file (e.g.
    ["scripts/mpirun", "-n", "2", "build/cassini", "cases/x/case.toml"]), `out` the run directory,
    `sets` the --set overrides, `restart` a snapshot to continue from. Its output goes to out.log.
    Returns (wall seconds, stopped_by_guard). A guard stop (exit 3: e.g. a ring heated beyond what
    t_c allows) is a result a study analyses up to the stop; any other failure is a RunError
    naming the log."""
    cmd = list(command) + ["--out", out] + (["--force"] if force else [])
    if restart:
        cmd += ["--restart", restart]
    for s in sets:
        cmd += ["--set", s]
    t = time.time()
    with open(out + ".log", "w") as log:
        code = subprocess.run(cmd, stdout=log, stderr=subprocess.STDOUT).returncode
    seconds = time.time() - t
    if code not in (0, 3):
        raise RunError(f"{label or os.path.basename(out)}: cassini exited with {code}; see {out}.log")
    print(f"{label or os.path.basename(out)}: {seconds:.0f} s{' (stopped by a guard: see its log)' if code == 3 else ''}",
          flush=True)
    return seconds, code == 3


class Hill:
    """The Hill frame of a case: Omega0 = sqrt(G M / r0^3), T0 = 2 pi / Omega0, the Keplerian shear
    rate 1.5 Omega0 (or the case's domain.shear_rate) and Hill radii r0 (m / 3M)^(1/3)."""

    def __init__(self, case):
        h = case.get("hill", {})
        self.saturn_mass = float(h.get("saturn_mass", SATURN_MASS))
        self.orbit_radius = float(h.get("orbit_radius", ORBIT_RADIUS))
        self.omega0 = math.sqrt(G * self.saturn_mass / self.orbit_radius ** 3)
        self.period = 2 * math.pi / self.omega0
        self.shear_rate = float(case.get("domain", {}).get("shear_rate", 1.5 * self.omega0))

    def hill_radius(self, mass):
        return self.orbit_radius * (mass / (3 * self.saturn_mass)) ** (1 / 3)

    def orbits(self, time):
        return time / self.period


class Snapshot:
    """One frame: particle columns (numpy arrays, rows in id order) and the frame's parameters."""

    def __init__(self, path, columns=None, copy=None):
        h5py = _h5py()
        self.path = path
        try:
            with h5py.File(path, "r") as f:
                if text(f["parameters"].attrs.get("complete", "")) != "yes":
                    raise RunError(f"{path}: an incomplete snapshot (no parameters@complete)")
                grains = f["particles/grains"]
                names = columns or [k for k in grains if k not in ("box", "lees_edwards")]
                self.columns = {k: grains[k + "/value"][0] for k in names if k in grains}
                self.step = int(grains["id/step"][0])
                now = f["parameters/time_offset_dt"][:]
                self.time, self.offset, self.dt = float(now[0]), float(now[1]), float(now[2])
                self.shear_rate = float(f["parameters/shear_rate"][0])
                self.frame_rotation = float(f["parameters/frame_rotation"][0]) if "parameters/frame_rotation" in f else 0.0
                self.planar = bool(f["parameters/planar"][0]) if "parameters/planar" in f else False
                self.edges = grains["box/edges/value"][0]
                self.origin = grains["box/origin"][:]
                self.boundary = text(grains["box"].attrs.get("boundary", "")).split(",")
                self.case = tomllib.loads(text(f["parameters"].attrs["case"]))
                self.results = {k: (text(v) if isinstance(v, (bytes, str)) else np.asarray(v).ravel()[0])
                                for k, v in f["results"].attrs.items()} if "results" in f else {}
                self.run_id = text(f["parameters"].attrs.get("run_id", ""))
                le = grains["le_copy/value"][0].ravel() if "le_copy" in grains else None
        except OSError as e:
            raise RunError(f"{path}: not a readable HDF5 file (truncated, or not a cassini snapshot): {e}") from e
        except KeyError as e:
            raise RunError(f"{path}: not a cassini snapshot (missing {e}); is it an observables or fields file?") from e
        if copy is not None and le is not None:  # modified Lees-Edwards runs: one copy of the box
            keep = le == copy
            self.columns = {k: v[keep] for k, v in self.columns.items()}

    def __getattr__(self, name):  # snap.position, snap.velocity, snap.id, snap.radius, ...
        columns = self.__dict__.get("columns", {})
        if name in columns:
            return columns[name]
        raise AttributeError(f"{self.__dict__.get('path', 'snapshot')} has no particle column '{name}'")

    @property
    def lengths(self):
        return np.array([self.edges[0][0], self.edges[1][1], self.edges[2][2]])

    def __len__(self):
        return len(next(iter(self.columns.values()))) if self.columns else 0


class Frame:
    """A snapshot file of a run: its step from the name; read() loads it."""

    def __init__(self, path):
        self.path = path
        self.step = int(re.search(r"snap_(\d+)\.h5md$", path).group(1))
        self._time = None

    @property
    def time(self):
        if self._time is None:
            h5py = _h5py()
            try:
                with h5py.File(self.path, "r") as f:
                    self._time = float(f["parameters/time_offset_dt"][0])
            except (OSError, KeyError) as e:
                raise RunError(f"{self.path}: not a readable cassini snapshot: {e}") from e
        return self._time

    def read(self, columns=None, copy=None):
        return Snapshot(self.path, columns, copy)


class Run:
    """A run directory written by cassini (--out)."""

    def __init__(self, path):
        if not os.path.isdir(path):
            what = "is a file" if os.path.exists(path) else "no such directory"
            raise RunError(f"{path}: {what}, expected a run directory written by cassini (--out)")
        self.path = path

    def _file(self, name):
        p = os.path.join(self.path, name)
        if not os.path.exists(p):
            raise RunError(f"{p}: no such file (is {self.path} a finished cassini run?)")
        return p

    @property
    def summary(self):
        p = self._file("summary.json")
        try:
            with open(p) as f:
                return json.load(f)
        except json.JSONDecodeError as e:
            raise RunError(f"{p}: not valid JSON: {e}") from e

    @property
    def case(self):
        p = self._file("case.toml")
        try:
            with open(p, "rb") as f:
                return tomllib.load(f)
        except tomllib.TOMLDecodeError as e:
            raise RunError(f"{p}: not valid TOML: {e}") from e

    def hill(self):
        return Hill(self.case)

    def observables(self):
        """observables.csv as {column: numpy array}."""
        p = self._file("observables.csv")
        with open(p) as f:
            rows = list(csv.DictReader(f))
        if not rows:
            with open(p) as f:
                names = f.readline().strip().split(",")
            return {k: np.zeros(0) for k in names}
        return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}

    def observable_rows(self):
        """observables.csv as a list of {column: float} rows."""
        with open(self._file("observables.csv")) as f:
            return [{k: float(v) for k, v in r.items()} for r in csv.DictReader(f)]

    def frames(self, start=None, end=None):
        """The complete snapshots (no .partial), in step order; with start/end, those whose time
        lies in [start, end] (seconds)."""
        frames = [Frame(p) for p in sorted(glob.glob(os.path.join(self.path, "snap_*.h5md")))]
        if start is not None or end is not None:
            lo, hi = -math.inf if start is None else start, math.inf if end is None else end
            frames = [f for f in frames if lo - 1e-9 * abs(lo) <= f.time <= hi + 1e-9 * abs(hi)]
        return frames

    def dump(self, step=None, tag="step"):
        """A text dump (output.dump_every), every rank's part, as (time, array with columns id species
        radius x y z vx vy vz), rows in id order; the last one unless step is given."""
        files = glob.glob(os.path.join(self.path, "dump", f"{tag}_*.rank*.txt"))
        steps = sorted({int(re.search(rf"{tag}_(\d+)\.rank", f).group(1)) for f in files})
        if not steps:
            raise RunError(f"{self.path}/dump: no {tag}_*.txt dumps (run with output.dump_every)")
        step = steps[-1] if step is None else step
        parts = sorted(f for f in files if f"{tag}_{step:09d}.rank" in f)
        if not parts:
            raise RunError(f"{self.path}/dump: no dump of step {step}")
        with open(parts[0]) as f:
            time = float(f.readline().split()[4])  # "# step N time T"
        data = np.vstack([np.loadtxt(p, ndmin=2).reshape(-1, 9) for p in parts])
        return time, data[np.argsort(data[:, 0], kind="stable")]

    def ensemble(self):
        """ensemble.csv (--ensemble) as a list of rows, numbers as float, empty fields as None."""
        return read_ensemble(self._file("ensemble.csv"))


class ContinuedRun:
    """A study's run that may have been stopped part-way (killed, a machine handed back) and
    continued: its directory and the continuations PATH-part1, PATH-part2, ..., each restarted
    from the last snapshot before it (restarts are bitwise exact at any rank count, so the parts
    together are the uninterrupted run).

        run = ContinuedRun("runs/x/e0.9_s1")
        if not run.finished(until=T_END):   # completed, and as far as asked
            out, restart = run.next()           # where to write, which snapshot to start from
            launch(command, out, sets, restart=restart)
        frames = run.frames(start=T0)           # every part's snapshots, each time once
    """

    def __init__(self, path):
        self.path = path

    def parts(self):
        more = [p for p in glob.glob(self.path + "-part*") if re.fullmatch(r"-part\d+", p[len(self.path):])]
        more.sort(key=lambda p: int(p.rsplit("-part", 1)[1]))
        return [p for p in [self.path] + more if os.path.isdir(p)]

    def summary(self):
        """The last part's summary.json, or None while it has none (running, or killed)."""
        parts = self.parts()
        if not parts or not os.path.exists(os.path.join(parts[-1], "summary.json")):
            return None
        return Run(parts[-1]).summary

    def finished(self, until=None):
        """Whether the run is over: stopped by a guard, or completed (and, with `until`, having
        reached that time to within a step: a run asked to go on further than it went is not)."""
        summary = self.summary() or {}
        if summary.get("status") == "stopped by a guard":
            return True
        if summary.get("status") != "completed":
            return False
        return until is None or summary["simulated_time"] >= until - summary["dt"]

    def frames(self, start=None, end=None):
        by_time = {}
        for p in self.parts():
            for f in Run(p).frames(start=start, end=end):
                by_time.setdefault(round(f.time, 6), f)
        return [by_time[t] for t in sorted(by_time)]

    def next(self):
        """(out, restart): the directory the next launch writes and the snapshot it continues from
        (None: from the start). A part that ended before its first snapshot is redone in place;
        nothing with a snapshot is ever overwritten."""
        parts = self.parts()
        frames = [f for f in self.frames() if f.time > 0]
        if not frames:
            return (parts[-1] if parts else self.path), None  # nothing past the start: begin again
        last = parts[-1]
        if Run(last).frames(start=1e-300):
            last = f"{self.path}-part{len(parts)}"
        return last, frames[-1].path


def read_ensemble(path, raw=False):
    """An ensemble.csv (or a concatenation of them) as rows; numbers as float, empty as None, or
    with raw=True every field as the text the file holds (lists stay space-separated text)."""
    if not os.path.exists(path):
        raise RunError(f"{path}: no such file (written by cassini --ensemble)")
    if raw:
        with open(path) as f:
            return list(csv.DictReader(f))

    def value(v):
        if v == "":
            return None
        try:
            return float(v)
        except ValueError:
            return v
    with open(path) as f:
        return [{k: value(v) for k, v in r.items()} for r in csv.DictReader(f)]

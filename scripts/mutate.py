"""Mutation check: deliberate small bugs in the core stages must each be caught by some test.

Run on demand (it takes a few minutes)::

    .venv/bin/python scripts/mutate.py            # every mutation
    .venv/bin/python scripts/mutate.py slicing    # those whose name contains "slicing"

Each mutation copies ``src/`` to a temporary directory, replaces one exact piece of code there
(a sign, a threshold, an off-by-one, an interpolation weight), and runs the tests named for it
with that copy first on ``PYTHONPATH`` (the editable install is a plain path entry, so the copy
wins). A mutation that leaves those tests green is a gap in the tests: the script lists it and
exits with status 1. A mutation whose code is no longer found (the code changed) is reported as
stale, and also fails, so that the list is kept up to date.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Mutation:
    name: str
    file: str  # relative to src/meshplan
    old: str
    new: str
    tests: tuple[str, ...]  # pytest node ids or files, relative to the repository


MUTATIONS = (
    Mutation(
        "slicing: the cut point at the edge midpoint",
        "slicing.py",
        "(d0 / (d0 - du))[:, None]",
        "0.5",
        ("tests/test_core.py",),
    ),
    Mutation(
        "slicing: a vertex on a plane counts as below it",
        "slicing.py",
        "above = d >= 0",
        "above = d > 0",
        ("tests/test_core.py",),
    ),
    Mutation(
        "box DBSCAN: a core point needs one more neighbour (off by one)",
        "walls/boxdbscan.py",
        "core_s = dbscan_core(sp, start, neigh, int(min_points))",
        "core_s = dbscan_core(sp, start, neigh, int(min_points) + 1)",
        ("tests/test_core.py",),
    ),
    Mutation(
        "levels: the plane fit of the floor ignored (normals only)",
        "orient/params.py",
        "gravity_plane_fit: bool = True",
        "gravity_plane_fit: bool = False",
        ("tests/test_orient.py",),
    ),
    Mutation(
        "slicing planes: the ceiling plane left out",
        "slicing.py",
        "np.arange(n + 1) / n",
        "np.arange(n) / n",
        ("tests/test_core.py", "tests/test_plans.py"),
    ),
    Mutation(
        "openings: doors need to reach twice as high",
        "plan/doors.py",
        "tall = head >= f.floor + params.door_height_m - tol",
        "tall = head >= f.floor + 2 * params.door_height_m - tol",
        ("tests/test_openings_synthetic.py",),
    ),
)


def _run(m: Mutation, keep: bool) -> str:
    """``"caught"``, ``"survived"`` or ``"stale"``."""
    with tempfile.TemporaryDirectory(prefix="meshplan-mutant-") as tmp:
        src = Path(tmp) / "src"
        shutil.copytree(ROOT / "src", src, ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
        target = src / "meshplan" / m.file
        text = target.read_text(encoding="utf-8")
        if text.count(m.old) != 1:
            return "stale"
        target.write_text(text.replace(m.old, m.new), encoding="utf-8")
        env = dict(os.environ, PYTHONPATH=f"{src}{os.pathsep}{os.environ.get('PYTHONPATH', '')}", NUMBA_CACHE_DIR=str(Path(tmp) / "numba"))
        cmd = [sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider", "-p", "no:randomly", *m.tests]
        proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
        if keep and proc.returncode == 0:
            print(proc.stdout[-2000:])
        return "caught" if proc.returncode != 0 else "survived"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("select", nargs="*", help="run only mutations whose name contains one of these words")
    parser.add_argument("-v", "--verbose", action="store_true", help="show the test output of surviving mutations")
    args = parser.parse_args(argv)
    chosen = [m for m in MUTATIONS if not args.select or any(w in m.name for w in args.select)]
    bad = 0
    for m in chosen:
        t0 = time.perf_counter()
        outcome = _run(m, args.verbose)
        bad += outcome != "caught"
        print(f"{outcome:9s} {time.perf_counter() - t0:6.1f} s  {m.name}", flush=True)
    print(f"{len(chosen) - bad} of {len(chosen)} mutations caught")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())

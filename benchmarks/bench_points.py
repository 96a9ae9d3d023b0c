"""A 10-million-point E57, end to end (issue 14): ``meshplan run`` in a fresh process, its time
and its peak memory, against the targets (under 60 s and 6 GB).

    .venv/bin/python benchmarks/bench_points.py [--points 10000000] [--keep DIR]

The cloud is the synthetic apartment (``SynthParams(preset="apartment", seed=1)``) sampled at
the density that gives the asked number of points (some 25,000 points/m2 for 10 million: a
terrestrial laser scan), with 2 mm noise, colours and intensities, written as four scans with
their poses.
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from meshplan.synthetic import SynthParams, generate  # noqa: E402
from test_points import sample_cloud, write_e57  # noqa: E402

TARGET_S, TARGET_GB = 60.0, 6.0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=10_000_000)
    ap.add_argument("--keep", type=Path, default=None, help="write the E57 and the results here")
    args = ap.parse_args()
    work = args.keep or Path(tempfile.mkdtemp(prefix="meshplan-bench-points-"))
    work.mkdir(parents=True, exist_ok=True)
    scan = generate(SynthParams(preset="apartment", seed=1))
    density = args.points / scan.mesh.area
    path = work / "apartment-10M.e57"
    t0 = time.perf_counter()
    p, colors, intensity = sample_cloud(scan.mesh, density, 0.002, seed=0)
    write_e57(path, p, colors, intensity, scans=4)
    n = len(p)
    del p, colors, intensity
    print(f"wrote {path} ({n:,} points, {density:,.0f} points/m2, {path.stat().st_size / 1e6:,.0f} MB) in {time.perf_counter() - t0:.1f} s")
    out = work / "out"
    cmd = [sys.executable, "-m", "meshplan", "run", str(path), "-o", str(out), "--force", "--json"]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    peak_gb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024 / 1e9  # kB on Linux
    if proc.returncode != 0:
        print(proc.stderr, file=sys.stderr)
        return 1
    print(f"meshplan run: {wall:.1f} s end to end (target {TARGET_S:.0f} s), peak {peak_gb:.2f} GB (target {TARGET_GB:.0f} GB)")
    import json

    summary = json.loads(proc.stdout)
    print("timings:", {k: round(v, 2) for k, v in summary.get("timings", {}).items()})
    doc = json.loads((out / "plan.json").read_text())
    print("input:", {k: doc["input"].get(k) for k in ("points_read", "points", "faces")}, "walls:", len(doc["walls"]), "rooms:", len(doc["rooms"]))
    return 0 if wall < TARGET_S and peak_gb < TARGET_GB else 1


if __name__ == "__main__":
    sys.exit(main())

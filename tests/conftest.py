"""Shared fixtures: the real scans in ../shared (skipped when absent) and synthetic scans."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import settings

# Property and fuzz tests (hypothesis) draw the same cases on every run, so that CI is
# reproducible, and keep no example database; HYPOTHESIS_PROFILE=explore draws new cases.
settings.register_profile("ci", derandomize=True, database=None, deadline=None, print_blob=True)
settings.register_profile("explore", deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


def pytest_configure(config):
    config.addinivalue_line("markers", "hypothesis_cases(n): a hypothesis test that must run at least n generated cases")


#: Fixtures that run the whole pipeline (every computing stage of a synthetic scan): a test
#: using one is a whole-pipeline test, marked ``slow`` so that ``make unit`` (``-m "not slow and
#: not realscan"``) stays the fast layer.
WHOLE_PIPELINE_FIXTURES = frozenset({"computed"})


def pytest_collection_modifyitems(config, items):
    for item in items:
        if WHOLE_PIPELINE_FIXTURES & set(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.slow)


def pytest_terminal_summary(terminalreporter):
    """Report how many cases the hypothesis tests ran (recorded by tests/test_properties.py,
    also across pytest-xdist workers)."""
    counts = {}
    for reports in terminalreporter.stats.values():
        for report in reports:
            for name, value in getattr(report, "user_properties", ()):
                if name == "hypothesis_cases":
                    counts[report.nodeid] = value
    if counts:
        terminalreporter.write_line(f"hypothesis: {sum(counts.values())} generated cases in {len(counts)} property and fuzz tests")


ROOT = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("MESHPLAN_SHARED", ROOT.parent / "shared"))
SCANS = SHARED / "scans"

#: The real scans, their up vector and their levels along up, from ../shared/scans/MANIFEST.md.
REAL_SCANS = {
    "hl1_mrtk_example_office.ply": {"up": (0, 1, 0), "stories": [(-1.04, 1.76)]},
    "hl1_htk_fake_spatial_mapping_room_corner.ply": {"up": (0, 1, 0), "stories": [(-1.66, None)]},
    "hl2_su_apartment_two_story.ply": {"up": (-0.902, -0.049, -0.429), "stories": [(-1.6, 0.8), (1.2, 4.0)]},
    "hl2_su_office_chroje.ply": {"up": (-0.785, 0.174, -0.594), "stories": [(-1.62, 0.78)]},
}


def real_scan_names(suffixes: tuple[str, ...] = (".ply", ".obj", ".glb", ".stl", ".off", ".usdz")) -> list[str]:
    """The scans in ../shared/scans with one of ``suffixes`` (the HoloLens 2 plane sidecars
    left out); empty when ../shared is absent (parametrize with a placeholder that skips)."""
    if not SCANS.is_dir():
        return []
    return sorted(p.name for p in SCANS.iterdir() if p.suffix in suffixes and not p.name.endswith(".su_planes.ply"))


def real_scan(name: str) -> Path:
    path = SCANS / name
    if not path.is_file():
        pytest.skip(f"real scan {name} not available (../shared/scans)")
    return path


def angle_deg(a, b) -> float:
    a = np.asarray(a, float) / np.linalg.norm(a)
    b = np.asarray(b, float) / np.linalg.norm(b)
    return float(np.degrees(np.arccos(np.clip(a @ b, -1.0, 1.0))))


def box_room(width=5.0, depth=4.0, height=2.6, cell=0.1) -> tuple[np.ndarray, np.ndarray]:
    """A closed box room (floor, ceiling, four walls) tessellated in cells, normals inward."""
    verts, faces = [], []

    def quad_grid(origin, du, dv, nu, nv):
        o = np.asarray(origin, float)
        du, dv = np.asarray(du, float), np.asarray(dv, float)
        i, j = np.meshgrid(np.arange(nu + 1), np.arange(nv + 1), indexing="ij")
        p = o + i[..., None] * du / nu + j[..., None] * dv / nv
        base = sum(len(v) for v in verts)
        verts.append(p.reshape(-1, 3))
        idx = (i * (nv + 1) + j)[:-1, :-1].reshape(-1) + base
        faces.append(np.c_[idx, idx + (nv + 1), idx + (nv + 1) + 1])
        faces.append(np.c_[idx, idx + (nv + 1) + 1, idx + 1])

    nw, nd, nh = int(width / cell), int(depth / cell), int(height / cell)
    quad_grid([0, 0, 0], [0, 0, depth], [width, 0, 0], nd, nw)  # floor, normal +y
    quad_grid([0, height, 0], [width, 0, 0], [0, 0, depth], nw, nd)  # ceiling, normal -y
    quad_grid([0, 0, 0], [width, 0, 0], [0, height, 0], nw, nh)  # wall z=0, normal +z
    quad_grid([0, 0, depth], [0, height, 0], [width, 0, 0], nh, nw)  # wall z=depth, normal -z
    quad_grid([0, 0, 0], [0, height, 0], [0, 0, depth], nh, nd)  # wall x=0, normal +x
    quad_grid([width, 0, 0], [0, 0, depth], [0, height, 0], nd, nh)  # wall x=width, normal -x
    return np.concatenate(verts), np.concatenate(faces)


@pytest.fixture(scope="session")
def computed():
    """``computed(preset, seed, **synth)`` -> (scan, result): synthetic scans run through every
    computing stage (no files), cached for the session."""
    from meshplan.io import LoadStats
    from meshplan.options import RunOptions
    from meshplan.pipeline import compute
    from meshplan.synthetic import SynthParams, generate

    cache = {}

    def get(preset: str, seed: int, **kw):
        key = (preset, seed, tuple(sorted(kw.items())))
        if key not in cache:
            scan = generate(SynthParams(preset=preset, seed=seed, **kw))
            m = scan.mesh
            stats = LoadStats("synthetic", "obj", "m", 1.0, 1, m.n_vertices, m.n_faces, 0, 0, 0, m.n_vertices, m.n_faces)
            cache[key] = (scan, compute(m, stats, scan.annotations, RunOptions()))
        return cache[key]

    return get

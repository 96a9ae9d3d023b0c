"""The compiled cone k-means of the up direction (``_refine_kmeans``) against the numpy rounds
it replaced: the same faces in the final cone, the same up to rounding."""

from __future__ import annotations

import numpy as np
import pytest

from meshplan.geometry import unit
from meshplan.orient.gravity import _refine_kmeans

CONES_DEG = (30.0, 20.0, 10.0, 5.0, 3.0)


def _numpy_refine(normals: np.ndarray, areas: np.ndarray, rough: np.ndarray, cones_deg: tuple[float, ...]) -> tuple[np.ndarray, int]:
    """The numpy implementation the kernels replaced (four passes per round)."""
    g = unit(rough)
    dots = normals @ g
    cand = np.flatnonzero(np.abs(dots) >= np.cos(np.radians(cones_deg[0] + 10.0)))
    n = np.ascontiguousarray(normals[cand] * np.sign(dots[cand])[:, None])
    a = areas[cand]
    used = 0
    for cone in cones_deg:
        cos_c = np.cos(np.radians(cone))
        previous = None
        for _ in range(10):
            sel = n @ g >= cos_c
            if not sel.any():
                return g, 0
            if previous is not None and np.array_equal(sel, previous):
                break
            g = unit(np.where(sel, a, 0.0) @ n)
            previous = sel
        used = int(sel.sum())
        keep = n @ g >= np.cos(np.radians(cone + 2.0))
        n, a = n[keep], a[keep]
    return g, used


def _scene(seed: int, noise: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    up = unit(rng.normal(size=3) * [0.1, 1.0, 0.1])
    side = unit(np.cross(up, [1.0, 0.0, 0.0]))
    floor = up + noise * rng.normal(size=(4000, 3))
    ceiling = -up + noise * rng.normal(size=(3000, 3))
    walls = np.cross(up, side) * rng.choice([-1.0, 1.0], size=(5000, 1)) + noise * rng.normal(size=(5000, 3))
    clutter = rng.normal(size=(2000, 3))
    normals = unit(np.concatenate([floor, ceiling, walls, clutter]))
    order = rng.permutation(len(normals))
    return normals[order], rng.uniform(0.001, 0.01, len(normals)), up + 0.1 * rng.normal(size=3)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("noise", [0.02, 0.1, 0.3])
def test_refine_kmeans_matches_numpy(seed: int, noise: float) -> None:
    normals, areas, rough = _scene(seed, noise)
    want, want_used = _numpy_refine(normals, areas, rough, CONES_DEG)
    got, got_used = _refine_kmeans(normals, areas, rough, CONES_DEG)
    assert got_used == want_used
    assert np.abs(got - want).max() < 1e-12


def test_refine_kmeans_no_face_in_cone() -> None:
    normals = unit(np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]))
    g, used = _refine_kmeans(normals, np.ones(2), np.array([0.0, 1.0, 0.0]), CONES_DEG)
    assert used == 0
    assert np.allclose(g, [0.0, 1.0, 0.0])

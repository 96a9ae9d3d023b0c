"""The cues of the up estimate one by one, on small constructed meshes with a known answer.

The floor-plane refinement (:func:`meshplan.orient.gravity.refine_with_slabs`) is combined with
Method 2's up from the normals by inverse variance, the fit's variance measured by a block
jackknife (:func:`meshplan.orient.gravity.floor_fit_uncertainty_deg`): a flat floor is trusted,
a warped one (the Tango rooms: domed by 3-4 cm, their plane 1.1-1.4 degrees off gravity) much
less.
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import angle_deg
from meshplan.geometry import Mesh, unit
from meshplan.orient import OrientParams
from meshplan.orient.gravity import floor_fit_uncertainty_deg, refine_with_slabs


def floor_patch(size=(4.0, 3.0), cell=0.05, height=None, seed=0, noise_m=0.005):
    """Faces (centroids, normals, areas) of a floor tessellated in ``cell`` squares, with heights
    ``height(x, z)`` and independent vertex noise."""
    rng = np.random.default_rng(seed)
    nx, nz = int(size[0] / cell), int(size[1] / cell)
    i, j = np.meshgrid(np.arange(nx + 1), np.arange(nz + 1), indexing="ij")
    x, z = i * cell, j * cell
    y = (height(x, z) if height else np.zeros_like(x)) + rng.normal(0.0, noise_m, x.shape)
    v = np.stack([x, y, z], -1).reshape(-1, 3)
    idx = (i * (nz + 1) + j)[:-1, :-1].ravel()
    f = np.r_[np.c_[idx, idx + 1, idx + nz + 2], np.c_[idx, idx + nz + 2, idx + nz + 1]]
    m = Mesh(v, f)
    return m.face_centroids, m.face_normals, m.face_areas


def test_a_flat_floor_defines_its_normal_tightly():
    c, n, a = floor_patch()
    sigma = floor_fit_uncertainty_deg(c, a, np.zeros(len(c), np.int64), np.array([0.0, 1.0, 0.0]))
    assert sigma < 0.02  # half a centimetre of random noise over 4 m: hundredths of a degree


def test_a_warped_floor_does_not():
    # a floor rising by 4 cm over its last metre (a sag, or drift between two passes)
    c, n, a = floor_patch(height=lambda x, z: 0.04 * np.clip(x - 3.0, 0.0, None))
    sigma = floor_fit_uncertainty_deg(c, a, np.zeros(len(c), np.int64), np.array([0.0, 1.0, 0.0]))
    assert sigma > 0.1


def test_too_few_blocks_give_no_precision():
    c, n, a = floor_patch(size=(0.9, 0.9))
    assert floor_fit_uncertainty_deg(c, a, np.zeros(len(c), np.int64), np.array([0.0, 1.0, 0.0])) == np.inf


def test_a_flat_floor_wins_over_the_normals():
    """Up from the normals 1 degree off, a flat floor: the fit puts it right."""
    c, n, a = floor_patch()
    rough = unit(np.array([np.sin(np.radians(1.0)), np.cos(np.radians(1.0)), 0.0]))
    up, used = refine_with_slabs(c, n, a, rough, [0.0], OrientParams(gravity_fit_blend=True))
    assert used > 0
    assert angle_deg(up, [0, 1, 0]) < 0.05


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_warped_floor_does_not_pull_up_far_from_the_normals(seed):
    """A floor of a small room (3.5 x 1.8 m) with a 6 cm dome off-centre, like the Tango rooms:
    its best plane is tilted, and the refinement stays nearer the (right) up from the normals
    than the plain fit (the jackknife sees about half of such a warp's effect)."""
    def dome(x, z):
        return 0.06 * np.exp(-((x - 1.0) ** 2 + (z - 0.6) ** 2) / 0.5)

    c, n, a = floor_patch(size=(3.5, 1.8), height=dome, seed=seed)
    truth = np.array([0.0, 1.0, 0.0])
    x = c - np.average(c, axis=0, weights=a)
    plain = np.linalg.eigh((x * a[:, None]).T @ x)[1][:, 0]
    up, used = refine_with_slabs(c, n, a, truth, [float(np.average(c[:, 1], weights=a))], OrientParams(gravity_fit_blend=True))
    assert used > 0
    assert angle_deg(plain, truth) > 0.5  # the warp does tilt the plane
    assert angle_deg(up, truth) < 0.75 * angle_deg(plain, truth)

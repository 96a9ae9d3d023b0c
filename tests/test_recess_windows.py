"""Windows whose glazing was scanned, set back in a reveal behind the wall's face
(:func:`meshplan.plan.doors._recesses`, issue 16): a reveal is a step at the recess's edge, while a
hollow of a warped mesh (the synthetic scans' smooth noise, a HoloLens mesh's bending) and a panel
set 2-3 cm into the wall are not windows."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from meshplan.plan.doors import RECESS_MIN_M, RECESS_STEP_M, _Frame, _recesses, _step
from meshplan.plan.params import PlanParams

CELL = 0.05
CEILING = 2.8
LENGTH = 3.0
#: Samples per cell along each axis (the detector samples faces at 0.7 cells).
SUB = 3


def _face(depth_at) -> tuple:
    """A 3 m face from the floor to the ceiling, sampled ``SUB`` x ``SUB`` times per cell, its
    surface at ``depth_at(u, y)`` (m, negative behind the face's plane): the arguments of
    :func:`_recesses`."""
    params = PlanParams()
    nrow, ncol = int(round(CEILING / CELL)), int(round(LENGTH / CELL))
    s = (np.arange(SUB) + 0.5) / SUB
    u = ((np.arange(ncol)[:, None] + s[None, :]).ravel()) * CELL
    y = ((np.arange(nrow)[:, None] + s[None, :]).ravel()) * CELL
    uu, yy = np.meshgrid(u, y)
    d = depth_at(uu, yy).ravel()
    r = np.floor(yy.ravel() / CELL).astype(np.int64)
    c = np.floor(uu.ravel() / CELL).astype(np.int64)
    face = np.zeros((nrow, ncol), dtype=bool)
    face[r[d >= -RECESS_MIN_M], c[d >= -RECESS_MIN_M]] = True
    recess = np.zeros((nrow, ncol), dtype=bool)
    recess[r[d < -RECESS_MIN_M], c[d < -RECESS_MIN_M]] = True
    recess &= ~face
    margin = int(np.ceil(params.opening_margin_m / CELL))
    f = _Frame(np.ones((nrow, ncol), dtype=bool), 0.0, 0.0, CEILING, CELL, margin, np.zeros(0), np.zeros(0), 0, False, False)
    walls = SimpleNamespace(u_min=np.array([0.0]), u_max=np.array([LENGTH]))
    return f, face, recess, lambda: (r, c, d), walls, params


def _pane(deep_m: float):
    """Glazing ``deep_m`` behind the face, 1.0-2.0 m along it and 1.0-2.0 m up."""
    return lambda u, y: np.where((u > 1.0) & (u < 2.0) & (y > 1.0) & (y < 2.0), -deep_m, 0.0)


def test_glazing_in_a_reveal_is_a_window():
    found = _recesses(*_face(_pane(0.05)))
    assert len(found) == 1
    w = found[0]
    assert (w.kind, w.how) == ("window", "recess")
    assert abs(w.u_min - 1.0) <= CELL and abs(w.u_max - 2.0) <= CELL
    assert abs(w.bottom - 1.0) <= CELL and abs(w.top - 2.0) <= CELL


def test_a_hollow_of_a_warped_mesh_is_no_window():
    # as deep as the glazing in its middle, but sloping into it (a smooth bump 0.35 m wide)
    def hollow(u, y):
        return -0.07 * np.exp(-((u - 1.5) ** 2 + (y - 1.5) ** 2) / (2 * 0.35**2))

    args = _face(hollow)
    assert args[2].sum() > 100  # a window-sized region behind the face's plane
    assert _recesses(*args) == []


def test_a_panel_set_a_few_centimetres_into_the_wall_is_no_window():
    # a sliding door or a panel in its track: a sharp step, but shallower than any glazed reveal
    args = _face(_pane(0.035))
    assert args[2].sum() > 100
    assert _step(args[2], args[3]()) < RECESS_STEP_M
    assert _recesses(*args) == []


"""Door gaps read column by column from one wall face's raster (:func:`meshplan.plan.doors._doors`):
a gap from the floor up to a lintel between two jambs is a door only when its lintel stands at a
door's head, not higher (a HoloLens scan rounds off the corner between wall and ceiling, and the
gap under it is no door)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from meshplan.plan.doors import DOOR_HEAD_MAX_M, _doors, _Frame
from meshplan.plan.params import PlanParams

CELL = 0.05
CEILING = 2.8


def _frame(head_m: float, left_m: float = 1.0, right_m: float = 1.85, length_m: float = 3.0) -> _Frame:
    """A 3 m wall face from the floor to the ceiling with one gap from the floor up to
    ``head_m`` between ``left_m`` and ``right_m``; triangle corners on the gap's edges."""
    params = PlanParams()
    nrow, ncol = int(round(CEILING / CELL)), int(round(length_m / CELL))
    grid = np.ones((nrow, ncol), dtype=bool)
    c0, c1, r1 = int(round(left_m / CELL)), int(round(right_m / CELL)), int(round(head_m / CELL))
    grid[:r1, c0:c1] = False
    margin = int(np.ceil(params.opening_margin_m / CELL))
    grid[:margin] = True
    # corners along the jambs (every 10 cm up to the head) and along the lintel
    ys = np.arange(0.0, head_m, 0.1)
    xs = np.arange(left_m, right_m, 0.1)
    vu = np.r_[np.full(len(ys), left_m), np.full(len(ys), right_m), xs]
    vy = np.r_[ys, ys, np.full(len(xs), head_m)]
    return _Frame(grid, 0.0, 0.0, CEILING, CELL, margin, vu, vy, 0, False, False)


def _find(head_m: float) -> list:
    walls = SimpleNamespace(u_min=np.array([0.0]), u_max=np.array([3.0]))
    f = _frame(head_m)
    return _doors(f, walls, np.ones(f.grid.shape[1]), PlanParams())


@pytest.mark.parametrize("head_m", [2.0, 2.1, 2.3])
def test_a_gap_up_to_a_door_head_is_a_door(head_m):
    (door,) = _find(head_m)
    assert door.kind == "door" and door.top == pytest.approx(head_m, abs=CELL)
    assert door.u_max - door.u_min == pytest.approx(0.85, abs=CELL)


@pytest.mark.parametrize("head_m", [DOOR_HEAD_MAX_M + 0.1, 2.6])
def test_a_gap_up_to_a_lintel_above_any_door_head_is_no_door(head_m):
    assert _find(head_m) == []


def _walls_in_line(*faces: tuple[float, float]) -> SimpleNamespace:
    """Wall faces along x at z = 0 facing +z (``(u_min, u_max)`` each), in one story."""
    n = len(faces)
    lo, hi = np.array([f[0] for f in faces]), np.array([f[1] for f in faces])
    return SimpleNamespace(
        u_min=lo, u_max=hi, normal=np.tile([0.0, 1.0], (n, 1)), tangent=np.tile([1.0, 0.0], (n, 1)),
        offset=np.zeros(n), story=np.zeros(n, dtype=int),
        start=np.c_[lo, np.zeros(n)], end=np.c_[hi, np.zeros(n)],
    )


def test_a_gap_past_the_end_of_a_face_is_a_door_only_up_to_another_piece_of_wall():
    """The face ends at 1.0 m; a gap from 1.0 to 1.85 m up to a lintel at 2.1 m has a far jamb.
    With the wall going on from 2.0 m (a piece 15 cm short of the jamb, as scans round a door's
    frame off) it is a door; with nothing of the wall there (a cupboard's side, a counter's end
    standing in the line) it is not."""
    f = _frame(2.1)
    params = PlanParams()
    with_wall = _doors(f, _walls_in_line((0.0, 1.0), (2.0, 3.0)), np.ones(f.grid.shape[1]), params)
    alone = _doors(f, _walls_in_line((0.0, 1.0)), np.ones(f.grid.shape[1]), params)
    assert [d.kind for d in with_wall] == ["door"] and alone == []

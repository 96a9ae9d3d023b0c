"""Walls are walls (issue 9): the flat-wall stage on real scans and on small built rooms.

The real-scan tests run the walls stage on each of the 13 scans with a hand-digitized truth in
``../shared/truth`` (skipped when absent) and score it with :mod:`meshplan.evaluate_real`. The
scan is levelled with the truth's own up direction (``up_hint``), so that these tests measure
the walls and not the gravity search (which still turns three of these scans on their side).
The thresholds are the level reached, with a margin; the old test ("reaches an assumed 2.5 m
ceiling") found no wall at all in the scans without a ceiling and 7 m of furniture in the
apartment, and fails them.

The built rooms check the two halves of the issue without any file: a room without a ceiling
whose walls stop at 1.8 m gets its four walls, and a counter (a 0.9 m box with its top) is
not a wall.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import pytest

from conftest import SHARED
from meshplan.evaluate_real import evaluate_real
from meshplan.geometry import Mesh
from meshplan.io import load_mesh
from meshplan.orient import orient
from meshplan.orient.params import OrientParams
from meshplan.walls import find_flat_walls
from meshplan.walls.params import WallParams

TRUTH = SHARED / "truth"

#: Per scan: least wall recall (``None``: fewer than 2 sure walls, not checked) and most
#: furniture length (m) of story 0. Reached (recall / furniture), with the walls at the edge of
#: the scan kept where their tops are lost under the ceiling, their feet hidden by furniture or
#: the scan ends below the work surfaces, and the boxes of parametric models, pilasters, pillars
#: and fragments seen through doors no walls (test_walls_furniture_real): ashro 1.0 / 0.03, cuny
#: 0.73 / 0, hemkinator 0.92 / 0, holosoma - / 0.29, mrtk 0.98 / 0, apartment 0.93 / 1.33,
#: chroje 0.92 / 0, tatami 0.97 / 0, quest 0.97 / 0, library 0.96 / 0, small room 1.0 / 0,
#: office 1.0 / 0, closed room 0.99 / 0. Before the last (evidence.EDGE_WALL_MIN_TOP_M and
#: EDGE_WALL_MIN_SEEN_M only): ashro 1.0 / 0.03, cuny 0.73 / 0, hemkinator 0.92 / 2.85, holosoma - /
#: 0.39, mrtk 0.98 / 0, apartment 0.93 / 1.33, chroje 0.92 / 0, tatami 0.97 / 0, quest 0.97 /
#: 0.04, library 0.98 / 1.9, small room 1.0 / 0, office 1.0 / 0.51, closed room 0.99 / 0.
#: Before that (walls at their own angle, free-standing pieces dropped): 0.91 /
#: 0.04, 0.27 / 0, 0.83 / 2.4, - / 0.40, 0.92 / 0, 0.92 / 1.33, 0.91 / 0, 0.97 / 0, 0.97 / 0.04,
#: 0.98 / 1.9, 1.0 / 0, 0.68 / 0.51, 0.92 / 0. Walls snapped onto their cluster's direction:
#: 0.91 / 0.03, 0.27 / 0, 0.61 / 14.0, - / 0.39, 0.91 / 3.0, 0.94 / 1.33, 0.91 / 0, 0.97 / 0,
#: 0.97 / 0.04, 0.98 / 2.4, 0.87 / 0, 0.60 / 1.08, 0.89 / 0. The old code (reaches an assumed
#: ceiling): 0.42 / 0, 0.33 / 0, 0.62 / 18.4, - / 0, 1.0 / 6.8, 0.98 / 7.0, 0.86 / 1.8, 1.0 /
#: 3.2, 0 / 0, 0 / 0, 0 / 0, 0 / 0, 0.63 / 1.5.
EXPECTED = {
    "hl1_ashro_room_45deg": (0.95, 0.5),  # no ceiling
    "hl1_cuny_room_sparse_walls": (0.9, 0.5),  # walls seen in pieces, tops lost under the ceiling, ends grazed
    "hl1_hemkinator_large_hall": (0.85, 0.5),  # drifted walls (drawn at their angle), pillars, pilasters
    "hl1_holosoma_room_sparse_walls": (None, 0.6),
    "hl1_mrtk_example_office": (0.85, 0.5),  # free-standing screens
    "hl2_su_apartment_two_story": (0.9, 2.0),  # kitchen counters and island
    "hl2_su_office_chroje": (0.85, 0.5),  # desks
    "iphone_polycam_tamatebox_tatami_room": (0.9, 0.5),  # a beam at 2.0 m
    "quest_mruk_radiotwin_lab_parametric": (0.9, 0.5),  # two triangles per wall
    "roomplan_sekhar_library_parametric": (0.9, 0.5),  # no ceiling, walls 2.82 m, furniture boxes
    "roomplan_sekhar_small_room_parametric": (0.95, 0.5),  # no ceiling, walls 2.41 m
    "tango_rainfiel_office_open": (0.95, 0.5),  # no ceiling, walls seen to 1.1-1.3 m, a desk screen
    "tango_rainfiel_room_closed": (0.95, 0.5),
}


def _score(stem: str, story0: bool = True) -> Any:
    path = TRUTH / f"{stem}.truth.json"
    if not path.is_file():
        pytest.skip(f"truth {stem} not available (../shared/truth)")
    truth = json.loads(path.read_text(encoding="utf-8"))
    scan = SHARED / "scans" / truth["scan"]
    if not scan.is_file():
        pytest.skip(f"real scan {truth['scan']} not available (../shared/scans)")
    mesh = load_mesh(scan, "m", None).mesh
    up = np.asarray(truth["truth_to_input"], dtype=np.float64)[:3, :3] @ [0.0, 1.0, 0.0]
    o = orient(mesh, OrientParams(), up_hint=up)
    walls = find_flat_walls(mesh.transformed(o.transform).with_flipped(o.flipped), o)
    plan = {
        "transform": o.transform.tolist(),
        "input": {"units": "m"},
        "stories": [s.to_dict() for s in o.stories],
        "walls": walls.to_list(),
        "rooms": [],
        "openings": [],
    }
    return evaluate_real(plan, truth)["stories"][0]["walls"] if story0 else evaluate_real(plan, truth)["stories"]


@pytest.mark.realscan
@pytest.mark.parametrize("stem", sorted(EXPECTED))
def test_real_scan_walls(stem: str) -> None:
    min_recall, max_furniture = EXPECTED[stem]
    w = _score(stem)
    if min_recall is not None:
        assert w["recall"] >= min_recall, w
    assert w["furniture_length_m"] <= max_furniture, w


#: Issue 9's bounds, story by story: wall length F1 at least 0.90 on every story whose truth
#: has at least 3 sure walls, furniture at most 0.5 m on every story.
MIN_F1, MIN_SURE_WALLS, MAX_FURNITURE_M = 0.90, 3, 0.5

#: Where the bound is not met, and why (strict: the test fails when it starts to pass).
#: The apartment: 0.96-1.18 m of its 1.33 m is a surface across the mouth of what the truth calls
#: a corridor (R2, open to the hall, a doorway at its north end). The scan says otherwise: the
#: surface faces the hall from the floor to the hall's ceiling (fully covered from 1.0 to 2.4 m;
#: furniture hides parts of it lower down), and behind it nothing was scanned at floor level
#: (no up-facing face within 10 cm of the floor over its 1.1 x 3.3 m, where the hall's floor in
#: front of it is scanned) and no face looks into it; its only horizontal faces are at 2.03-2.76 m,
#: facing up: the second flight of a dogleg stair (landing at 1.85 m at the end of the first
#: flight, one riser to 2.04, four risers to story 1 at 2.76), seen from above. What the truth
#: reads as the doorway's head at 2.05 m is that landing's top. The space under it is closed to
#: the hall (a closet under the stair; a door-shaped 0.75 m recess, 5.5 cm deep, faces it from
#: the bedroom), and the wall across its mouth is a wall (measured in test_truth_disputes_real).
BOUND_MISSED = {
    "hl2_su_apartment_two_story": "1.18 m of the 1.33 m is the wall that closes the space under the stair's second flight to "
    "the hall, which the truth reads as the open mouth of a corridor (see the comment above BOUND_MISSED)",
}


@pytest.mark.realscan
@pytest.mark.parametrize(
    "stem",
    [pytest.param(s, marks=pytest.mark.xfail(reason=BOUND_MISSED[s], strict=True)) if s in BOUND_MISSED else s for s in sorted(EXPECTED)],
)
def test_real_scan_walls_meet_the_issue_bounds_on_every_story(stem: str) -> None:
    for story in _score(stem, story0=False):
        w = story["walls"]
        if w["sure_truth_walls"] >= MIN_SURE_WALLS:
            assert w["f1"] >= MIN_F1, (story["truth_story"] if "truth_story" in story else story, w)
        assert w["furniture_length_m"] <= MAX_FURNITURE_M, w


# ------------------------------------------------------------------------- built rooms


class _Builder:
    """Vertices and faces of grids of quads (normal = du x dv, right-hand rule)."""

    def __init__(self) -> None:
        self.verts: list[np.ndarray] = []
        self.faces: list[np.ndarray] = []
        self.n = 0

    def quad(self, origin, du, dv, cell: float = 0.1) -> None:
        o, du, dv = (np.asarray(a, float) for a in (origin, du, dv))
        nu = max(int(round(np.linalg.norm(du) / cell)), 1)
        nv = max(int(round(np.linalg.norm(dv) / cell)), 1)
        i, j = np.meshgrid(np.arange(nu + 1), np.arange(nv + 1), indexing="ij")
        p = o + i[..., None] * du / nu + j[..., None] * dv / nv
        idx = (i * (nv + 1) + j)[:-1, :-1].reshape(-1) + self.n
        self.verts.append(p.reshape(-1, 3))
        self.faces.append(np.c_[idx, idx + (nv + 1), idx + (nv + 1) + 1])
        self.faces.append(np.c_[idx, idx + (nv + 1) + 1, idx + 1])
        self.n += len(p.reshape(-1, 3))

    def room(self, width: float, depth: float, wall_top: float, ceiling: bool) -> None:
        """Floor, four walls up to ``wall_top``, and a ceiling there when ``ceiling``."""
        w, d, h = width, depth, wall_top
        self.quad([0, 0, 0], [0, 0, d], [w, 0, 0])  # floor, +y
        if ceiling:
            self.quad([0, h, 0], [w, 0, 0], [0, 0, d])  # ceiling, -y
        self.quad([0, 0, 0], [w, 0, 0], [0, h, 0])  # z = 0, +z
        self.quad([0, 0, d], [0, h, 0], [w, 0, 0])  # z = d, -z
        self.quad([0, 0, 0], [0, h, 0], [0, 0, d])  # x = 0, +x
        self.quad([w, 0, 0], [0, 0, d], [0, h, 0])  # x = w, -x

    def counter(self, x0: float, x1: float, depth: float, height: float) -> None:
        """A counter against the wall z = 0: its front (facing +z), top and two ends."""
        self.quad([x0, 0, depth], [x1 - x0, 0, 0], [0, height, 0])  # front, +z
        self.quad([x0, height, 0], [0, 0, depth], [x1 - x0, 0, 0])  # top, +y
        self.quad([x0, 0, 0], [0, 0, depth], [0, height, 0])  # low-x end, -x
        self.quad([x1, 0, 0], [0, height, 0], [0, 0, depth])  # high-x end, +x

    def mesh(self) -> Mesh:
        return Mesh(np.concatenate(self.verts), np.concatenate(self.faces))


def _walls(mesh: Mesh):
    o = orient(mesh, OrientParams(), up_hint=np.array([0.0, 1.0, 0.0]))
    return o, find_flat_walls(mesh.transformed(o.transform).with_flipped(o.flipped), o)


def test_room_without_ceiling_walls_to_1_8_m_gets_its_four_walls() -> None:
    b = _Builder()
    b.room(5.0, 4.0, 1.8, ceiling=False)
    o, walls = _walls(b.mesh())
    assert not o.stories[0].ceiling_found  # an assumed ceiling its walls never reach
    assert len(walls) == 4
    assert sorted(np.round(walls.length, 1)) == pytest.approx([4.0, 4.0, 5.0, 5.0], abs=0.15)
    assert np.all(walls.top > 1.7)


@pytest.mark.parametrize("ceiling", [True, False])
def test_counter_is_not_a_wall(ceiling: bool) -> None:
    b = _Builder()
    b.room(5.0, 4.0, 2.6 if ceiling else 1.8, ceiling=ceiling)
    b.counter(1.0, 3.5, depth=0.6, height=0.9)
    _, walls = _walls(b.mesh())
    # the four walls of the room, none in the counter front's plane (2.5 m long, 0.9 m high)
    assert len(walls) == 4
    assert sorted(np.round(walls.length, 1)) == pytest.approx([4.0, 4.0, 5.0, 5.0], abs=0.15)
    assert np.all(walls.top > 1.7)


def test_walls_at_the_edge_of_the_scan_keep_their_lost_tops_and_hidden_feet() -> None:
    """A 5 x 4 m room with a 2.8 m ceiling whose walls were scanned only from 0.7 m (furniture
    hid their feet) to 2.3 m (the band under the ceiling was missed): nothing was scanned behind
    them, so they still bound the room (issue 9: a headset room with its walls in pieces)."""
    b = _Builder()
    w, d, h = 5.0, 4.0, 2.8
    b.quad([0, 0, 0], [0, 0, d], [w, 0, 0])  # floor
    b.quad([0, h, 0], [w, 0, 0], [0, 0, d])  # ceiling
    lo, hi = 0.7, 2.3
    b.quad([0, lo, 0], [w, 0, 0], [0, hi - lo, 0])  # z = 0
    b.quad([0, lo, d], [0, hi - lo, 0], [w, 0, 0])  # z = d
    b.quad([0, lo, 0], [0, hi - lo, 0], [0, 0, d])  # x = 0
    b.quad([w, lo, 0], [0, 0, d], [0, hi - lo, 0])  # x = w
    o, walls = _walls(b.mesh())
    assert o.stories[0].ceiling_found
    assert sorted(np.round(walls.length, 1)) == pytest.approx([4.0, 4.0, 5.0, 5.0], abs=0.15)


def test_a_short_patch_facing_back_in_front_of_a_wall_does_not_take_the_wall_with_it() -> None:
    """hl1_mrtk's only floor-to-ceiling wall (3.6 m) was lost in one frame of the plan out of
    two: a 0.45 m patch 7 cm in front of it, wound the other way (a headset's second layer of
    the same surface), faced back at it, and the two were taken for the inner faces of a wall
    modelled by its two sides (flat._wall_cores), both dropped. The core of a face lies behind
    most of the face itself; here it is the patch's, and only the patch goes. Two faces of equal
    length facing each other across 7 cm (a wall modelled by two thin boxes) both still go."""
    from meshplan.walls.flat import _wall_cores

    def row(normal, offset, u_min, u_max):
        return {"normal": normal, "offset": offset, "u_min": u_min, "u_max": u_max}

    wall = row((1.0, 0.0), 0.0, 0.0, 3.6)  # x = 0, facing +x, z 0 to 3.6 (tangent +z)
    patch = row((-1.0, 0.0), -0.07, -1.45, -1.0)  # x = 0.07, facing -x, z 1.0 to 1.45 (tangent -z)
    twin = row((-1.0, 0.0), -0.07, -3.6, 0.0)  # x = 0.07 facing -x along the whole wall
    params = WallParams()
    assert _wall_cores([wall, patch], params).tolist() == [False, True]
    assert _wall_cores([wall, twin], params).tolist() == [True, True]


def _grazed_room(low_piece_in_line: bool) -> Mesh:
    """A 5 x 4 m room under a 2.8 m ceiling. The wall z = 4 is scanned to the ceiling from x 0
    to 2.5; past a 0.8 m door a piece from x 3.3 to 5 is seen only from 0.3 to 1.6 m (a headset
    grazed it at the edge of the scan) in the wall's plane, or, with ``low_piece_in_line``
    false, 0.6 m in front of it with nothing of that wall scanned (a wardrobe's front at the
    scan's edge). The wall x = 0 is scanned to the ceiling up to z 3 and only to 1.6 m beyond."""
    b = _Builder()
    w, d, h = 5.0, 4.0, 2.8
    b.quad([0, 0, 0], [0, 0, d], [w, 0, 0])  # floor, +y
    b.quad([0, h, 0], [w, 0, 0], [0, 0, d])  # ceiling, -y
    b.quad([0, 0, 0], [w, 0, 0], [0, h, 0])  # z = 0, +z
    b.quad([w, 0, 0], [0, 0, d], [0, h, 0])  # x = w, -x
    b.quad([0, 0, 0], [0, h, 0], [0, 0, 3.0])  # x = 0 to z 3, +x
    b.quad([0, 0.3, 3.0], [0, 1.3, 0], [0, 0, 1.0])  # x = 0 beyond z 3, seen 0.3-1.6 m
    if low_piece_in_line:
        b.quad([0, 0, d], [0, h, 0], [2.5, 0, 0])  # z = d, -z, to the ceiling
        b.quad([3.3, 0.3, d], [0, 1.3, 0], [1.7, 0, 0])  # past the door, seen 0.3-1.6 m
    else:
        b.quad([3.3, 0.3, d - 0.6], [0, 1.3, 0], [1.7, 0, 0])  # a front 0.6 m inside, nothing behind
    return b.mesh()


def test_a_wall_grazed_at_the_edge_of_the_scan_continues_its_wall() -> None:
    """Issue 9 (hl1_cuny's south and west walls): the end of a wall at the edge of the scan is
    seen only to 1.6 m where the rest reaches the ceiling; it continues the wall (across a door
    too), it does not stop it."""
    _, walls = _walls(_grazed_room(low_piece_in_line=True))
    # the four walls whole: 2.5 m (z = 4 stopped at its door) and 3.0 m (x = 0) before
    assert sorted(np.round(walls.length, 2)) == pytest.approx([4.0, 4.0, 5.0, 5.0], abs=0.15)


def test_a_low_front_at_the_edge_of_the_scan_out_of_any_wall_line_is_no_wall() -> None:
    """The same low surface 0.6 m in front of an unscanned wall (a wardrobe at the edge of the
    scan) continues no wall: it is not one."""
    _, walls = _walls(_grazed_room(low_piece_in_line=False))
    # three walls (x = 0 continued by its grazed end), none in the front's plane
    assert sorted(np.round(walls.length, 2)) == pytest.approx([4.0, 4.0, 5.0], abs=0.15)


def _window_wall_room(hole_m: float) -> Mesh:
    """A 6 x 4 m room without a ceiling, its walls scanned to 1.5 m. The wall z = 0 holds a
    window 2.4 m wide (x 1.5 to 3.9) over a parapet 0.95 m high with its sill (a level surface
    0.2 m deep into the wall) and its jambs; over the last ``hole_m`` by the right jamb a hole in
    the scan took the sill and the parapet's top 8 cm."""
    b = _Builder()
    w, d, h = 6.0, 4.0, 1.5
    b.quad([0, 0, 0], [0, 0, d], [w, 0, 0])  # floor, +y
    b.quad([0, 0, d], [0, h, 0], [w, 0, 0])  # z = d, -z
    b.quad([0, 0, 0], [0, h, 0], [0, 0, d])  # x = 0, +x
    b.quad([w, 0, 0], [0, 0, d], [0, h, 0])  # x = w, -x
    x0, x1, sill = 1.5, 3.9, 0.95
    b.quad([0, 0, 0], [x0, 0, 0], [0, h, 0])  # z = 0 (+z) left of the window
    b.quad([x0, 0, 0], [x1 - hole_m - x0, 0, 0], [0, sill, 0])  # the parapet
    b.quad([x1 - hole_m, 0, 0], [hole_m, 0, 0], [0, sill - 0.08, 0])  # its top in the hole
    b.quad([x1, 0, 0], [w - x1, 0, 0], [0, h, 0])  # right of the window
    b.quad([x0, sill, 0], [x1 - hole_m - x0, 0, 0], [0, 0, -0.2])  # the sill, +y
    b.quad([x0, sill, 0], [0, 0, -0.2], [0, h - sill, 0])  # left jamb, +x
    b.quad([x1, sill, 0], [0, h - sill, 0], [0, 0, -0.2])  # right jamb, -x
    return b.mesh()


@pytest.mark.parametrize("hole_m", [0.0, 0.5])
def test_a_window_wider_than_a_door_does_not_split_its_wall(hole_m: float) -> None:
    """Issue 16 (hard preset, seed 2): the wall under a window (its parapet, with the sill on its
    top) neither starts nor breaks a wall; where a hole in the scan took the sill by a jamb, the
    sill of the columns beside still says so (judged over a box length). Before, the 0.5 m
    without a sill split the wall in two across the 2.4 m window (wider than merge_gap_m), and
    the window was lost with it."""
    _, walls = _walls(_window_wall_room(hole_m))
    assert sorted(np.round(walls.length, 1)) == pytest.approx([4.0, 4.0, 6.0, 6.0], abs=0.15)


def test_a_room_scanned_to_1_1_m_gets_its_walls_but_not_its_counter() -> None:
    """A room without a ceiling scanned only up to 1.1 m (below the highest work surface): its
    walls, with nothing scanned behind them, are walls; the 0.9 m counter front, with its top
    attached, is not."""
    b = _Builder()
    b.room(5.0, 4.0, 1.1, ceiling=False)
    b.counter(1.0, 3.5, depth=0.6, height=0.9)
    _, walls = _walls(b.mesh())
    assert sorted(np.round(walls.length, 1)) == pytest.approx([4.0, 4.0, 5.0, 5.0], abs=0.15)


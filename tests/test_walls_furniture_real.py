"""Walls are walls (issue 9): the furniture walls of the real scans, and built rooms that hold
what caused them.

On the real scans (skipped when ``../shared`` is absent), story 0 scored against the hand-digitized
truth (:func:`test_walls_real._score`: the walls stage with the truth's up):

* ``roomplan_sekhar_library_parametric``: 1.90 m of furniture before, the sides of RoomPlan's
  storage boxes (1.9 m tall, 0.6 x 1 m), turned inside out by the winding repair (their bottom
  votes like a floor), so that their tops face down and lie in front of their sides, where the
  test of a top attached behind a front never looks (:mod:`meshplan.walls.solids`);
* ``hl1_hemkinator_large_hall``: 2.85 m before: the fronts of two pilasters standing 0.17 and
  0.3 m out of the west and south walls (:func:`meshplan.walls.flat._pilasters`), the north face
  of a column rising to the ceiling out of a 2 m booth (the ceiling scanned all round its top,
  the pillar case of :func:`meshplan.walls.flat._free_standing`), and a 0.6 m fragment of clutter
  seen through the north-east door up to 1.8 m, connected to no wall, under a 3.3 m ceiling (the
  fragment case);
* ``tango_rainfiel_office_open``: 0.51 m before, a desk's screen (0.5 m, up to 1.24 m, the desk
  top against it along 90 % of its length) connected to no wall, in a story without a ceiling.

The apartment's 1.33 m stay: 1.18 m of it is a floor-to-ceiling surface across the mouth of what
the truth reads as an open corridor, where the scan shows the closed space under a dogleg stair's
second flight (:data:`test_walls_real.BOUND_MISSED`).
"""

from __future__ import annotations

import numpy as np
import pytest

from meshplan.geometry import Mesh
from meshplan.walls.params import WallParams
from meshplan.walls.solids import object_boxes
from test_walls_real import _Builder, _score, _walls

# ------------------------------------------------------------------------- real scans


@pytest.mark.realscan
def test_parametric_furniture_boxes_are_not_walls() -> None:
    w = _score("roomplan_sekhar_library_parametric")
    assert w["furniture_length_m"] <= 0.5, w  # 1.90 m before
    assert w["f1"] >= 0.97, w  # 0.974 before, 0.982 now (a 0.29 m wall lost its furniture extension)


@pytest.mark.realscan
def test_large_hall_pilasters_pillar_and_clutter_are_not_walls() -> None:
    w = _score("hl1_hemkinator_large_hall")
    assert w["furniture_length_m"] <= 0.5, w  # 2.85 m before
    assert w["recall"] >= 0.92, w  # no true wall lost (0.923 before and now)
    assert w["f1"] >= 0.95, w  # 0.932 before, 0.960 now


@pytest.mark.realscan
def test_desk_screen_in_an_open_office_is_not_a_wall() -> None:
    w = _score("tango_rainfiel_office_open")
    assert w["furniture_length_m"] <= 0.5, w  # 0.51 m before
    assert w["recall"] >= 0.99, w  # the curved wall's chords, all kept


@pytest.mark.realscan
def test_sparse_wall_with_a_desk_against_it_is_a_wall() -> None:
    """``hl1_holosoma_room_sparse_walls``: its one sure wall (1.1 m, seen to 1.67 m in a room
    without a scanned ceiling, connected to no other wall) has a desk top (0.71 m) against it
    along 62 % of its length; it was dropped as a screen rising out of the desk (recall 0). It
    rises 0.96 m above the desk, which no screen does (flat.SCREEN_RISE_M)."""
    w = _score("hl1_holosoma_room_sparse_walls")
    assert w["recall"] >= 0.99, w  # 0.0 before
    assert w["f1"] >= 0.9, w  # 0.0 before, 0.94 now
    assert w["furniture_length_m"] <= 0.45, w  # 0.39 before and now


@pytest.mark.realscan
@pytest.mark.parametrize(
    "stem, min_f1, max_furniture",
    [
        ("hl2_su_office_chroje", 0.95, 0.1),  # a wall meeting a 2.08 m soffit stays (below door height, top not lost)
        ("quest_mruk_radiotwin_lab_parametric", 0.98, 0.1),  # its tables and storage are boxes too
        ("roomplan_sekhar_small_room_parametric", 1.0, 0.0),
        ("hl1_cuny_room_sparse_walls", 0.95, 0.05),  # walls in short pieces under a scanned ceiling stay, grazed ends too (0.84 before)
    ],
)
def test_other_scans_keep_their_walls(stem: str, min_f1: float, max_furniture: float) -> None:
    w = _score(stem)
    assert w["f1"] >= min_f1 - 1e-3, w
    assert w["furniture_length_m"] <= max_furniture, w


# ------------------------------------------------------------------------- built cases


def _cuboid(x0: float, x1: float, y0: float, y1: float, z0: float, z1: float) -> tuple[np.ndarray, np.ndarray]:
    """A closed box of 8 corners and 12 outward-wound triangles."""
    v = np.array([[x, y, z] for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)], dtype=np.float64)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    f = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))], dtype=np.int64)
    return v, f


def _meshes(*parts: tuple[np.ndarray, np.ndarray]) -> Mesh:
    verts, faces, n = [], [], 0
    for v, f in parts:
        verts.append(v)
        faces.append(f + n)
        n += len(v)
    return Mesh(np.concatenate(verts), np.concatenate(faces))


def test_object_boxes_are_the_boxes_thicker_than_a_wall() -> None:
    wall = _cuboid(0.0, 4.0, 0.0, 2.8, 0.0, 0.0001)  # RoomPlan's wall: a box 0.1 mm thick
    storage = _cuboid(1.0, 1.6, 0.0, 1.9, 0.5, 1.5)  # a bookcase 0.6 x 1.0 x 1.9 m
    panel = _cuboid(2.0, 3.0, 0.0, 1.2, 1.0, 1.1)  # a 0.1 m thick panel: may be a wall
    skew_v, skew_f = _cuboid(0.0, 1.0, 0.0, 1.0, 3.0, 4.0)
    skew_v = skew_v.copy()
    skew_v[7] += [0.3, 0.2, 0.1]  # 12 triangles and 8 corners, but not a box
    mesh = _meshes(wall, storage, panel, (skew_v, skew_f))
    got = object_boxes(mesh, WallParams().max_wall_thickness_m)
    assert got.reshape(4, 12).all(axis=1).tolist() == [False, True, False, False]
    assert got.reshape(4, 12).any(axis=1).tolist() == [False, True, False, False]


def test_parametric_room_storage_box_against_a_wall_gap_is_not_a_wall() -> None:
    """A parametric room (thin wall boxes, no ceiling) with a 1.9 m storage box standing where
    one wall has a gap: the box's front is in no wall's plane and must not become a wall."""
    h = 2.8
    parts = [
        _cuboid(0.0, 6.0, 0.0, h, 0.0, 0.0001),  # z = 0
        _cuboid(0.0, 6.0, 0.0, h, 5.0, 5.0001),  # z = 5
        _cuboid(6.0, 6.0001, 0.0, h, 0.0, 5.0),  # x = 6
        _cuboid(0.0, 0.0001, 0.0, h, 0.0, 2.0),  # x = 0, south part
        _cuboid(0.0, 0.0001, 0.0, h, 3.0, 5.0),  # x = 0, north part (a 1 m gap at z 2-3)
        _cuboid(0.2, 0.8, 0.0, 1.9, 2.0, 3.0),  # storage in the gap, 0.2 m in from the wall line
    ]
    floor_v = np.array([[0, 0, 0], [6, 0, 0], [6, 0, 5], [0, 0, 5]], dtype=np.float64)
    floor_f = np.array([[0, 2, 1], [0, 3, 2]], dtype=np.int64)
    o, walls = _walls(_meshes(*parts, (floor_v, floor_f)))
    assert not o.stories[0].ceiling_found
    # no wall in the planes of the storage's sides (x 0.2 and 0.8 in the input frame): every
    # wall found lies in the plane of a wall box
    inv = np.linalg.inv(o.transform)
    for s, e in zip(walls.start, walls.end):
        mid = inv @ np.array([(s[0] + e[0]) / 2, 1.0, (s[1] + e[1]) / 2, 1.0])
        x, z = mid[0], mid[2]
        on_wall = min(abs(x), abs(x - 6.0), abs(z), abs(z - 5.0)) <= 0.16
        assert on_wall, (x, z)


@pytest.mark.parametrize("top, is_wall", [(1.65, True), (1.2, False)])
def test_piece_rising_out_of_a_desk_is_a_screen_only_as_high_as_one(top: float, is_wall: bool) -> None:
    """A room without a ceiling (walls scanned to 1.7 m) whose x = 0 side is scanned only
    along a 1 m piece connected to no other wall, a desk (0.75 m high, 0.6 m deep) against it:
    seen to 1.65 m, 0.9 m above the desk, it is a wall; seen to 1.2 m, rising 0.45 m out of the
    desk, a screen (flat.SCREEN_RISE_M)."""
    b = _Builder()
    w, d, h = 5.0, 4.0, 1.7
    b.quad([0, 0, 0], [0, 0, d], [w, 0, 0])  # floor, +y
    b.quad([w, 0, 0], [0, 0, d], [0, h, 0])  # x = w, -x
    b.quad([1.5, 0, 0], [w - 1.5, 0, 0], [0, h, 0])  # z = 0 from x = 1.5, +z
    b.quad([1.5, 0, d], [0, h, 0], [w - 1.5, 0, 0])  # z = d from x = 1.5, -z
    z0, z1 = 1.5, 2.5
    b.quad([0, 0, z0], [0, top, 0], [0, 0, z1 - z0], cell=0.05)  # the piece at x = 0, +x
    b.quad([0, 0.75, z0], [0, 0, z1 - z0], [0.6, 0, 0])  # the desk's top, +y
    b.quad([0.6, 0, z0], [0, 0.75, 0], [0, 0, z1 - z0])  # its front, +x
    _, walls = _walls(b.mesh())
    expected = [1.0, 3.5, 3.5, 4.0] if is_wall else [3.5, 3.5, 4.0]
    assert sorted(np.round(walls.length, 1)) == pytest.approx(expected, abs=0.15)


def test_pilaster_is_not_a_wall() -> None:
    """A 6 x 5 m room with a ceiling and a 0.6 m pilaster standing 0.2 m out of its x = 0 wall:
    the wall is drawn behind it, the pilaster's front is no wall."""
    b = _Builder()
    w, d, h = 6.0, 5.0, 2.6
    b.room(w, d, h, ceiling=True)
    z0, z1, dx = 2.2, 2.8, 0.2
    b.quad([dx, 0, z0], [0, h, 0], [0, 0, z1 - z0], cell=0.05)  # front, +x
    b.quad([0, 0, z0], [0, h, 0], [dx, 0, 0], cell=0.05)  # side facing -z
    b.quad([0, 0, z1], [dx, 0, 0], [0, h, 0], cell=0.05)  # side facing +z
    o, walls = _walls(b.mesh())
    assert o.stories[0].ceiling_found
    assert sorted(np.round(walls.length, 1)) == pytest.approx([5.0, 5.0, 6.0, 6.0], abs=0.15)


def test_pillar_with_the_ceiling_all_round_it_is_not_a_wall() -> None:
    """A 0.8 m square pillar from the floor to the ceiling in a 7 x 6 m room, with the floor
    around it hidden (a ring of furniture whose fronts were not scanned) so that no floor is seen
    behind its faces: the ceiling scanned all round its top says that the room goes on behind
    it; its faces are no walls."""
    b = _Builder()
    w, d, h = 7.0, 6.0, 2.7
    # the room without its floor, then the floor with a 2.8 m hole round the pillar
    b.quad([0, h, 0], [w, 0, 0], [0, 0, d])  # ceiling, -y
    b.quad([0, 0, 0], [w, 0, 0], [0, h, 0])
    b.quad([0, 0, d], [0, h, 0], [w, 0, 0])
    b.quad([0, 0, 0], [0, h, 0], [0, 0, d])
    b.quad([w, 0, 0], [0, 0, d], [0, h, 0])
    cx, cz, r, hole = 3.5, 3.0, 0.4, 1.4
    for x0, x1, z0, z1 in ((0, w, 0, cz - hole), (0, w, cz + hole, d), (0, cx - hole, cz - hole, cz + hole), (cx + hole, w, cz - hole, cz + hole)):
        b.quad([x0, 0, z0], [0, 0, z1 - z0], [x1 - x0, 0, 0])  # floor, +y
    x0, x1, z0, z1 = cx - r, cx + r, cz - r, cz + r
    b.quad([x0, 0, z0], [0, h, 0], [x1 - x0, 0, 0], cell=0.05)  # z = z0, facing -z
    b.quad([x0, 0, z1], [x1 - x0, 0, 0], [0, h, 0], cell=0.05)  # z = z1, facing +z
    b.quad([x0, 0, z0], [0, 0, z1 - z0], [0, h, 0], cell=0.05)  # x = x0, facing -x
    b.quad([x1, 0, z0], [0, h, 0], [0, 0, z1 - z0], cell=0.05)  # x = x1, facing +x
    o, walls = _walls(b.mesh())
    assert o.stories[0].ceiling_found
    assert sorted(np.round(walls.length, 1)) == pytest.approx([6.0, 6.0, 7.0, 7.0], abs=0.15)

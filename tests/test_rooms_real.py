"""Rooms bounded by walls (issue 9): on the real scans against their hand-digitized truth, and
on small synthetic walls built here.

A room is the free floor between its walls. Where a wall was not scanned the room is closed
along the walls that were (a piece missing at a corner or at a door), where no wall closes it its
ragged floor outline is straightened, and fragments smaller than a closet are merged or dropped.
The real-scan part is skipped when ../shared is absent.
"""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, Polygon

from conftest import SHARED
from meshplan.plan.closure import _corner_fills, close_walls, reach_walls, straighten
from meshplan.plan.params import PlanParams
from meshplan.plan.rooms import _open_rooms

SCANS = SHARED / "scans"
TRUTH = SHARED / "truth"

#: Per scan: smallest mean room IoU, largest mean area error, smallest number of truth rooms
#: matched, at the level reached (with a margin for the wall finder's changes).
REAL_ROOMS = {
    # closed on its open side by the partition's run to the edge of the scan (closure.run_to_boundary)
    "hl1_ashro_room_45deg.obj": (0.9, 0.08, 1),
    # the north wall was not scanned: the room follows the scanned footprint there (11 % short);
    # carried up to the west and south walls and the south wall's continuation where furniture
    # hid the floor (IoU 0.73 -> 0.81, 25.5 -> 16.7 % short: closure.reach_walls), and into the
    # south-east corner the continued walls meet in (0.81 -> 0.86, 16.7 -> 11.1 %)
    "hl1_cuny_room_sparse_walls.obj": (0.84, 0.13, 1),
    "hl1_hemkinator_large_hall.ply": (0.95, 0.02, 1),
    # only the west wall is sure; closed by the footprint (15 % short)
    "hl1_holosoma_room_sparse_walls.obj": (0.78, 0.18, 1),
    # the stair and the corridor are rooms: walls enclose them although their floor was not
    # scanned, and the partition between them runs on to the edge of the scan
    "hl2_su_apartment_two_story.ply": (0.85, 0.09, 5),
    "hl2_su_office_chroje.ply": (0.85, 0.03, 2),
    # its second truth room is split off by 2.0-2.2 m partitions (unsure truth walls), which the
    # free-standing rule of the walls now drops as screens: one of the two low-confidence rooms,
    # its area 27 % off the truth's (which splits the scanned floor at that partition line)
    "hl1_mrtk_example_office.ply": (0.75, 0.30, 1),
    # up from the format (glTF is +y up) where the geometry cannot decide
    "iphone_polycam_tamatebox_tatami_room.glb": (0.95, 0.02, 1),
    "quest_mruk_radiotwin_lab_parametric.obj": (0.98, 0.01, 1),
    # the corridor beyond a 2.3 m mouth over scanned floor stays part of the room (the truth
    # splits it there)
    "roomplan_sekhar_library_parametric.ply": (0.85, 0.08, 1),
    "roomplan_sekhar_small_room_parametric.ply": (0.95, 0.01, 1),
    # partial (the truth follows the footprint of floor, desks and low surfaces): a desk's
    # screen, no wall, once cut the room where the truth's outline happens to run (0.5 %)
    "tango_rainfiel_office_open.ply": (0.8, 0.04, 1),
    "tango_rainfiel_room_closed.ply": (0.93, 0.02, 1),
}

#: Pooled over every truth scan: room recall and median area error of the matched rooms, the
#: numbers of issue 9 (reached: 18 of 20, median 2.6 %; 1.6 % while a desk's screen was a wall
#: cutting the open office's room where its partial truth ends).
POOLED_RECALL = 0.90
POOLED_MEDIAN_AREA_ERROR = 0.03


def _score(name: str) -> dict:
    import meshplan
    from meshplan.evaluate_real import evaluate_real
    from meshplan.export import plan_document

    result = meshplan.run(SCANS / name, output=None)
    truth = json.loads((TRUTH / f"{name.rsplit('.', 1)[0]}.truth.json").read_text())
    return evaluate_real(plan_document(result), truth)["total"]["rooms"]


@pytest.fixture(scope="module")
def real_rooms():
    if not SCANS.is_dir() or not TRUTH.is_dir():
        pytest.skip("real scans not available (../shared)")
    out = {}
    for truth in sorted(TRUTH.glob("*.truth.json")):
        scan = json.loads(truth.read_text())["scan"]
        if (SCANS / scan).is_file():
            out[scan] = _score(scan)
    return out


@pytest.mark.realscan
@pytest.mark.parametrize("name", sorted(REAL_ROOMS))
def test_real_rooms(real_rooms, name):
    if name not in real_rooms:
        pytest.skip(f"{name} not available")
    iou_min, err_max, matched_min = REAL_ROOMS[name]
    r = real_rooms[name]
    assert r["matched"] >= matched_min, r
    assert r["mean_iou"] >= iou_min, r
    assert r["mean_area_error"] <= err_max, r


@pytest.mark.realscan
def test_real_rooms_pooled(real_rooms):
    matched = sum(r["matched"] for r in real_rooms.values())
    truth = sum(r["truth_rooms"] for r in real_rooms.values())
    errors = [p["area_error"] for r in real_rooms.values() for p in r["pairs"]]
    assert matched / truth >= POOLED_RECALL
    assert np.median(errors) <= POOLED_MEDIAN_AREA_ERROR


# --- synthetic walls -------------------------------------------------------------------------


def _walls(segments: list[tuple[tuple[float, float], tuple[float, float], tuple[float, float]]]) -> SimpleNamespace:
    """FlatWalls-like rows from ``(start, end, inward normal)`` of axis-parallel wall faces."""
    normal = np.array([n for _, _, n in segments], dtype=float)
    tangent = np.c_[-normal[:, 1], normal[:, 0]]
    a = np.array([s for s, _, _ in segments], dtype=float)
    b = np.array([e for _, e, _ in segments], dtype=float)
    ua, ub = np.einsum("ij,ij->i", a, tangent), np.einsum("ij,ij->i", b, tangent)
    return SimpleNamespace(
        normal=normal,
        tangent=tangent,
        offset=np.einsum("ij,ij->i", a, normal),
        u_min=np.minimum(ua, ub),
        u_max=np.maximum(ua, ub),
    )


def _faces(walls, extra=()) -> list[Polygon]:
    """The faces of the arrangement of the closed walls (and ``extra`` rings)."""
    p = PlanParams()
    index = np.arange(len(walls.offset))
    lo, hi, bridges = close_walls(walls, index, p.corner_extension_m, p.wall_gap_m, p.collinear_wall_m)
    lines = [LineString([lo[k] * walls.tangent[k] + walls.offset[k] * walls.normal[k], hi[k] * walls.tangent[k] + walls.offset[k] * walls.normal[k]]) for k in index]
    merged = shapely.union_all(lines + bridges + list(extra))
    return [f for f in shapely.get_parts(shapely.polygonize(shapely.get_parts(shapely.node(merged)))) if f.area > 0.5]


def test_a_corner_missed_by_the_scan_closes_along_the_walls():
    """A 4 x 3 m room whose north wall was scanned only up to 1 m short of the east wall, and
    whose east wall stops 0.8 m short of the north wall: both run on to their corner, and the
    room is the rectangle (not where its floor happens to end)."""
    walls = _walls(
        [
            ((0, 0), (3.0, 0), (0, 1)),  # north, 1 m missing at the NE corner
            ((4, 0.8), (4, 3), (-1, 0)),  # east, 0.8 m missing at the NE corner
            ((0, 3), (4, 3), (0, -1)),  # south
            ((0, 0), (0, 3), (1, 0)),  # west
        ]
    )
    faces = _faces(walls)
    assert len(faces) == 1
    assert faces[0].area == pytest.approx(12.0, abs=0.02)


def test_a_corridor_seen_through_a_door_does_not_leak_into_the_room():
    """A 4 x 3 m room whose south wall is two pieces either side of a 0.9 m door; the corridor
    beyond is scanned floor (a ragged outline). The door gap is closed along the wall's line:
    the room keeps its 12 m2 and the corridor is a face of its own."""
    walls = _walls(
        [
            ((0, 0), (4, 0), (0, 1)),
            ((4, 0), (4, 3), (-1, 0)),
            ((0, 3), (1.5, 3), (0, -1)),  # south wall, west of the door
            ((2.4, 3), (4, 3), (0, -1)),  # south wall, east of the door
            ((0, 0), (0, 3), (1, 0)),
        ]
    )
    rng = np.random.default_rng(0)
    t = np.linspace(0, 2 * np.pi, 80, endpoint=False)
    ragged = Polygon(np.c_[2 + 3.0 * np.cos(t), 3.9 + (1.2 + 0.1 * rng.random(80)) * np.sin(t)]).union(shapely.box(-0.1, -0.1, 4.1, 3.1))
    faces = _faces(walls, [ragged.exterior])
    room = max(faces, key=lambda f: f.intersection(shapely.box(0, 0, 4, 3)).area)
    assert room.area == pytest.approx(12.0, abs=0.05)


def test_a_wall_stub_does_not_cut_across_a_room():
    """A short wall piece in the middle of a room, 1.8 m from the nearest wall (further than a
    door is wide), splits nothing."""
    walls = _walls(
        [
            ((0, 0), (4, 0), (0, 1)),
            ((4, 0), (4, 5), (-1, 0)),
            ((0, 5), (4, 5), (0, -1)),
            ((0, 0), (0, 5), (1, 0)),
            ((1.8, 2.5), (2.3, 2.5), (0, 1)),  # a stub
        ]
    )
    assert len(_faces(walls)) == 1



def test_a_ragged_floor_outline_is_straightened():
    """A room closed by its scanned floor whose outline is a 3 x 2.5 m rectangle frayed by up to
    10 cm becomes a rectangle (set on the floor less its fringe: between the inner and the
    outer edge of the fraying)."""
    rng = np.random.default_rng(1)
    ring = []
    for (x0, z0), (x1, z1) in zip([(0, 0), (3, 0), (3, 2.5), (0, 2.5)], [(3, 0), (3, 2.5), (0, 2.5), (0, 0)]):
        for f in np.linspace(0, 1, 20, endpoint=False):
            x, z = x0 + f * (x1 - x0), z0 + f * (z1 - z0)
            inward = np.array([-(z1 - z0), x1 - x0]) / np.hypot(x1 - x0, z1 - z0)
            ring.append(np.array([x, z]) + inward * 0.1 * rng.random() * (0.05 < f < 0.95))
    piece = Polygon(ring).buffer(0)
    shape = straighten(piece, None, PlanParams().open_room_fit_m, 0.2)
    assert (3 - 0.2) * (2.5 - 0.2) <= shape.area <= 7.5 + 1e-9
    assert len(shape.exterior.coords) == 5


def test_a_straightened_side_stands_in_the_middle_of_the_fringe():
    """Teeth of floor sticking out up to 20 cm past a 3 x 2.5 m room (the floor seen through a
    missing wall, under a bed) do not set its sides: each stands where the floor covers half
    of it, not on the outermost tooth (3.4 x 2.9 m)."""
    ring = []
    for (x0, z0), (x1, z1) in zip([(0, 0), (3, 0), (3, 2.5), (0, 2.5)], [(3, 0), (3, 2.5), (0, 2.5), (0, 0)]):
        outward = -np.array([-(z1 - z0), x1 - x0]) / np.hypot(x1 - x0, z1 - z0)
        for f in np.linspace(0, 1, 6, endpoint=False):
            a = np.array([x0 + f * (x1 - x0), z0 + f * (z1 - z0)])
            b = np.array([x0 + (f + 1 / 18) * (x1 - x0), z0 + (f + 1 / 18) * (z1 - z0)])
            ring += [a, a + 0.2 * outward, b + 0.2 * outward, b]  # a tooth over a third of each sixth
    piece = Polygon(ring).buffer(0)
    shape = straighten(piece, None, PlanParams().open_room_fit_m, 0.05)
    assert len(shape.exterior.coords) == 5
    assert 2.95 * 2.45 <= shape.area <= 3.1 * 2.6, shape.bounds


def test_a_floor_hidden_along_a_side_by_a_desk_is_straightened():
    """A 4 x 3 m room closed by its scanned floor, the floor hidden 0.6 m deep along 1.5 m of
    one side (a desk against a wall the scan missed): the room is its 4 x 3 m rectangle, the
    desk's depth within PlanParams.open_room_fit_m (at 0.3 m, before, the notch stayed)."""
    piece = shapely.box(0, 0, 4, 3).difference(shapely.box(1.0, 2.4, 2.5, 3.0))
    shape = straighten(piece, None, PlanParams().open_room_fit_m, 0.2)
    assert len(shape.exterior.coords) == 5
    assert shape.area == pytest.approx(12.0, abs=0.05)


def test_a_straightened_room_keeps_its_floor_up_to_an_oblique_wall():
    """A room whose floor was scanned up to a wall at 7.6 degrees to the plan's axes (from
    (0, 2.0) to (3, 2.4)): straightened, its side runs along the axis; the floor between that
    side and the wall stays the room's (straighten's ``hold``: the strip along the walls,
    rooms.wall_band), so that its outline holds to the wall (which the energy model pairs
    across)."""
    from meshplan.plan.rooms import wall_band

    piece = Polygon([(0, 0), (3, 0), (3, 2.4), (0, 2.0)])
    wall = LineString([(0, 2.0), (3, 2.4)])
    beyond = Polygon([(0, 2.0), (3, 2.4), (3, 5.0), (0, 5.0)])  # the next room, past the wall
    rect = straighten(piece, beyond, PlanParams().open_room_fit_m, 0.2)
    near_wall = shapely.Point(2.9, 2.33)  # floor 5 cm inside the wall, near its high end
    assert not rect.contains(near_wall)  # the axis rectangle stops short of the wall there
    shape = straighten(piece, beyond, PlanParams().open_room_fit_m, 0.2, hold=wall_band([wall]))
    assert shape.contains(near_wall)
    assert shape.difference(piece).area <= 1e-3  # nothing past the wall
    assert shape.area >= piece.area - 0.05  # the floor up to the wall, its corners' rounding aside


def test_a_fragment_smaller_than_a_closet_disappears():
    """A 1 m2 scrap of floor that no wall closes, on its own, is dropped; one touching a room
    is merged into it."""
    params = PlanParams()
    room = shapely.box(0, 0, 4, 3)
    alone = shapely.box(10, 10, 11, 11)
    out = _open_rooms([alone], [(room, "walls")], [room], params)
    assert len(out) == 1 and out[0][0].area == pytest.approx(12.0)
    touching = shapely.box(4, 1, 5, 2)
    out = _open_rooms([touching], [(room, "walls")], [room], params)
    assert len(out) == 1 and out[0][0].area == pytest.approx(13.0, abs=0.01)


def _bays(floor_along_run: bool):
    """A stair bay beside a corridor, 1.2 m wide each and 3.4 m long, open to a hall at z = 0
    (a wall line across) and ending at the edge of the scan at z = 3.4; the partition between
    them was scanned from z = 0 to 1.7 only (the stair hides the rest). Returns the walls, their
    spans after :func:`run_to_boundary` and the faces of the arrangement with the scan's edge."""
    from meshplan.plan.closure import run_to_boundary
    from meshplan.plan.rooms import FloorRaster

    walls = _walls(
        [
            ((0, 0), (2.4, 0), (0, 1)),  # the hall's wall line, across both bays
            ((0, 0), (0, 3.4), (1, 0)),
            ((2.4, 0), (2.4, 3.4), (-1, 0)),
            ((1.2, 0), (1.2, 1.7), (1, 0)),  # the partition, half seen
        ]
    )
    p = PlanParams()
    index = np.arange(4)
    lo, hi, bridges = close_walls(walls, index, p.corner_extension_m, p.wall_gap_m, p.collinear_wall_m)
    edge = shapely.box(-0.15, -0.15, 2.55, 3.55)  # the footprint's outline, a margin outside
    cell = 0.05
    grid = np.zeros((80, 60), dtype=bool)  # rows z from -0.5, columns x from -0.5
    if floor_along_run:
        grid[:, :] = True
    raster = FloorRaster(-0.5, -0.5, cell, grid)
    lo, hi = run_to_boundary(walls, index, lo, hi, edge, p.wall_gap_m, p.room_mouth_m, raster.segment_share)
    lines = [LineString([lo[k] * walls.tangent[k] + walls.offset[k] * walls.normal[k], hi[k] * walls.tangent[k] + walls.offset[k] * walls.normal[k]]) for k in index]
    merged = shapely.union_all(lines + bridges + [edge.exterior])
    faces = [f for f in shapely.get_parts(shapely.polygonize(shapely.get_parts(shapely.node(merged)))) if f.area > 0.5]
    return lo, hi, faces


def test_a_partition_half_hidden_by_a_stair_divides_its_two_bays():
    """The partition's free end runs on the 1.85 m to the edge of the scan (more than a door,
    less than ``room_mouth_m``; a third of it scanned; no floor seen where it would stand):
    the stair and the corridor are two rooms of about 4.1 m2 each, not one U of 8.2 m2."""
    lo, hi, faces = _bays(floor_along_run=False)
    assert hi[3] == pytest.approx(3.55, abs=0.01)
    inside = sorted(f.intersection(shapely.box(0, 0, 2.4, 3.4)).area for f in faces)
    assert inside[-2:] == pytest.approx([4.08, 4.08], abs=0.05)


def test_a_partition_does_not_run_over_floor_seen_where_it_would_stand():
    """The same bays with the floor scanned along the partition's line: the partition is seen to
    stop, so the bays stay one space."""
    lo, hi, faces = _bays(floor_along_run=True)
    assert hi[3] == pytest.approx(1.7)
    inside = sorted(f.intersection(shapely.box(0, 0, 2.4, 3.4)).area for f in faces)
    assert inside[-1] == pytest.approx(8.16, abs=0.05)


def test_a_short_wall_piece_does_not_run_across_a_room():
    """A 0.5 m piece (a jamb, a counter's end) 2 m from the edge of the scan implies no
    partition: it is less than a third of the length it would have."""
    from meshplan.plan.closure import run_to_boundary

    walls = _walls([((0, 0), (0, 0.5), (1, 0))])
    p = PlanParams()
    lo, hi = run_to_boundary(walls, np.arange(1), walls.u_min.copy(), walls.u_max.copy(), shapely.box(-3, -3, 3, 2.5), p.wall_gap_m, p.room_mouth_m)
    assert (lo[0], hi[0]) == pytest.approx((0.0, 0.5))


def test_a_room_whose_floor_was_not_scanned_counts_when_walls_enclose_it():
    """A 1.2 x 3 m bay (a stair: its treads stand above the floor level) walled on three sides
    and seen throughout is a room; with one wall only, or where nothing was seen, it is not."""
    from shapely.geometry import MultiLineString

    from meshplan.plan.rooms import FloorRaster, _classify

    bay = shapely.box(0, 0, 1.2, 3.0)
    no_floor = FloorRaster(-1.0, -1.0, 0.05, np.zeros((100, 60), dtype=bool))
    seen = FloorRaster(-1.0, -1.0, 0.05, np.ones((100, 60), dtype=bool))
    three = MultiLineString([[(0, 0), (1.2, 0)], [(0, 0), (0, 3)], [(1.2, 0), (1.2, 3)]])
    one = MultiLineString([[(0, 0), (0, 3)]])
    params = PlanParams()
    assert _classify(bay, no_floor, three, three, params, seen) is not None
    assert _classify(bay, no_floor, one, one, params, seen) is None
    assert _classify(bay, no_floor, three, three, params, no_floor) is None
    assert _classify(bay, no_floor, three, three, params) is None


# --- rooms carried up to the walls their floor stops short of (issue 9 item 3) ---------------


def _reach(room, wall, normal, beyond=None, others=()):
    walls = [LineString(wall), *[LineString(o) for o, _ in others]]
    normals = np.array([normal, *[n for _, n in others]], dtype=float)
    return reach_walls(room, walls, normals, beyond, PlanParams().wall_reach_m)


def test_a_room_is_carried_up_to_the_wall_its_floor_stops_short_of():
    """A 4 x 3 m room whose floor was seen only up to 0.4 m from its south wall (furniture
    along it): the room reaches the wall, over the stretch the floor ran along it."""
    floor = shapely.box(0.0, 0.0, 4.0, 2.6)
    grown = _reach(floor, [(0.0, 3.0), (4.0, 3.0)], (0.0, -1.0))  # the face looks north, at the room
    assert grown.area == pytest.approx(12.0, abs=1e-6)
    assert grown.bounds == pytest.approx((0.0, 0.0, 4.0, 3.0))


def test_a_room_carried_up_to_two_walls_is_carried_into_their_corner():
    """A 4 x 3 m room whose floor was not seen in its south-east corner (a wardrobe in it,
    1.0 x 0.9 m): carried up to the south and the east wall, it fills the corner they meet in.
    Not when a wall line crosses the corner, when the walls' lines do not meet there, or when
    the floor stops more than twice wall_reach_m short of the corner (a notch, not furniture)."""
    south = ([(0.0, 3.0), (4.0, 3.0)], (0.0, -1.0))
    east = ([(4.0, 0.0), (4.0, 3.0)], (-1.0, 0.0))
    floor = shapely.box(0.0, 0.0, 4.0, 3.0).difference(shapely.box(3.0, 2.1, 4.0, 3.0))
    assert _reach(floor, *south, others=[east]).area == pytest.approx(12.0, abs=1e-6)
    assert _reach(floor, *east, others=[south]).area == pytest.approx(12.0, abs=1e-6)  # either order
    # a partition across the corner (its line crosses the corner's rectangle)
    partition = ([(3.5, 2.4), (3.5, 3.0)], (1.0, 0.0))
    assert _reach(floor, *south, others=[east, partition]).area == pytest.approx(floor.area, abs=1e-6)
    # the east wall scanned (or continued) only to 0.5 m short of the corner: no corner
    short = ([(4.0, 0.0), (4.0, 2.5)], (-1.0, 0.0))
    assert _reach(floor, *south, others=[short]).area == pytest.approx(floor.area, abs=1e-6)
    # a notch 2 m along each wall is part of the room's shape
    notch = shapely.box(0.0, 0.0, 4.0, 3.0).difference(shapely.box(2.0, 1.0, 4.0, 3.0))
    assert _reach(notch, *south, others=[east]).area == pytest.approx(notch.area, abs=1e-6)
    # the same two bands, 1 m short of the corner of the walls along each: the corner is filled
    # when it is the room's own, not when the room wraps round the outside of it (an L-shaped
    # room round a notch: the corner's inside lies behind both faces)
    lines = [LineString([(4.0, 2.0), (4.0, 0.0)]), LineString([(6.0, 2.0), (4.0, 2.0)])]
    reached = {0: (1.0, 2.0, 2.0), 1: (0.0, 1.0, 2.0)}  # each band 1 m short of (4, 2)
    inside = _corner_fills(lines, np.array([(1.0, 0.0), (0.0, -1.0)]), reached, 1.6)  # a room in the notch
    assert len(inside) == 1 and inside[0][2].area == pytest.approx(1.0) and inside[0][2].contains(shapely.Point(4.5, 1.5))
    assert _corner_fills(lines, np.array([(-1.0, 0.0), (0.0, 1.0)]), reached, 1.6) == []  # the L round it


def test_a_room_is_not_carried_through_a_wall_or_into_another_room():
    """The face of a wall seen from the next room lies behind the wall's thickness: a room
    whose own face was not scanned stops where its floor does. Nor is a room carried across a
    partition, into another room, or farther than wall_reach_m."""
    floor = shapely.box(0.0, 0.0, 4.0, 2.6)
    wall = [(0.0, 3.0), (4.0, 3.0)]
    # the face looks south, away from the room: the next room's face of the wall
    assert _reach(floor, wall, (0.0, 1.0)).area == pytest.approx(floor.area)
    # a partition across the band
    partition = ([(2.0, 2.4), (2.0, 3.0)], (1.0, 0.0))
    assert _reach(floor, wall, (0.0, -1.0), others=[partition]).area == pytest.approx(floor.area)
    # another room in the band takes its part of it
    other = shapely.box(3.0, 2.6, 4.0, 3.0)
    assert _reach(floor, wall, (0.0, -1.0), beyond=other).area == pytest.approx(12.0 - 0.4, abs=1e-6)
    # a floor that runs 20 cm past the line of a wall whose face looks away from the room (the
    # far face of its wall) is not carried on beyond it
    crossing = shapely.box(0.0, 0.0, 4.0, 3.2)
    assert _reach(crossing, wall, (0.0, 1.0)).area == pytest.approx(crossing.area)
    # a wall farther than wall_reach_m
    far = [(0.0, 3.5), (4.0, 3.5)]
    assert _reach(floor, far, (0.0, -1.0)).area == pytest.approx(floor.area)

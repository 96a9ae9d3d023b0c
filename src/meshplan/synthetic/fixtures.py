"""Fixtures that real scans show and plain furniture lacks: kitchens, built-ins and door leaves.

* Kitchens (:func:`place_fixtures` with ``kitchen``): a run of base units with a worktop along
  one wall, wall cabinets above it and a free-standing island.
* Built-ins (``built_ins``): wardrobes (2.0-2.2 m high, often wall to wall) and desks, flush
  against a wall. A wardrobe front is a flat vertical surface 2 m high and 0.6 m in front of a
  wall: it is furniture, never a truth wall.
* Door leaves (:func:`place_leaves`): a 4 cm leaf in every door, hinged at a jamb on one face of
  the wall and opened 0-110 degrees into the room on that side (0: closed, flush with the wall).

All of them are :class:`~meshplan.synthetic.furniture.Item` (or :class:`Leaf`) made of boxes, in
the truth frame, placed with the same keep-out rules as the furniture (doors, windows, sensors).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from shapely.geometry import Polygon

from ..geometry import FloatArray
from .annotate import Marker
from .furniture import Item, _footprint, _frame, _world_boxes, keep_out_zones
from .layout import Building, Opening
from .tessellate import Box

#: Height of a kitchen worktop above the floor (the European standard 0.9 m).
COUNTER_HEIGHT_M = 0.9
#: Depth of base units and worktop from the wall (standard 0.6 m).
COUNTER_DEPTH_M = 0.6
#: Thickness of a worktop.
WORKTOP_M = 0.04
#: Length of a run of base units along its wall.
COUNTER_LENGTH_M = (2.4, 3.6)
#: Shortest run worth building.
MIN_COUNTER_M = 1.8
#: Wall cabinets: from 1.4 m (0.5 m over the worktop) to 2.1 m, 0.35 m deep.
UPPER_BOTTOM_M, UPPER_TOP_M, UPPER_DEPTH_M = 1.4, 2.1, 0.35
#: Shortest run of wall cabinets (one unit).
MIN_UPPER_M = 0.4
#: Island: length, depth; the same height as the worktop.
ISLAND_LENGTH_M, ISLAND_DEPTH_M = (1.2, 2.0), (0.8, 1.0)
#: Clear floor between the island and the counter (a working aisle), other walls and doors.
AISLE_M, ISLAND_WALL_M, ISLAND_DOOR_M = 0.9, 0.8, 0.9
#: Wardrobes: height and depth (standard built-in wardrobes), width when not wall to wall.
WARDROBE_HEIGHT_M, WARDROBE_DEPTH_M, WARDROBE_WIDTH_M = (2.0, 2.2), 0.6, (1.0, 2.4)
#: Longest wall a wardrobe fills from corner to corner.
WALL_TO_WALL_M = 3.6
#: Desks: top height (standard 0.75 m), length, depth; panel thickness.
DESK_HEIGHT_M, DESK_LENGTH_M, DESK_DEPTH_M, PANEL_M = 0.75, (1.2, 1.6), (0.6, 0.8), 0.025
#: How far a flush fixture stands off its wall (scribed to it: 0-3 mm).
FLUSH_GAP_M = (0.0, 0.003)
#: Door leaves: thickness, gap under the leaf, largest opening angle (degrees).
LEAF_M, LEAF_UNDERCUT_M, LEAF_MAX_DEG = 0.04, 0.01, 110.0
#: Angle by which a leaf that hits something is closed, step after step (degrees).
LEAF_STEP_DEG = 10.0

_UP = np.array([0.0, 1.0, 0.0])
_WARDROBE_ROOMS = ("bedroom", "hall", "office")
_DESK_ROOMS = ("bedroom", "study", "office")
_KITCHEN_ROOMS = ("kitchen", "living", "room", "meeting")  # the first kind a story has


@dataclass(frozen=True, eq=False)
class Leaf:
    """The leaf of a door: one box, hinged at a jamb."""

    label: str  # the door's label
    room: int  # the room it opens into, -1 outside the building
    box: Box
    footprint: FloatArray  # (4, 2)
    angle_deg: float  # 0 closed, 90 against the wall's normal
    swing: str  # "inside" (into the room of the door's primary wall face) or "outside"
    hinge: FloatArray  # (2,) plan point of the hinge axis
    width_m: float
    thickness_m: float


def _right_corner(b: Building, wi: int, at_start: bool) -> bool:
    """The room's corner at the start (or end) of wall ``wi`` is a right-angled inside corner."""
    ids = b.room_walls(b.walls[wi].room)
    k = ids.index(wi)
    w = b.walls[wi]
    nb = b.walls[ids[k - 1]] if at_start else b.walls[ids[(k + 1) % len(ids)]]
    convex = w.convex_start if at_start else w.convex_end
    return bool(convex and abs(float(np.dot(w.direction, nb.direction))) < 1e-6)


def _side_faces(b: Building, wi: int, u0: float, u1: float, front: str) -> str:
    """Faces of a fixture from ``u0`` to ``u1`` along wall ``wi``: ``front`` plus the sides that
    do not touch a wall at a right-angled inside corner."""
    w = b.walls[wi]
    faces = front
    if not (u0 < 0.02 and _right_corner(b, wi, True)):
        faces += " +x"  # the item's +x side faces the wall's start (see _frame)
    if not (u1 > w.length - 0.02 and _right_corner(b, wi, False)):
        faces += " -x"
    return faces


def _zone_of(b: Building, o: Opening, pad: float, depth: float) -> Polygon:
    """The floor in front of opening ``o``, ``pad`` wider on each side, ``depth`` deep."""
    w = b.walls[o.wall]
    p0, p1 = w.point(o.u_m - o.width_m / 2 - pad), w.point(o.u_m + o.width_m / 2 + pad)
    return Polygon([p0, p1, p1 + depth * w.normal, p0 + depth * w.normal])


def _stretches(b: Building, wi: int, depth: float, zones: list[Polygon]) -> list[tuple[float, float]]:
    """Stretches of wall ``wi`` with nothing of ``zones`` within ``depth`` in front of it."""
    w = b.walls[wi]
    strip = Polygon([w.start, w.end, w.end + depth * w.normal, w.start + depth * w.normal])
    occupied = []
    for z in zones:
        if strip.intersection(z).area > 1e-9:
            us = [w.u_of(np.array(p)) for p in np.asarray(z.exterior.coords)]
            occupied.append((min(us), max(us)))
    free = [(0.0, w.length)]
    for a, c in occupied:
        nxt = []
        for f0, f1 in free:
            if c <= f0 or a >= f1:
                nxt.append((f0, f1))
                continue
            if a > f0:
                nxt.append((f0, a))
            if c < f1:
                nxt.append((c, f1))
        free = nxt
    return [(a, c) for a, c in free if c - a > 1e-6]


def _against(b: Building, wi: int, u0: float, u1: float, gap: float) -> tuple[FloatArray, FloatArray]:
    """Frame and origin of an item whose back runs from ``u0`` to ``u1`` along wall ``wi``,
    ``gap`` in front of it (local x across, z out of the wall, origin at the back's middle)."""
    w = b.walls[wi]
    p = w.point(0.5 * (u0 + u1)) + gap * w.normal
    floor = b.stories[w.story][0]
    return _frame(w.normal), np.array([p[0], floor, p[1]])


def place_fixtures(b: Building, markers: list[Marker], rng: np.random.Generator, kitchen: bool, built_ins: bool) -> list[Item]:
    """Kitchens (one per story) and built-in wardrobes and desks.

    Parameters
    ----------
    b
        The building.
    markers
        Annotated objects: tall fixtures keep clear of the wall-mounted ones.
    rng
        The fixtures' random generator.
    kitchen, built_ins
        What to build.

    Returns
    -------
    The fixtures, as furniture items marked ``built_in``.
    """
    always, tall = keep_out_zones(b, markers)
    rooms = {r: Polygon(room.polygon).buffer(1e-6, join_style="mitre") for r, room in enumerate(b.rooms)}
    placed: dict[int, list[Polygon]] = {r: [] for r in range(len(b.rooms))}
    counts: dict[tuple[int, str], int] = {}
    items: list[Item] = []

    def add(r: int, kind: str, boxes: tuple[Box, ...], fp: FloatArray, top: float, bottom: float = 0.0) -> None:
        counts[(r, kind)] = counts.get((r, kind), 0) + 1
        name = f"{b.rooms[r].label}_{kind}{counts[(r, kind)]}"
        items.append(Item(b.rooms[r].story, r, name, kind, boxes, fp, float(top), False, float(bottom), True))
        placed[r].append(Polygon(fp))

    def wall_item(r: int, kind: str, length: tuple[float, float], depth: float, tall_item: bool, full_wall: bool = False):
        """A stretch along one of the room's walls for an item of ``length`` (or the whole wall)
        and ``depth``: (wall, u0, u1), or None."""
        zones = always[r] + (tall[r] if tall_item else []) + [p.buffer(0.05) for p in placed[r]]
        options = []
        for wi in b.room_walls(r):
            for a, c in _stretches(b, wi, depth + 0.05, zones):
                if c - a >= length[0]:
                    options.append((wi, a, c))
        if not options:
            return None
        spans = np.array([c - a for _, a, c in options])
        for _ in range(12):
            wi, a, c = options[int(rng.choice(len(options), p=spans / spans.sum()))]
            w = b.walls[wi]
            whole = full_wall and a < 1e-6 and c > w.length - 1e-6 and w.length <= WALL_TO_WALL_M and rng.random() < 0.5
            if whole:
                u0, u1 = 0.0, w.length
            else:
                n = float(rng.uniform(length[0], min(length[1], c - a)))
                if rng.random() < 0.5:  # from one end of the stretch (a corner or a door zone)
                    u0, u1 = a, a + n
                else:
                    u0, u1 = c - n, c
            for _shrink in range(8):  # away from a neighbouring wall at an acute corner
                frame, origin = _against(b, wi, u0, u1, 0.0)
                fp = _footprint(frame, origin, -(u1 - u0) / 2, (u1 - u0) / 2, 0.0, depth)
                if rooms[r].contains(Polygon(fp)):
                    return wi, u0, u1
                at0, at1 = u0 < 0.5, u1 > w.length - 0.5
                if not (at0 or at1):
                    break
                u0, u1 = u0 + 0.1 * at0, u1 - 0.1 * at1
                if u1 - u0 < length[0]:
                    break
        return None

    def build(r: int, kind: str, wi: int, u0: float, u1: float, local: list, top: float, bottom: float = 0.0) -> FloatArray:
        gap = float(rng.uniform(*FLUSH_GAP_M))
        frame, origin = _against(b, wi, u0, u1, gap)
        depth = max(bx[5] for bx in local)
        fp = _footprint(frame, origin, -(u1 - u0) / 2, (u1 - u0) / 2, 0.0, depth)
        add(r, kind, _world_boxes(local, frame, origin), fp, top, bottom)
        return frame

    if kitchen:
        # base units may stand under a window whose sill clears the worktop; wall cabinets keep
        # clear of every window and wall-mounted sensor
        low_windows: dict[int, list[Polygon]] = {r: [] for r in range(len(b.rooms))}
        for o in b.openings:
            if o.kind == "window" and o.bottom - b.stories[o.story][0] < COUNTER_HEIGHT_M + 0.05:
                low_windows[b.walls[o.wall].room].append(_zone_of(b, o, 0.1, 0.6))
        for s in range(len(b.stories)):
            story_rooms = [r for r, room in enumerate(b.rooms) if room.story == s]
            order = [r for k in _KITCHEN_ROOMS for r in story_rooms if b.rooms[r].kind == k]
            for r in order:
                # a wall free for the wall cabinets too, else one with a window over the worktop
                got = wall_item(r, "counter", (MIN_COUNTER_M, COUNTER_LENGTH_M[1]), COUNTER_DEPTH_M, True)
                if got is None:
                    saved = tall[r]
                    tall[r] = low_windows[r]
                    got = wall_item(r, "counter", (MIN_COUNTER_M, COUNTER_LENGTH_M[1]), COUNTER_DEPTH_M, True)
                    tall[r] = saved
                if got is None:
                    continue
                wi, u0, u1 = got
                half = (u1 - u0) / 2
                base = _side_faces(b, wi, u0, u1, "+z")
                top_faces = _side_faces(b, wi, u0, u1, "+y +z")
                counter = [
                    (-half, half, 0.0, COUNTER_HEIGHT_M - WORKTOP_M, 0.0, COUNTER_DEPTH_M - 0.02, base),
                    (-half, half, COUNTER_HEIGHT_M - WORKTOP_M, COUNTER_HEIGHT_M, 0.0, COUNTER_DEPTH_M, top_faces),
                ]
                frame = build(r, "counter", wi, u0, u1, counter, COUNTER_HEIGHT_M)
                for a, c in _stretches(b, wi, UPPER_DEPTH_M + 0.05, tall[r]):
                    a, c = max(a, u0), min(c, u1)
                    if c - a >= MIN_UPPER_M:
                        h = (c - a) / 2
                        upper = [(-h, h, UPPER_BOTTOM_M, UPPER_TOP_M, 0.0, UPPER_DEPTH_M, _side_faces(b, wi, a, c, "-y +y +z"))]
                        build(r, "upper_cabinet", wi, a, c, upper, UPPER_TOP_M, UPPER_BOTTOM_M)
                doors = [_zone_of(b, o, 0.1, ISLAND_DOOR_M) for o in b.openings if o.kind == "door" and b.walls[o.wall].room == r]
                _island(b, r, frame, placed, doors, rng, add)
                break

    if built_ins:
        for r, room in enumerate(b.rooms):
            if room.kind in _WARDROBE_ROOMS:
                height = float(rng.uniform(*WARDROBE_HEIGHT_M))
                got = wall_item(r, "wardrobe", WARDROBE_WIDTH_M, WARDROBE_DEPTH_M, True, full_wall=True)
                if got is not None:
                    wi, u0, u1 = got
                    half = (u1 - u0) / 2
                    local = [(-half, half, 0.0, height, 0.0, WARDROBE_DEPTH_M, _side_faces(b, wi, u0, u1, "+y +z"))]
                    build(r, "wardrobe", wi, u0, u1, local, height)
            if room.kind in _DESK_ROOMS:
                depth = float(rng.uniform(*DESK_DEPTH_M))
                got = wall_item(r, "desk", DESK_LENGTH_M, depth, False)
                if got is not None:
                    wi, u0, u1 = got
                    h = (u1 - u0) / 2
                    t, y1 = PANEL_M, DESK_HEIGHT_M - 0.03
                    local = [
                        (-h, h, y1, DESK_HEIGHT_M, 0.0, depth, "+x -x +y +z -y"),
                        (-h, -h + t, 0.0, y1, 0.0, depth, "+x -x +z"),
                        (h - t, h, 0.0, y1, 0.0, depth, "+x -x +z"),
                        (-h + t, h - t, 0.35, y1, 0.0, 0.02, "+z"),  # modesty panel
                    ]
                    build(r, "desk", wi, u0, u1, local, DESK_HEIGHT_M)
    return items


def _island(b: Building, r: int, frame: FloatArray, placed: dict, zones: list[Polygon], rng: np.random.Generator, add) -> bool:
    """A free-standing island parallel to the counter, an aisle in front of it."""
    room = b.rooms[r]
    floor = b.stories[room.story][0]
    clear = Polygon(room.polygon).buffer(-ISLAND_WALL_M, join_style="mitre")
    if clear.is_empty:
        return False
    length, depth = float(rng.uniform(*ISLAND_LENGTH_M)), float(rng.uniform(*ISLAND_DEPTH_M))
    lo, hi = room.polygon.min(axis=0), room.polygon.max(axis=0)
    for k in range(60):
        if k == 30:  # the smallest island, if a bigger one does not fit
            length, depth = ISLAND_LENGTH_M[0], ISLAND_DEPTH_M[0]
        c = rng.uniform(lo, hi)
        origin = np.array([c[0], floor, c[1]]) - frame @ np.array([0.0, 0.0, depth / 2])
        fp = _footprint(frame, origin, -length / 2, length / 2, 0.0, depth)
        poly = Polygon(fp)
        if not clear.contains(poly) or any(poly.intersects(z) for z in zones):
            continue
        if any(poly.distance(p) < AISLE_M for p in placed[r]):
            continue
        h, o = length / 2, 0.03  # the worktop overhangs the units by 3 cm
        local = [
            (-h + o, h - o, 0.0, COUNTER_HEIGHT_M - WORKTOP_M, o, depth - o, "+x -x +z -z"),
            (-h, h, COUNTER_HEIGHT_M - WORKTOP_M, COUNTER_HEIGHT_M, 0.0, depth, "+x -x +y +z -z"),
        ]
        add(r, "island", _world_boxes(local, frame, origin), fp, COUNTER_HEIGHT_M)
        return True
    return False


def _leaf_geometry(b: Building, o: Opening, swing: str, left: bool, angle_deg: float) -> tuple[Box, FloatArray, FloatArray]:
    """Box, footprint and hinge of the leaf of door ``o``."""
    w = b.walls[o.wall]
    s = w.normal if swing == "inside" else -w.normal
    offset = 0.0 if swing == "inside" else o.depth_m
    a_h = w.direction if left else -w.direction  # from the hinge across the opening
    hinge = w.point(o.u_m - o.width_m / 2 if left else o.u_m + o.width_m / 2) - offset * w.normal
    th = np.radians(angle_deg)
    d = np.cos(th) * a_h + np.sin(th) * s  # along the leaf
    p = -np.cos(th) * s + np.sin(th) * a_h  # across it, away from the hinge side's jamb face
    width, t = o.width_m, LEAF_M
    bottom, top = o.bottom + LEAF_UNDERCUT_M, o.top - 0.005
    fp = np.array([hinge, hinge + width * d, hinge + width * d + t * p, hinge + t * p])
    x3 = np.array([d[0], 0.0, d[1]])
    z3 = np.cross(x3, _UP)
    c2 = hinge + 0.5 * width * d + 0.5 * t * p
    box = Box(np.array([c2[0], 0.5 * (bottom + top), c2[1]]), np.array([width / 2, (top - bottom) / 2, t / 2]),
              np.stack([x3, _UP, z3], axis=1), "+x -x +z -z")
    return box, fp, hinge


def place_leaves(b: Building, items: list[Item], rng: np.random.Generator) -> list[Leaf]:
    """A leaf in every door, opened a random 0-110 degrees to a random side and closed step by
    step until it hits nothing (walls, furniture, other leaves).

    Parameters
    ----------
    b
        The building.
    items
        Furniture and fixtures, already placed.
    rng
        The leaves' random generator.
    """
    rooms = [Polygon(room.polygon).buffer(1e-6, join_style="mitre") for room in b.rooms]
    outside = Polygon(b.footprint)
    obstacles: dict[int, list[Polygon]] = {r: [] for r in range(-1, len(b.rooms))}
    for it in items:
        obstacles[it.room].append(Polygon(it.footprint).buffer(0.02))
    leaves: list[Leaf] = []
    for o in b.openings:
        if o.kind != "door" or not o.primary:
            continue
        w = b.walls[o.wall]
        other = next((q for q in b.openings if q.label == o.label and not q.primary), None)
        swing = "inside" if rng.random() < 0.5 else "outside"
        left = bool(rng.random() < 0.5)
        angle = float(rng.uniform(0.0, LEAF_MAX_DEG))
        room = w.room if swing == "inside" else (b.walls[other.wall].room if other is not None else -1)
        p0, p1 = w.point(o.u_m - o.width_m / 2), w.point(o.u_m + o.width_m / 2)
        hole = Polygon([p0 + 0.01 * w.normal, p1 + 0.01 * w.normal, p1 - (o.depth_m + 0.01) * w.normal, p0 - (o.depth_m + 0.01) * w.normal])
        while True:
            box, fp, hinge = _leaf_geometry(b, o, swing, left, angle)
            rest = Polygon(fp).difference(hole)
            if room >= 0:
                ok = rest.is_empty or rooms[room].contains(rest)
            else:
                ok = rest.is_empty or rest.intersection(outside).area < 1e-8
            ok = ok and not any(Polygon(fp).intersects(q) for q in obstacles[room])
            if ok or angle <= 0.0:
                break
            angle = max(0.0, angle - LEAF_STEP_DEG)
        leaf = Leaf(o.label, room, box, fp, angle, swing, hinge, o.width_m, LEAF_M)
        leaves.append(leaf)
        obstacles[room].append(Polygon(fp).buffer(0.02))
    return leaves


def item_bounds(boxes: tuple[Box, ...]) -> Box:
    """The smallest box in the frame of ``boxes[0]`` holding all of ``boxes`` (what a parametric
    capture reports for a piece of furniture)."""
    r = np.asarray(boxes[0].rotation, dtype=np.float64)
    corners = []
    signs = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], dtype=np.float64)
    for bx in boxes:
        pts = np.asarray(bx.center) + (signs * np.asarray(bx.half)) @ np.asarray(bx.rotation).T
        corners.append(pts @ r)  # in the frame of the first box
    c = np.concatenate(corners)
    lo, hi = c.min(axis=0), c.max(axis=0)
    return Box(r @ (0.5 * (lo + hi)), 0.5 * (hi - lo), r, "+x -x +y -y +z -z")


__all__ = ["Leaf", "item_bounds", "place_fixtures", "place_leaves"]

"""Furniture: desks, tables, beds, sofas, cabinets, chairs, shelves and a leaning board.

Items are unions of boxes built in a local frame (x across the item, y up from the floor, z from
its back at 0 towards its front) and then stood against a wall (back to the wall, parallel to
it) or free in the room at a random yaw. An item must fit inside its room, keep clear of the
doors, the stairs, the other items and (when tall) of the windows and wall-mounted sensors, and
stay below 2 m so that it never looks like a floor-to-ceiling wall. Only visible faces are
scanned: no bottoms, no backs against a wall.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import Polygon

from ..geometry import FloatArray
from .annotate import Marker
from .layout import Building
from .tessellate import Box

#: No item is taller than this (m): anything taller could pass for a wall.
MAX_HEIGHT_M = 2.0

_ALL = "+x -x +y +z -z"
_NO_BACK = "+x -x +y +z"

# A local box: (x0, x1, y0, y1, z0, z1, faces)
_LBox = tuple[float, float, float, float, float, float, str]


@dataclass(frozen=True, eq=False)
class Item:
    """A furniture item (one face group of the scan)."""

    story: int
    room: int
    name: str
    kind: str
    boxes: tuple[Box, ...]
    footprint: FloatArray  # (4, 2) [x, z]
    height_m: float  # top above the floor
    tilted: bool
    bottom_m: float = 0.0  # lowest point above the floor (wall cabinets)
    built_in: bool = False  # a fixture flush against a wall (kitchen, wardrobe, desk)


def _legs(w: float, d: float, h: float, t: float, inset: float, z0: float = 0.0) -> list[_LBox]:
    xs = (-w / 2 + inset, w / 2 - inset - t)
    zs = (z0 + inset, z0 + d - inset - t)
    return [(x, x + t, 0.0, h, z, z + t, "+x -x +z -z") for x in xs for z in zs]


def _table(rng, w: float, d: float) -> list[_LBox]:
    top, th = rng.uniform(0.72, 0.76), rng.uniform(0.025, 0.04)
    return [(-w / 2, w / 2, top - th, top, 0.0, d, _ALL)] + _legs(w, d, top - th, rng.uniform(0.04, 0.06), 0.04)


def desk(rng):
    return _table(rng, rng.uniform(1.2, 1.6), rng.uniform(0.6, 0.8))


def dining_table(rng):
    return _table(rng, rng.uniform(1.2, 2.0), rng.uniform(0.8, 1.0))


def meeting_table(rng):
    return _table(rng, rng.uniform(2.4, 3.6), rng.uniform(1.0, 1.3))


def chair(rng):
    s, h = rng.uniform(0.42, 0.48), rng.uniform(0.42, 0.48)
    back = h + rng.uniform(0.35, 0.45)
    return [(-s / 2, s / 2, h - 0.04, h, 0.0, s, _ALL), (-s / 2, s / 2, h, back, 0.0, 0.03, _ALL)] + _legs(s, s, h - 0.04, 0.03, 0.01)


def bed(rng):
    w = rng.uniform(0.9, 1.0) if rng.random() < 0.4 else rng.uniform(1.4, 1.8)
    length, h = rng.uniform(1.95, 2.1), rng.uniform(0.45, 0.6)
    head = rng.uniform(0.9, 1.1)
    return [(-w / 2, w / 2, 0.0, h, 0.05, length, "+x -x +y +z"), (-w / 2 - 0.02, w / 2 + 0.02, 0.0, head, 0.0, 0.05, _NO_BACK)]


def sofa(rng):
    length, d = rng.uniform(1.6, 2.4), rng.uniform(0.8, 0.95)
    seat, bt, bh = rng.uniform(0.4, 0.45), rng.uniform(0.15, 0.22), rng.uniform(0.75, 0.9)
    aw, ah = rng.uniform(0.12, 0.2), rng.uniform(0.55, 0.65)
    x0, x1 = -length / 2, length / 2
    return [
        (x0 + aw, x1 - aw, 0.0, seat, bt, d, "+y +z"),
        (x0, x1, 0.0, bh, 0.0, bt, _NO_BACK),
        (x0, x0 + aw, 0.0, ah, bt, d, "+x -x +y +z"),
        (x1 - aw, x1, 0.0, ah, bt, d, "+x -x +y +z"),
    ]


def _block(w: tuple[float, float], d: tuple[float, float], h: tuple[float, float]):
    def make(rng):
        ww, dd, hh = rng.uniform(*w), rng.uniform(*d), rng.uniform(*h)
        return [(-ww / 2, ww / 2, 0.0, hh, 0.0, dd, _NO_BACK)]

    return make


wardrobe = _block((0.8, 2.0), (0.5, 0.6), (1.8, 2.0))
cabinet = _block((0.8, 1.6), (0.4, 0.5), (0.8, 1.2))
counter = _block((1.8, 3.0), (0.58, 0.62), (0.88, 0.92))
fridge = _block((0.55, 0.7), (0.6, 0.7), (1.7, 1.95))
bathtub = _block((1.6, 1.8), (0.7, 0.8), (0.5, 0.6))
vanity = _block((0.6, 1.0), (0.45, 0.55), (0.8, 0.9))


def shelf(rng):
    w, d, h, t = rng.uniform(0.6, 1.2), rng.uniform(0.28, 0.38), rng.uniform(1.2, 2.0), 0.02
    out = [(-w / 2, -w / 2 + t, 0.0, h, 0.0, d, _NO_BACK), (w / 2 - t, w / 2, 0.0, h, 0.0, d, _NO_BACK)]
    out.append((-w / 2 + t, w / 2 - t, 0.0, h, 0.0, 0.01, "+z"))  # back panel
    n = max(2, int(h / 0.35))
    for k in range(n + 1):
        y = 0.08 + k * (h - 0.08) / n
        out.append((-w / 2 + t, w / 2 - t, y - t, y, 0.01, d, "+y +z"))
    return out


def toilet(rng):
    return [(-0.19, 0.19, 0.0, 0.4, 0.18, 0.68, "+x -x +y +z"), (-0.19, 0.19, 0.0, 0.8, 0.0, 0.18, _NO_BACK)]


# kind -> list of (name, factory, free-standing?, weight); the first entry is placed first
_Entry = tuple[str, Callable, bool, float]
CATALOG: dict[str, list[_Entry]] = {
    "living": [
        ("sofa", sofa, False, 1), ("table", dining_table, True, 1), ("chair", chair, True, 2),
        ("shelf", shelf, False, 1), ("cabinet", cabinet, False, 1),
    ],
    "kitchen": [
        ("counter", counter, False, 1), ("fridge", fridge, False, 1), ("table", dining_table, True, 1),
        ("chair", chair, True, 2), ("cabinet", cabinet, False, 1),
    ],
    "bedroom": [
        ("bed", bed, False, 1), ("wardrobe", wardrobe, False, 1), ("desk", desk, False, 1),
        ("chair", chair, True, 1), ("shelf", shelf, False, 1),
    ],
    "bath": [("bathtub", bathtub, False, 1), ("vanity", vanity, False, 1), ("toilet", toilet, False, 1), ("cabinet", cabinet, False, 0.5)],
    "hall": [("cabinet", cabinet, False, 1), ("shelf", shelf, False, 1), ("wardrobe", wardrobe, False, 1)],
    "corridor": [("cabinet", cabinet, False, 1), ("shelf", shelf, False, 1)],
    "study": [("desk", desk, False, 1), ("chair", chair, True, 1), ("shelf", shelf, False, 1), ("cabinet", cabinet, False, 1)],
    "office": [
        ("desk", desk, False, 1), ("chair", chair, True, 1), ("cabinet", cabinet, False, 1),
        ("shelf", shelf, False, 1), ("desk", desk, False, 0.5),
    ],
    "meeting": [("table", meeting_table, True, 1), ("chair", chair, True, 3), ("cabinet", cabinet, False, 1)],
    "stairwell": [("cabinet", cabinet, False, 1), ("shelf", shelf, False, 1)],
    "room": [
        ("table", dining_table, True, 1), ("chair", chair, True, 2), ("shelf", shelf, False, 1),
        ("sofa", sofa, False, 1), ("cabinet", cabinet, False, 1), ("desk", desk, False, 1),
    ],
}
_SMALL_ROOMS = ("hall", "corridor", "stairwell", "bath")


def _extent(boxes: list[_LBox]) -> tuple[float, float, float, float, float]:
    a = np.array([b[:6] for b in boxes], dtype=np.float64)
    return a[:, 0].min(), a[:, 1].max(), a[:, 4].min(), a[:, 5].max(), a[:, 3].max()


def _world_boxes(boxes: list[_LBox], frame: FloatArray, origin: FloatArray) -> tuple[Box, ...]:
    out = []
    for x0, x1, y0, y1, z0, z1, faces in boxes:
        c = origin + frame @ np.array([(x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2])
        out.append(Box(c, np.array([(x1 - x0) / 2, (y1 - y0) / 2, (z1 - z0) / 2]), frame, faces))
    return tuple(out)


def _frame(facing: FloatArray) -> FloatArray:
    """Rotation whose local +z is the horizontal ``facing`` and +y is up (x = y cross z)."""
    fx, fz = facing / np.hypot(facing[0], facing[1])
    return np.array([[fz, 0.0, fx], [0.0, 1.0, 0.0], [-fx, 0.0, fz]])


def _footprint(frame: FloatArray, origin: FloatArray, x0: float, x1: float, z0: float, z1: float) -> FloatArray:
    corners = np.array([[x0, 0, z0], [x1, 0, z0], [x1, 0, z1], [x0, 0, z1]], dtype=np.float64)
    world = origin + corners @ frame.T
    return world[:, [0, 2]]


def _zone(b: Building, wi: int, u0: float, u1: float, depth: float) -> Polygon:
    w = b.walls[wi]
    p0, p1 = w.point(u0), w.point(u1)
    return Polygon([p0, p1, p1 + depth * w.normal, p0 + depth * w.normal])


def _rect(rect: tuple[float, float, float, float], pad: float) -> Polygon:
    x0, x1, z0, z1 = rect
    return shapely.box(x0 - pad, z0 - pad, x1 + pad, z1 + pad)


def keep_out_zones(b: Building, markers: list[Marker]) -> tuple[dict[int, list[Polygon]], dict[int, list[Polygon]]]:
    """Keep-out zones per room: ``always`` (in front of doors, around stairs and slab openings)
    and, for items taller than a table, ``tall`` (in front of windows and wall-mounted sensors)."""
    always: dict[int, list[Polygon]] = {r: [] for r in range(len(b.rooms))}
    tall: dict[int, list[Polygon]] = {r: [] for r in range(len(b.rooms))}
    for o in b.openings:
        r = b.walls[o.wall].room
        if o.kind == "door":
            always[r].append(_zone(b, o.wall, o.u_m - o.width_m / 2 - 0.2, o.u_m + o.width_m / 2 + 0.2, 1.0))
        else:
            tall[r].append(_zone(b, o.wall, o.u_m - o.width_m / 2 - 0.1, o.u_m + o.width_m / 2 + 0.1, 0.6))
    for m in markers:
        if m.kind in ("sensor", "thermostat"):
            tall[b.walls[m.wall].room].append(_zone(b, m.wall, m.u_m - 0.3, m.u_m + 0.3, 0.6))
    for st in b.stairs:
        always[st.room].append(_rect(st.opening, 0.3))
    for above, rect in b.floor_openings:
        always[above].append(_rect(rect, 0.3))
    return always, tall


def place_furniture(b: Building, markers: list[Marker], rng: np.random.Generator, fixed: Sequence[Item] = ()) -> list[Item]:
    """Furnish every room (2-6 items, fewer in halls, corridors, stairwells and baths), with one
    board leaning against a wall somewhere in the building.

    Parameters
    ----------
    b
        The building.
    markers
        Annotated objects: tall items keep clear of the wall-mounted ones.
    rng
        The furniture's random generator.
    fixed
        Items already in place (built-ins): the others keep clear of them; they come first in the
        result.
    """
    always, tall = keep_out_zones(b, markers)
    inside = {r: Polygon(room.polygon).buffer(-0.01, join_style="mitre") for r, room in enumerate(b.rooms)}
    placed: dict[int, list[Polygon]] = {r: [] for r in range(len(b.rooms))}
    room_walls = {}
    for r in range(len(b.rooms)):
        ids = b.room_walls(r)
        room_walls[r] = (ids, np.array([b.walls[i].length for i in ids]))
    counts: dict[tuple[int, str], int] = {}
    items: list[Item] = []
    for it in fixed:
        items.append(it)
        placed[it.room].append(Polygon(it.footprint))
        counts[(it.room, it.kind)] = counts.get((it.room, it.kind), 0) + 1

    def fits(r: int, fp: FloatArray, height: float) -> bool:
        poly = Polygon(fp)
        if not inside[r].contains(poly):
            return False
        zones = always[r] + (tall[r] if height > 0.75 else [])
        if any(poly.intersects(z) for z in zones):
            return False
        grown = poly.buffer(0.05)
        return not any(grown.intersects(p) for p in placed[r])

    def add(r: int, kind: str, boxes: tuple[Box, ...], fp: FloatArray, height: float, tilted: bool) -> None:
        key = (r, kind)
        counts[key] = counts.get(key, 0) + 1
        name = f"{b.rooms[r].label}_{kind}{counts[key]}"
        items.append(Item(b.rooms[r].story, r, name, kind, boxes, fp, height, tilted))
        placed[r].append(Polygon(fp))

    def try_place(r: int, kind: str, local: list[_LBox], free: bool, tilted: bool = False) -> bool:
        x0, x1, z0, z1, height = _extent(local)
        if height > MAX_HEIGHT_M + 1e-9:
            return False
        room = b.rooms[r]
        floor = b.stories[room.story][0]
        walls, lengths = room_walls[r]
        lo, hi = room.polygon.min(axis=0), room.polygon.max(axis=0)
        for _ in range(15):
            if free:
                yaw = rng.uniform(0.0, 2.0 * np.pi)
                frame = _frame(np.array([np.cos(yaw), np.sin(yaw)]))
                centre = rng.uniform(lo, hi)
                origin = np.array([centre[0], floor, centre[1]]) - frame @ np.array([(x0 + x1) / 2, 0.0, (z0 + z1) / 2])
            else:
                wi = walls[int(rng.choice(len(walls), p=lengths / lengths.sum()))]
                w = b.walls[wi]
                if w.length < x1 - x0 + 0.1:
                    continue
                u = rng.uniform(0.05 - x0, w.length - 0.05 - x1)
                p = w.point(u) + rng.uniform(0.02, 0.06) * w.normal
                frame = _frame(w.normal)
                origin = np.array([p[0], floor, p[1]])
            fp = _footprint(frame, origin, x0, x1, z0, z1)
            if fits(r, fp, height):
                add(r, kind, _world_boxes(local, frame, origin), fp, height, tilted)
                return True
        return False

    # the leaning board: tilted about its bottom edge, top edge resting on a wall
    for r in rng.permutation(len(b.rooms)):
        if _place_board(b, int(r), rng, fits, add):
            break

    for r, room in enumerate(b.rooms):
        entries = CATALOG.get(room.kind, CATALOG["room"])
        n = int(rng.integers(2, 4)) if room.kind in _SMALL_ROOMS else int(rng.integers(2, 7))
        n -= sum(1 for it in items if it.room == r)
        weights = np.array([e[3] for e in entries], dtype=np.float64)
        # the room's main item first, then random ones; a few spare draws make up for misfits
        picks = [0] + list(rng.choice(len(entries), size=3 * max(n, 1), p=weights / weights.sum()))
        done = 0
        for k in picks:
            if done >= n:
                break
            name, factory, free, _ = entries[k]
            done += try_place(r, name, factory(rng), free)
    return items


def _place_board(b: Building, r: int, rng: np.random.Generator, fits, add) -> bool:
    room = b.rooms[r]
    floor = b.stories[room.story][0]
    walls = b.room_walls(r)
    for _ in range(25):
        wi = walls[int(rng.integers(len(walls)))]
        w = b.walls[wi]
        width, length, t = rng.uniform(0.5, 1.2), rng.uniform(1.2, 2.0), rng.uniform(0.02, 0.04)
        theta = np.radians(rng.uniform(10.0, 35.0))
        if w.length < width + 0.3:
            continue
        u = rng.uniform(0.15 + width / 2, w.length - 0.15 - width / 2)
        frame = _frame(w.normal)
        p = w.point(u) + 0.01 * w.normal
        origin = np.array([p[0], floor, p[1]])
        # board axes in the item frame: across, up the board (leaning onto the wall), its front
        by = np.array([0.0, np.cos(theta), -np.sin(theta)])
        bz = np.array([0.0, np.sin(theta), np.cos(theta)])
        zq = length * np.sin(theta)
        centre_local = np.array([0.0, 0.0, zq]) + 0.5 * length * by + 0.5 * t * bz
        rot = frame @ np.stack([np.array([1.0, 0.0, 0.0]), by, bz], axis=1)
        box = Box(origin + frame @ centre_local, np.array([width / 2, length / 2, t / 2]), rot, "+x -x +y +z -z")
        fp = _footprint(frame, origin, -width / 2, width / 2, 0.0, zq + t * np.cos(theta))
        height = length * np.cos(theta) + t * np.sin(theta)
        if fits(r, fp, height):
            add(r, "board", (box,), fp, float(height), True)
            return True
    return False

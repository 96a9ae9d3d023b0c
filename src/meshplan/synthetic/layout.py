"""Building layouts of the synthetic presets: rooms, walls, openings and stairs (truth frame).

:mod:`.presets` draws a *plan* per story: axis-aligned room polygons given by their inner wall
faces (the gaps between neighbouring rooms are the partitions, the outside of the plan is the
exterior wall), the pairs of rooms joined by a door, the room with the entrance and how many
windows each room gets. :func:`make_building` then derives everything else the same way for all
presets: one wall face per polygon edge, doors on the wall faces two rooms share (once per side),
windows on the exterior stretches of the walls, and the stairs.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from shapely.geometry import Polygon

from ..geometry import FloatArray
from .polygons import ccw, edge_normals, point_in_polygon, rect_polygon, signed_area
from .presets import RISE_M, STAIR_APPROACH_M, STAIR_WALL_GAP_M, plan_apartment, plan_hard, plan_office, plan_room, uniform
from .tessellate import Box

#: Clear wall kept between a door and a corner, the end of a shared wall or another opening.
DOOR_MARGIN_M = 0.25
#: The same for windows.
WINDOW_MARGIN_M = 0.3
#: Two parallel wall faces at most this far apart, facing away from each other, are the two
#: sides of one partition.
MAX_PARTITION_M = 0.6

__all__ = ["Building", "Opening", "Room", "Stair", "Wall", "free_centres", "make_building", "point_in_polygon"]

_UP = np.array([0.0, 1.0, 0.0])


# --------------------------------------------------------------------------------------------
# Data


@dataclass(frozen=True, eq=False)
class Room:
    """A room: its net floor polygon between the inner wall faces."""

    story: int
    label: str
    kind: str
    polygon: FloatArray

    @property
    def area(self) -> float:
        return abs(signed_area(self.polygon))

    @property
    def extent(self) -> tuple[float, float]:
        """Width along x and depth along z."""
        span = self.polygon.max(axis=0) - self.polygon.min(axis=0)
        return float(span[0]), float(span[1])


@dataclass(frozen=True, eq=False)
class Wall:
    """One inner wall face of one room, corner to corner."""

    story: int
    room: int
    start: FloatArray
    end: FloatArray
    normal: FloatArray  # unit [nx, nz], into the room
    bottom: float
    top: float
    convex_start: bool  # the room's corner at ``start`` is convex (90 degrees inside)
    convex_end: bool

    @cached_property
    def length(self) -> float:
        return float(np.hypot(*(self.end - self.start)))

    @cached_property
    def direction(self) -> FloatArray:
        return (self.end - self.start) / self.length

    def point(self, u: float) -> FloatArray:
        """The plan point ``u`` metres along the wall from its start."""
        return self.start + u * self.direction

    def u_of(self, point: FloatArray) -> float:
        return float(np.dot(np.asarray(point) - self.start, self.direction))


@dataclass(frozen=True, eq=False)
class Opening:
    """A door or window cut from one wall face.

    A door between two rooms is two openings (one per wall face) with the same label; the
    ``primary`` one carries the jambs, head and threshold and the annotation.
    """

    story: int
    kind: str
    wall: int
    u_m: float  # centre, metres along the wall from its start
    width_m: float
    bottom: float  # absolute heights, truth frame
    top: float
    label: str
    depth_m: float  # through the wall (door) or to the glass (window)
    primary: bool
    exterior: bool


@dataclass(frozen=True, eq=False)
class Stair:
    """A U-shaped stair from the floor of ``story`` up to the floor of the story above."""

    story: int
    room: int
    opening: tuple[float, float, float, float]  # (x0, x1, z0, z1) cut from the slab above
    boxes: tuple[Box, ...]
    risers: int
    rise_m: float
    going_m: float
    width_m: float


@dataclass(frozen=True, eq=False)
class Building:
    """Everything the scan is made from, truth frame."""

    preset: str
    stories: tuple[tuple[float, float], ...]  # (floor, ceiling) per story
    rooms: tuple[Room, ...]
    walls: tuple[Wall, ...]
    openings: tuple[Opening, ...]
    stairs: tuple[Stair, ...]
    footprint: FloatArray  # outer outline of the exterior walls
    exterior_m: float
    floor_openings: tuple[tuple[int, tuple[float, float, float, float]], ...] = ()  # (room, rect)

    def room_walls(self, room: int) -> list[int]:
        return [i for i, w in enumerate(self.walls) if w.room == room]

    def wall_openings(self, wall: int) -> list[Opening]:
        return [o for o in self.openings if o.wall == wall]


# --------------------------------------------------------------------------------------------
# Assembly


def free_centres(lo: float, hi: float, width: float, margin: float, occupied: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Intervals of possible centres of an opening of ``width`` in ``[lo, hi]`` keeping ``margin``
    from the ends and from the ``occupied`` intervals."""
    free = [(lo + margin + width / 2, hi - margin - width / 2)]
    for o0, o1 in occupied:
        a, b = o0 - margin - width / 2, o1 + margin + width / 2
        nxt = []
        for f0, f1 in free:
            if b <= f0 or a >= f1:
                nxt.append((f0, f1))
                continue
            if a > f0:
                nxt.append((f0, a))
            if b < f1:
                nxt.append((b, f1))
        free = nxt
    return [(a, b) for a, b in free if b >= a]


def _pick(intervals: list[tuple[float, float]], rng: np.random.Generator) -> float | None:
    if not intervals:
        return None
    lengths = np.array([b - a for a, b in intervals]) + 1e-9
    k = int(rng.choice(len(intervals), p=lengths / lengths.sum()))
    return uniform(rng, *intervals[k])


def _facing(wa: Wall, wb: Wall) -> tuple[float, float, float] | None:
    """``(lo, hi, gap)``: the stretch of ``wa`` (its own coordinates) facing ``wb`` across a partition."""
    if wa.story != wb.story or wa.room == wb.room or np.dot(wa.normal, wb.normal) > -0.99:
        return None
    gap = float(np.dot(wb.start - wa.start, -wa.normal))
    if not 0.0 < gap <= MAX_PARTITION_M:
        return None
    ub = sorted([wa.u_of(wb.start), wa.u_of(wb.end)])
    lo, hi = max(0.0, ub[0]), min(wa.length, ub[1])
    return (lo, hi, gap) if hi - lo > 1e-6 else None


def _exterior(walls: list[Wall], i: int) -> list[tuple[float, float]]:
    """Stretches of wall ``i`` with no room behind it."""
    out = [(0.0, walls[i].length)]
    for j in range(len(walls)):
        f = _facing(walls[i], walls[j])
        if f is None:
            continue
        lo, hi, _ = f
        nxt = []
        for a, b in out:
            if hi <= a or lo >= b:
                nxt.append((a, b))
                continue
            if lo > a:
                nxt.append((a, lo))
            if hi < b:
                nxt.append((hi, b))
        out = nxt
    return out


def _walls_of(room_index: int, room: Room, bottom: float, top: float) -> list[Wall]:
    poly = room.polygon
    normals = edge_normals(poly)
    k = len(poly)
    d = np.roll(poly, -1, axis=0) - poly
    cross = d[:, 0] * np.roll(d, -1, axis=0)[:, 1] - d[:, 1] * np.roll(d, -1, axis=0)[:, 0]
    convex = cross < 0  # corner at the end of edge i (vertex i+1) turns the polygon's way
    return [
        Wall(
            room.story, room_index, poly[i].copy(), poly[(i + 1) % k].copy(), normals[i], bottom, top,
            bool(convex[i - 1]), bool(convex[i]),
        )
        for i in range(k)
    ]


def _stair(
    story: int, room: int, wall: Wall, far_m: float, floor: float, rise_total: float, going: float, flight: float,
    rng: np.random.Generator,
) -> Stair:
    """A U-stair starting ``STAIR_APPROACH_M`` in front of ``wall`` (the stairwell's door wall)
    and running away from it: the first flight along one side wall, a half landing, the second
    flight back beside it."""
    n = max(2, int(round(rise_total / RISE_M)))
    rise = rise_total / n
    n1 = (n + 1) // 2
    a = np.r_[wall.direction[0], 0.0, wall.direction[1]]
    rot = np.stack([a, _UP, np.cross(a, _UP)], axis=1)
    gap = STAIR_WALL_GAP_M
    if rng.random() < 0.5:
        lane_a, lane_b = (gap, gap + flight), (gap + flight, gap + 2 * flight)
    else:
        end = wall.length - gap
        lane_a, lane_b = (end - flight, end), (end - 2 * flight, end - flight)
    start = STAIR_APPROACH_M
    landing = start + (n1 - 1) * going
    depth_l = flight + 0.05
    boxes = []

    def add(lane, r0, r1, y0, y1):
        c2 = wall.start + 0.5 * (lane[0] + lane[1]) * wall.direction + 0.5 * (r0 + r1) * wall.normal
        center = np.r_[c2[0], floor + 0.5 * (y0 + y1), c2[1]]
        half = np.array([0.5 * abs(lane[1] - lane[0]), 0.5 * (y1 - y0), 0.5 * (r1 - r0)])
        boxes.append(Box(center, half, rot, "+x -x +y +z -z"))

    for k in range(1, n1):
        add(lane_a, start + (k - 1) * going, start + k * going, (k - 1) * rise, k * rise)
    both = (min(lane_a[0], lane_b[0]), max(lane_a[1], lane_b[1]))
    add(both, landing, landing + depth_l, n1 * rise - 0.15, n1 * rise)
    for k in range(n1 + 1, n):
        j = k - n1
        add(lane_b, landing - j * going, landing - (j - 1) * going, (k - 1) * rise, k * rise)
    # the slab opening: over the whole stair, clear of the walls
    pts = []
    for lane in (both,):
        for r in (start, landing + depth_l):
            for u in lane:
                pts.append(wall.start + u * wall.direction + r * wall.normal)
    corners = np.array(pts)
    lo, hi = corners.min(axis=0) - 0.03, corners.max(axis=0) + 0.03
    assert landing + depth_l + 0.03 < far_m - 0.1, "stairwell too short for its stair"
    return Stair(story, room, (float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])), tuple(boxes), n, rise, going, flight)


def make_building(preset: str, n_stories: int, rng: np.random.Generator, angled: bool = False) -> Building:
    """Draw the building of ``preset`` (truth frame) from ``rng``.

    Parameters
    ----------
    preset
        One of ``room``, ``apartment``, ``office``, ``multistory``, ``hard`` (``hard-parametric``
        is the same building).
    n_stories
        Number of stories (1 except for ``multistory``).
    rng
        The layout's random generator.
    angled
        Walls off the axes: a slanted wall and a 45-degree chamfer (``room`` and ``hard`` only).
    """
    if preset == "room":
        plans, ceil_h, slabs, width, depth, (going, flight) = plan_room(rng, angled)
    elif preset in ("hard", "hard-parametric"):
        plans, ceil_h, slabs, width, depth, (going, flight) = plan_hard(rng, angled)
    elif preset == "office":
        plans, ceil_h, slabs, width, depth, (going, flight) = plan_office(rng)
    else:
        plans, ceil_h, slabs, width, depth, (going, flight) = plan_apartment(rng, n_stories)
    ext = uniform(rng, 0.25, 0.35)
    floors = [0.0]
    for c, s in zip(ceil_h[:-1], slabs):
        floors.append(floors[-1] + c + s)
    stories = tuple((round(f, 6), round(f + c, 6)) for f, c in zip(floors, ceil_h))

    # random mirror and transpose, the same for every story (stairwells stay stacked)
    fx, fz, swap = rng.random(3) < 0.5

    def mapped(poly: FloatArray) -> FloatArray:
        p = np.array(poly, dtype=np.float64)
        if fx:
            p[:, 0] = width - p[:, 0]
        if fz:
            p[:, 1] = depth - p[:, 1]
        if swap:
            p = p[:, ::-1].copy()
        return ccw(np.round(p, 6))  # the truth's precision, so that truth and geometry agree

    rooms: list[Room] = []
    index: dict[tuple[int, str], int] = {}
    for s, plan in enumerate(plans):
        for label, kind, poly in plan.rooms:
            index[(s, label)] = len(rooms)
            rooms.append(Room(s, label, kind, mapped(poly)))
    walls: list[Wall] = []
    for i, room in enumerate(rooms):
        walls += _walls_of(i, room, *stories[room.story])
    occupied: dict[int, list[tuple[float, float]]] = {i: [] for i in range(len(walls))}
    openings: list[Opening] = []
    n_doors = n_windows = 0

    def room_walls(r: int) -> list[int]:
        return [i for i, w in enumerate(walls) if w.room == r]

    for s, plan in enumerate(plans):
        floor = stories[s][0]
        for la, lb in plan.doors:
            ra, rb = index[(s, la)], index[(s, lb)]
            width_m, height_m = uniform(rng, 0.8, 0.9), uniform(rng, 2.0, 2.1)
            door_options: list[tuple[int, int, float, list[tuple[float, float]]]] = []
            for ia in room_walls(ra):
                for ib in room_walls(rb):
                    f = _facing(walls[ia], walls[ib])
                    if f is None:
                        continue
                    lo, hi, gap = f
                    wb = walls[ib]
                    taken = list(occupied[ia])
                    for o in occupied[ib]:
                        u0, u1 = sorted(walls[ia].u_of(wb.point(u)) for u in o)
                        taken.append((u0, u1))
                    free = free_centres(lo, hi, width_m, DOOR_MARGIN_M, taken)
                    if free:
                        door_options.append((ia, ib, gap, free))
            if not door_options:
                raise RuntimeError(f"no room for a door between {la} and {lb}")  # a layout bug
            ia, ib, gap, free = door_options[int(rng.integers(len(door_options)))]
            u = _pick(free, rng)
            assert u is not None  # free is never empty
            n_doors += 1
            label = f"D{n_doors}"
            ub = walls[ib].u_of(walls[ia].point(u))
            for w, uu, primary in ((ia, u, True), (ib, ub, False)):
                openings.append(Opening(s, "door", w, uu, width_m, floor, floor + height_m, label, gap, primary, False))
                occupied[w].append((uu - width_m / 2, uu + width_m / 2))
        if plan.entrance is not None:
            r = index[(s, plan.entrance)]
            width_m, height_m = uniform(rng, 0.8, 0.9), uniform(rng, 2.0, 2.1)
            entrance_options: list[tuple[int, list[tuple[float, float]]]] = []
            for i in room_walls(r):
                for lo, hi in _exterior(walls, i):
                    free = free_centres(lo, hi, width_m, DOOR_MARGIN_M, occupied[i])
                    if free:
                        entrance_options.append((i, free))
            if not entrance_options:
                raise RuntimeError(f"no room for the entrance of {plan.entrance}")
            i, free = entrance_options[int(rng.integers(len(entrance_options)))]
            u = _pick(free, rng)
            assert u is not None  # free is never empty
            n_doors += 1
            openings.append(Opening(s, "door", i, u, width_m, floor, floor + height_m, f"D{n_doors}", ext, True, True))
            occupied[i].append((u - width_m / 2, u + width_m / 2))
        for label, _, _ in plan.rooms:
            lo_n, hi_n = plan.windows.get(label, (0, 0))
            count = int(rng.integers(lo_n, hi_n + 1))
            r = index[(s, label)]
            for _ in range(count):
                width_m = uniform(rng, 0.9, 1.8)
                sill, head = uniform(rng, 0.8, 1.0), uniform(rng, 2.0, 2.2)
                window_options: list[tuple[int, float, list[tuple[float, float]]]] = []
                for i in room_walls(r):
                    for lo, hi in _exterior(walls, i):
                        fit = min(width_m, hi - lo - 2 * WINDOW_MARGIN_M)
                        if fit < 0.9:
                            continue
                        free = free_centres(lo, hi, fit, WINDOW_MARGIN_M, occupied[i])
                        if free:
                            window_options.append((i, fit, free))
                if not window_options:
                    break
                i, fit, free = window_options[int(rng.integers(len(window_options)))]
                u = _pick(free, rng)
                assert u is not None  # free is never empty
                n_windows += 1
                depth_m = ext * uniform(rng, 0.5, 0.7)
                openings.append(Opening(s, "window", i, u, fit, floor + sill, floor + head, f"W{n_windows}", depth_m, True, True))
                occupied[i].append((u - fit / 2, u + fit / 2))

    stairs: list[Stair] = []
    floor_openings: list[tuple[int, tuple[float, float, float, float]]] = []
    for s, plan in enumerate(plans):
        if plan.stairwell is None:
            continue
        r = index[(s, plan.stairwell)]
        door_walls = [o.wall for o in openings if o.kind == "door" and walls[o.wall].room == r]
        wall = walls[door_walls[0]]
        poly = rooms[r].polygon
        far = float(np.max((poly - wall.start) @ wall.normal))
        rise_total = stories[s + 1][0] - stories[s][0]
        st = _stair(s, r, wall, far, stories[s][0], rise_total, going, flight, rng)
        stairs.append(st)
        cx, cz = 0.5 * (st.opening[0] + st.opening[1]), 0.5 * (st.opening[2] + st.opening[3])
        above = [i for i, rm in enumerate(rooms) if rm.story == s + 1 and point_in_polygon(rm.polygon, cx, cz)]
        if above:
            floor_openings.append((above[0], st.opening))

    if plans[0].envelope is not None:  # the outline of the exterior walls, grown by their thickness
        grown = Polygon(mapped(plans[0].envelope)).buffer(ext, join_style="mitre")
        fp = ccw(np.round(np.asarray(grown.exterior.coords)[:-1], 6))
    else:
        fp = mapped(rect_polygon(-ext, width + ext, -ext, depth + ext))
    return Building(
        preset=preset,
        stories=stories,
        rooms=tuple(rooms),
        walls=tuple(walls),
        openings=tuple(openings),
        stairs=tuple(stairs),
        footprint=fp,
        exterior_m=ext,
        floor_openings=tuple(floor_openings),
    )

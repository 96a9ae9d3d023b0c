"""Building elements: what the walls, rooms and openings *are*, beyond their geometry.

* **Rooms** are numbered in reading order per story, story number first (``0.01``, ``0.02``, ...:
  rows from the top of the plan down, each row from left to right; x to the right, z down the
  page), typed from their shape and contents (:func:`type_rooms`: a *stair* holds most of a
  stair found from the stepped surfaces, :mod:`meshplan.plan.stairs`; :func:`room_type`: a
  *corridor* is long and narrow with several doors, a *closet* is small, an
  *open* space is large, any other is a *room*) and named. A ``rooms.json`` (or a ``plan.json``,
  whose ``rooms`` block has the same form) passed back with ``--rooms`` renames, renumbers and
  retypes them: each of its rooms goes to the computed room of its story that overlaps it most
  (intersection over union at least :data:`MATCH_IOU`, or the one holding its centre), so the
  names survive a re-run that moves the walls a little.
* **Walls** (physical, :mod:`meshplan.walls.physical`) get the rooms on each side, whether they
  are exterior, and a confidence.
* **Openings** get their physical wall, clear width and height, sill, the two rooms they connect
  (or ``"outside"``), the leaf's side and swing where the scan shows the leaf
  (:func:`door_leaf`), and a confidence.

Confidence (``high``, ``medium``, ``low``, always with the reason) tells a reader what to check:

* wall: both faces scanned and reaching floor and ceiling: high; one face (thickness assumed),
  or not reaching floor or ceiling: medium; shorter than :data:`SHORT_WALL_M` or moved at its
  ends by more than :data:`LONG_JOIN_SHARE` of its length (extended across what the scan
  missed): low;
* room: closed by scanned walls: high; by walls continued across gaps (``extension``): medium;
  by the scanned floor: low;
* opening: the hole seen in both faces of its wall with wall beside both jambs: high; in one face:
  medium; in none clearly, or sizes outside those of doors and windows: low.

Why one long module: rooms, walls and openings become elements together (an opening's rooms come
from the rooms, a room's type from its doors, a wall's sides from its rooms), so their rules read
best side by side.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Point, Polygon

from ..errors import InputError
from ..geometry import FloatArray, Mesh, in_threads
from ..orient import Story
from ..walls import FlatWalls, PhysicalWall
from ..walls.flat import AJAR_MAX_TURN_DEG, AJAR_MIN_TURN_DEG
from ..walls.physical import wall_of_face
from .doors import LEAF_THICKNESS_M
from .draft import DraftingPlan
from .openings import Openings
from .params import PlanParams
from .rooms import Room
from .stairs import StairElement

# --------------------------------------------------------------------------------------------
# Thresholds (metres, square metres, degrees), each with its reason

#: A wall shorter than this (m) is a fragment as often as a wall: a return, a pillar's face.
SHORT_WALL_M = 1.0
#: A wall whose ends moved (``PhysicalWall.joined``) by more than this share of its length in
#: all was drawn across what the scan did not show.
LONG_JOIN_SHARE = 0.25
#: Probes for the rooms beside a wall lie this far (m) beyond each face: inside the net floor
#: area of a room (whose polygon starts at the face) but short of the next wall of a corridor.
SIDE_PROBE_M = 0.25
#: ... and a room counts when its polygon comes this close (m) to a probe: room polygons closed
#: by the floor end where the floor scan does, 0.1-0.2 m short of the wall behind furniture.
SIDE_SLACK_M = 0.2
#: Probes along a wall, as shares of its length (a long corridor wall has several rooms behind),
#: those within ``SIDE_PROBE_M + SIDE_SLACK_M`` of an end left out (the middle one at least kept).
SIDE_SAMPLES = np.linspace(0.1, 0.9, 9)

#: A room is a closet (storage) below this floor area (m2): a walk-in closet or a store room;
#: a bathroom is 3.5-6 m2.
CLOSET_AREA_M2 = 3.0
#: A room is an open space from this area (m2): an open-plan office or hall, larger than any
#: closed room of a dwelling (living rooms are 20-40 m2).
OPEN_AREA_M2 = 50.0
#: A corridor is at least this many times longer than wide (its minimum rotated rectangle:
#: a 2.2 m hall along two 2.5 m rooms) ...
CORRIDOR_ASPECT = 2.0
#: ... at most this wide (m): hallways are 0.9-2.4 m wide ...
CORRIDOR_MAX_WIDTH_M = 2.5
#: ... and has at least this many doors (several: a passage, not a narrow room such as a bath
#: or a galley kitchen with one or two).
CORRIDOR_MIN_DOORS = 3

#: A room above a stair of the story below, overlapping it by this share of the smaller, is the
#: stair's upper end (its floor has the stairwell's opening).
STAIR_ABOVE_SHARE = 0.3
#: A room holding most of a found stair's footprint (:mod:`meshplan.plan.stairs`) is its stairwell
#: when the stair covers at least this share of it: a living room with a stair in a corner stays
#: a room.
STAIR_ROOM_SHARE = 0.25

#: A computed room takes the name of a rooms.json room it overlaps by at least this intersection
#: over union: a re-run moves walls by centimetres, not by half a room.
MATCH_IOU = 0.3

#: Door and window sizes outside the detector's own limits (``PlanParams``: ``door_width_m``,
#: ``door_height_m``, ``window_width_m``) make an opening low-confidence. A measured width may
#: exceed the upper limit by this share (the scan rounds jambs off, and a width is measured
#: between the outermost faces), ...
ODD_WIDTH_MARGIN = 0.1
#: ... and a door taller than this (m) is odd: doors are 2.0-2.4 m high (a gap whose lintel was
#: scanned is no door above :data:`meshplan.plan.doors.DOOR_HEAD_MAX_M`), and a taller gap in a
#: wall whose lintel was not scanned, or a parametric model's door, is a passage or a scan hole
#: reaching the ceiling.
DOOR_ODD_HEAD_M = 2.6
#: The hole of an opening is seen on a face when wall-facing triangles in the plane of the face
#: (within :data:`HOLE_PLANE_M`) cover less than this share of the opening's inner rectangle
#: (inset by :data:`HOLE_INSET_M` from the jambs, sill and head, where scans round edges off).
HOLE_EMPTY_SHARE = 0.1
HOLE_PLANE_M = 0.05
HOLE_INSET_M = 0.1
#: The rooms an opening connects are probed this far (m) beyond each face of its wall.
OPENING_PROBE_M = 0.4

#: A door leaf is looked for in the height band (m above the floor) where nothing else stands
#: that close to a door: above skirtings and chair seats, below the head.
LEAF_BAND_M = (0.3, 1.8)
#: Faces of a leaf lie between these distances from the hinge, as shares of the door's width
#: (the part near the hinge is hidden by the jamb, the tip rounded off).
LEAF_REACH = (0.15, 0.95)
#: A leaf's faces contain the ray from the hinge: |normal . ray| at most this.
LEAF_RAY_COS = 0.3
#: A leaf is seen when its faces cover at least this share of one side of it (a 4 cm leaf shows
#: up to both sides, 2.0), and at least twice what any other (hinge, side) shows.
LEAF_MIN_SHARE = 0.3
#: A leaf opened past square stands back over its own wall; it is still a leaf up to this angle
#: (degrees): doors stop at 90-120 degrees on their stop or the wall behind them, and beyond
#: that a leaf lies along the wall, where it cannot be told from it.
LEAF_MAX_OPEN_DEG = 120.0
#: The direction of a leaf is the line fitted through its faces when they lie this close to it
#: (m, rms; the two faces of a 4 cm leaf are 2 cm off its middle), else the mean of the rays
#: from the hinge to them. The fitted line also places the hinge in a wall whose far face was
#: not scanned (its thickness is the default), where the line meets the jamb, as long as the
#: leaf stands at most :data:`LEAF_FIT_HINGE_MAX_DEG` open (beyond, that meeting point moves by
#: 2-4 cm for each degree of error in the line).
LEAF_FIT_RMS_M = 0.03
LEAF_FIT_HINGE_MAX_DEG = 75.0
#: A leaf standing ajar, within a few degrees of its closed position (from
#: :data:`~meshplan.walls.flat.AJAR_MIN_TURN_DEG` to
#: :data:`~meshplan.walls.flat.AJAR_MAX_TURN_DEG`), hardly leaves the wall's depth and looks the
#: same seen from either jamb; it is the line fitted through the faces standing in the doorway (within the wall's depth and this far (m) beyond either face),
#: spanning at least :data:`AJAR_LEAF_SPAN_SHARE` of the door, and its hinge is the end nearer
#: the middle of the wall: a leaf closes into its frame, and the free end is the one that left.
AJAR_BEYOND_M = 0.25
AJAR_LEAF_SPAN_SHARE = 0.8


# --------------------------------------------------------------------------------------------
# Rooms: reading order, numbers, types, names


def reading_order(rooms: tuple[Room, ...]) -> list[int]:
    """Indices of ``rooms`` in reading order: by story, then in rows from the top of the plan
    (smallest z) down, each row from left to right (smallest x).

    A row starts at the topmost room left and holds every room whose centroid lies above that
    room's bottom edge, so rooms of different depths side by side are read left to right.
    """
    order: list[int] = []
    for story in sorted({r.story for r in rooms}):
        left = [i for i, r in enumerate(rooms) if r.story == story]
        left.sort(key=lambda i: (rooms[i].polygon.bounds[1], rooms[i].polygon.bounds[0]))
        while left:
            first = left[0]
            bottom = rooms[first].polygon.bounds[3]
            row = [i for i in left if rooms[i].polygon.centroid.y < bottom]
            row.sort(key=lambda i: (rooms[i].polygon.centroid.x, rooms[i].polygon.centroid.y))
            order.extend(row)
            left = [i for i in left if i not in row]
    return order


def room_number(story: int, k: int) -> str:
    """``0.01``: the story, a dot, the room's place in its story (two digits, more if needed)."""
    return f"{story}.{k:02d}"


@dataclass(frozen=True)
class RoomEdit:
    """One room of a rooms.json: what the user set (``None``: keep what was computed)."""

    story: int
    polygon: Polygon | None
    center: tuple[float, float] | None
    number: str | None
    name: str | None
    type: str | None


ROOM_TYPES = ("room", "corridor", "stair", "closet", "open")


def load_room_edits(path: str | os.PathLike) -> tuple[RoomEdit, ...]:
    """Read a rooms.json (or a plan.json): ``{"rooms": [{"story", "polygon" or "center",
    "number", "name", "type"}, ...]}``; every field but ``story`` and a position is optional.

    Raises
    ------
    InputError
        For a missing or malformed file, with what to fix.
    """
    fix = 'give a rooms.json like {"rooms": [{"story": 0, "center": [x, z], "name": "Kitchen"}]} (plan.json\'s rooms block)'
    try:
        with open(path, encoding="utf-8") as fh:
            doc = json.load(fh)
    except OSError as exc:
        raise InputError(f"cannot read the rooms file {os.fspath(path)}: {exc.strerror or exc}", fix) from None
    except (ValueError, UnicodeDecodeError) as exc:
        raise InputError(f"the rooms file {os.fspath(path)} is not JSON ({exc})", fix) from None
    items = doc.get("rooms") if isinstance(doc, dict) else doc
    if not isinstance(items, list):
        raise InputError(f"the rooms file {os.fspath(path)} has no list of rooms", fix)
    out = []
    for k, it in enumerate(items):
        where = f"room {k} of {os.fspath(path)}"
        if not isinstance(it, dict):
            raise InputError(f"{where} is not an object", fix)
        try:
            story = int(it.get("story", 0))
            poly = Polygon(np.asarray(it["polygon"], dtype=np.float64)).buffer(0) if it.get("polygon") is not None else None
            center = tuple(float(v) for v in it["center"][:2]) if it.get("center") is not None else None
        except (TypeError, ValueError, IndexError) as exc:
            raise InputError(f"{where} has a malformed story, polygon or center ({exc})", fix) from None
        if poly is None and center is None:
            raise InputError(f"{where} has neither a polygon nor a center", fix)
        kind = it.get("type")
        if kind is not None and kind not in ROOM_TYPES:
            raise InputError(f"{where} has type {kind!r}", f"use one of {', '.join(ROOM_TYPES)}")
        text = {key: (str(it[key]) if it.get(key) is not None else None) for key in ("number", "name")}
        out.append(RoomEdit(story, poly if poly is not None and not poly.is_empty else None, center, text["number"], text["name"], kind))  # type: ignore[arg-type]
    return tuple(out)


def _match_edits(rooms: tuple[Room, ...], edits: tuple[RoomEdit, ...]) -> dict[int, RoomEdit]:
    """Computed room index -> the edit it takes: greedily, the largest overlap first."""
    pairs = []
    for j, e in enumerate(edits):
        for i, r in enumerate(rooms):
            if r.story != e.story:
                continue
            if e.polygon is not None and r.polygon.intersects(e.polygon):
                iou = r.polygon.intersection(e.polygon).area / max(r.polygon.union(e.polygon).area, 1e-12)
                if iou >= MATCH_IOU:
                    pairs.append((-iou, i, j))
                    continue
            c = e.center if e.center is not None else (e.polygon.representative_point().coords[0] if e.polygon is not None else None)
            if c is not None and r.polygon.contains(Point(c)):
                pairs.append((-MATCH_IOU + 1e-6, i, j))
    taken_r: set[int] = set()
    taken_e: set[int] = set()
    out = {}
    for _, i, j in sorted(pairs):
        if i in taken_r or j in taken_e:
            continue
        taken_r.add(i)
        taken_e.add(j)
        out[i] = edits[j]
    return out


@dataclass(frozen=True)
class ModelName:
    """A room's name that the scan's own model gives (a RoomPlan section's label), at a point
    (plan x, z) of a story's room."""

    story: int
    point: tuple[float, float]
    name: str


#: RoomPlan's section labels that name nothing.
UNNAMED_SECTIONS = ("unidentified",)


def section_names(labels: tuple[str, ...], centers: FloatArray, stories: tuple[Story, ...]) -> tuple[ModelName, ...]:
    """The :class:`ModelName` of each RoomPlan section (``labels`` such as ``livingRoom``, at
    ``centers``, ``(K, 3)`` plan coordinates): ``Living room`` on the story whose floor is the
    highest below the centre; the unidentified ones name nothing."""
    out = []
    for label, c in zip(labels, np.asarray(centers, dtype=np.float64).reshape(-1, 3)):
        if label in UNNAMED_SECTIONS or not stories:
            continue
        below = [s for s in stories if s.floor <= c[1]]
        story = max(below, key=lambda s: s.floor) if below else min(stories, key=lambda s: s.floor)
        words = "".join(f" {ch.lower()}" if ch.isupper() else ch for ch in label).strip()
        out.append(ModelName(story.index, (float(c[0]), float(c[2])), words[:1].upper() + words[1:]))
    return tuple(out)


def name_rooms(rooms: tuple[Room, ...], edits: tuple[RoomEdit, ...] = (), model_names: tuple[ModelName, ...] = ()) -> tuple[Room, ...]:
    """The rooms numbered in reading order per story and labelled ``Room 1``, ``Room 2``, ...
    across the stories in that order, with the numbers, names and types of the ``edits``
    (:func:`load_room_edits`) they match; a room matching none takes the next number free in
    its story. A user's name becomes the label too (plans, IFC and report show it); a room
    without one takes the name the scan's model gives it (``model_names``: the first that lies
    in it), as its label too."""
    order = reading_order(rooms)
    matched = _match_edits(rooms, edits)
    named: dict[int, str] = {}
    for given in model_names:
        for i, r in enumerate(rooms):
            if i not in named and r.story == given.story and r.polygon.contains(Point(given.point)):
                named[i] = given.name
                break
    used: dict[int, set[str]] = {}
    for i, m in matched.items():
        if m.number:
            used.setdefault(rooms[i].story, set()).add(m.number)
    numbers: dict[int, str] = {}
    count: dict[int, int] = {}
    for i in order:
        e = matched.get(i)
        s = rooms[i].story
        if e is not None and e.number:
            numbers[i] = e.number
            continue
        k = count.get(s, 0)
        while True:
            k += 1
            if room_number(s, k) not in used.get(s, set()):
                break
        count[s] = k
        numbers[i] = room_number(s, k)
    # listed by story and number (user numbers in their own order)
    final = sorted(order, key=lambda i: (rooms[i].story, _number_key(numbers[i])))
    out = []
    for n, i in enumerate(final):
        r, e = rooms[i], matched.get(i)
        label = e.name if e is not None and e.name else named.get(i, f"Room {n + 1}")
        kind = e.type if e is not None and e.type else ""
        out.append(replace(r, label=label, number=numbers[i], name=label, type=kind or r.type, type_reason="rooms.json" if kind else ""))
    return tuple(out)


def _number_key(number: str) -> tuple:
    """Sort key of a room number: numerically where it is ``story.k``, else as text."""
    try:
        return (0, float(number.split(".", 1)[1]) if "." in number else float(number), number)
    except ValueError:
        return (1, 0.0, number)


def room_type(room: Room, doors: int) -> tuple[str, str]:
    """``(type, reason)`` of a room from its shape and its ``doors``; stairwells are typed from
    the stairs found (:func:`type_rooms`)."""
    rect = room.polygon.minimum_rotated_rectangle
    xy = np.asarray(rect.exterior.coords)[:4] if isinstance(rect, Polygon) else np.zeros((4, 2))
    sides = np.linalg.norm(np.diff(np.vstack([xy, xy[:1]]), axis=0), axis=1)
    long_m, short_m = float(sides.max()), float(max(sides.min(), 1e-9))
    if long_m / short_m >= CORRIDOR_ASPECT and short_m <= CORRIDOR_MAX_WIDTH_M and doors >= CORRIDOR_MIN_DOORS:
        return "corridor", f"{long_m:.1f} x {short_m:.1f} m with {doors} doors"
    if room.area < CLOSET_AREA_M2:
        return "closet", f"{room.area:.1f} m2, below {CLOSET_AREA_M2:g} m2"
    if room.area >= OPEN_AREA_M2:
        return "open", f"{room.area:.0f} m2, {OPEN_AREA_M2:g} m2 or more"
    return "room", f"{room.area:.1f} m2"


ROOM_CONFIDENCE = {
    "walls": ("high", "closed by scanned walls"),
    "extension": ("medium", "closed by walls continued across what the scan missed"),
    "floor": ("low", "closed where the scanned floor ends: a wall is missing"),
}


# --------------------------------------------------------------------------------------------
# Walls: rooms on each side, exterior, confidence


def _rooms_near(rooms: tuple[Room, ...], story: int, pts: FloatArray, slack: float) -> set[int]:
    out = set()
    for i, r in enumerate(rooms):
        if r.story != story:
            continue
        if np.any(shapely.distance(r.polygon, shapely.points(pts)) <= slack):
            out.add(i)
    return out


#: The reveal of an opening's jamb (:func:`reveal_thickness`): the faces standing across the
#: wall at the jamb line, their centroids within this distance of it along the wall (m).
REVEAL_BAND_M = 0.1
#: ... facing along the wall within this angle (degrees) of its direction.
REVEAL_FACING_DEG = 30.0
#: ... between the opening's bottom and top less this margin (m): its sill, its head, a leaf's
#: gap and the rounded corners stay out.
REVEAL_MARGIN_M = 0.2
#: ... and covering at least this area (m2) at the jamb: a strip 5 cm deep over 0.5 m of its
#: height, more than a stray face.
REVEAL_MIN_AREA_M2 = 0.025
#: The depth of a reveal: this quantile (0-1) of how far its faces' corners reach behind the
#: face the opening was found on, so that a stray corner sets none.
REVEAL_DEPTH_QUANTILE = 0.9
#: The deepest reveal read (m): solid masonry exterior walls, 0.5-0.6 m. Not the pairing limit
#: of two faces into one wall (``WallParams.max_wall_thickness_m``, 8 in): exterior walls scanned
#: from inside are the ones seen from one side, and they are the thick ones (the synthetic
#: buildings' 0.25-0.35 m).
REVEAL_MAX_M = 0.6


def reveal_thickness(physical: tuple[PhysicalWall, ...], walls: FlatWalls, openings: Openings, mesh: Mesh) -> tuple[PhysicalWall, ...]:
    """The walls scanned from one side only with their thickness read from the reveals of their
    openings where those show it deeper than the default.

    Through a doorway or a window without its pane the scan sees the jambs' reveals, the faces
    across the wall's depth: how far they reach behind the scanned face is how thick the wall
    is there, or less (a window's frame, a door's leaf closed in it, stop the reveal short). So
    each opening's depth is the shallower of its two jambs' (a leaf opened outwards, nearly in
    line with one reveal, runs on beyond it), and a wall takes the deepest of its openings',
    up to :data:`REVEAL_MAX_M`, where it exceeds the default; the scanned face stays where it
    is and the centre line moves back. Exterior walls were drawn 15 cm thick (the default) where
    the synthetic buildings' are 25-35 cm, and the hinges of leaves opened outwards through them
    stood on the default's face.
    """
    if not len(openings) or not len(physical):
        return physical
    carrier = wall_of_face(physical, len(walls))
    cos_facing = np.cos(np.radians(REVEAL_FACING_DEG))
    vertical = np.flatnonzero(np.abs(mesh.face_normals[:, 1]) < np.sin(np.radians(REVEAL_FACING_DEG)))
    cxz = mesh.face_centroids[vertical][:, [0, 2]]
    cy = mesh.face_centroids[vertical, 1]
    depth_of: dict[int, float] = {}
    centers = openings.center(walls)
    for i in range(len(openings)):
        f = int(openings.wall[i])
        k = int(carrier[f]) if 0 <= f < len(carrier) else -1
        if k < 0 or physical[k].paired:
            continue
        low, high = float(openings.bottom[i]) + REVEAL_MARGIN_M, float(openings.top[i]) - REVEAL_MARGIN_M
        if high <= low:
            continue
        n, t, off = walls.normal[f], walls.tangent[f], float(walls.offset[f])
        width = float(openings.u_max[i] - openings.u_min[i])
        box = np.flatnonzero(np.all(np.abs(cxz - centers[i]) <= width / 2 + REVEAL_MAX_M + REVEAL_BAND_M, axis=1) & (cy >= low) & (cy <= high))
        faces = vertical[box]
        facing = np.abs(mesh.face_normals[faces][:, [0, 2]] @ t) >= cos_facing
        faces = faces[facing]
        corners = mesh.triangles[faces][..., [0, 2]]  # (k, 3, 2)
        across = corners @ n - off  # behind the face: negative
        u = mesh.face_centroids[faces][:, [0, 2]] @ t
        inside = (across.max(axis=1) <= REVEAL_BAND_M) & (across.min(axis=1) >= -(REVEAL_MAX_M + REVEAL_BAND_M))
        depths = []
        for u_j in (float(openings.u_min[i]), float(openings.u_max[i])):
            sel = inside & (np.abs(u - u_j) <= REVEAL_BAND_M)
            if float(mesh.face_areas[faces[sel]].sum()) < REVEAL_MIN_AREA_M2:
                break
            depths.append(float(np.quantile(-across[sel].min(axis=1), REVEAL_DEPTH_QUANTILE)))
        if len(depths) == 2:
            depth_of[k] = max(depth_of.get(k, 0.0), min(depths))
    out = []
    for k, w in enumerate(physical):
        depth = min(depth_of.get(k, 0.0), REVEAL_MAX_M)
        if depth <= w.thickness:
            out.append(w)
            continue
        n = walls.normal[w.faces[0]]
        shift = -(depth - w.thickness) / 2 * n  # the face stays; the centre line moves back
        start, end = np.asarray(w.start) + shift, np.asarray(w.end) + shift
        out.append(replace(w, start=(float(start[0]), float(start[1])), end=(float(end[0]), float(end[1])), thickness=depth, revealed=True))
    return tuple(out)


def wall_elements(
    physical: tuple[PhysicalWall, ...], rooms: tuple[Room, ...], stories: tuple[Story, ...], floor_reach_m: float, ceiling_reach_m: float
) -> tuple[PhysicalWall, ...]:
    """The walls with the rooms on each side, ``exterior`` (rooms on one side only) and their
    confidence (see the module's description)."""
    out = []
    for w in physical:
        a, b = np.asarray(w.start), np.asarray(w.end)
        # not near the ends: there a room beyond the corner, wrapping round the wall's end,
        # lies within the slack of a probe on the wall's outer side
        t = SIDE_SAMPLES[np.minimum(SIDE_SAMPLES, 1.0 - SIDE_SAMPLES) * w.length >= SIDE_PROBE_M + SIDE_SLACK_M]
        t = t if len(t) else np.array([0.5])
        base = a[None, :] + t[:, None] * (b - a)[None, :]
        n = w.normal
        reach = w.thickness / 2 + SIDE_PROBE_M
        front = _rooms_near(rooms, w.story, base + reach * n, SIDE_SLACK_M)
        back = _rooms_near(rooms, w.story, base - reach * n, SIDE_SLACK_M)
        exterior = bool(front) != bool(back)
        story = stories[w.story]
        moved = abs(w.joined[0]) + abs(w.joined[1])
        length = w.length
        floor_ok = w.bottom - story.floor <= floor_reach_m
        ceiling_ok = story.ceiling - w.top <= ceiling_reach_m
        if length < SHORT_WALL_M:
            level, why = "low", f"short ({length:.2f} m)"
        elif moved > LONG_JOIN_SHARE * length:
            level, why = "low", f"extended {moved:.2f} m across unscanned space"
        elif not w.paired and w.revealed:
            level, why = "medium", f"one face scanned (thickness {w.thickness:.2f} m from the reveals of its openings)"
        elif not w.paired:
            level, why = "medium", f"one face scanned (thickness assumed {w.thickness:.2f} m)"
        elif not (floor_ok and ceiling_ok):
            missing = "floor to ceiling" if not floor_ok and not ceiling_ok else "to the floor" if not floor_ok else "to the ceiling"
            level, why = "medium", f"both faces scanned, not {missing}"
        else:
            level, why = "high", "both faces scanned, floor to ceiling"
        out.append(replace(w, exterior=exterior, rooms=(tuple(sorted(front)), tuple(sorted(back))), confidence=level, confidence_reason=why))
    return tuple(out)


# --------------------------------------------------------------------------------------------
# Openings


@dataclass(frozen=True)
class Swing:
    """A door leaf seen in the scan: its hinge (plan point), which hand (``left`` or ``right``:
    the hinge's side seen from the room the leaf opens into, facing the door) and how far it
    stands open (degrees, 90 = square to the wall)."""

    hinge: tuple[float, float]
    hand: str
    angle_deg: float


@dataclass(frozen=True)
class OpeningElement:
    """What an opening is as a building element (one per row of :class:`Openings`).

    Attributes
    ----------
    wall
        Index of its physical wall (-1: none).
    clear_width, height
        Clear opening (m): between the jambs (less the open leaf, where one is seen) and from
        its bottom to the head.
    sill
        Windows: the sill's height above the story's floor (m); doors ``None``.
    connects
        The rooms on the side of the listed face's normal and on the other side: an index into
        the result's rooms, ``"outside"`` beyond an exterior wall, ``None`` where unknown.
    opens_to
        Doors whose leaf the scan shows: the side it opens into (as in ``connects``).
    swing
        The leaf (:class:`Swing`), ``None`` where the scan does not show it.
    confidence, confidence_reason
        high, medium or low, and why.
    """

    wall: int
    clear_width: float
    height: float
    sill: float | None
    connects: tuple[int | str | None, int | str | None]
    opens_to: int | str | None
    swing: Swing | None
    confidence: str
    confidence_reason: str

    def to_dict(self, ndigits: int = 4) -> dict[str, Any]:
        d: dict[str, Any] = {
            "physical_wall": self.wall,
            "clear_width": round(self.clear_width, ndigits),
            "height": round(self.height, ndigits),
            "sill": round(self.sill, ndigits) if self.sill is not None else None,
            "connects": list(self.connects),
            "opens_to": self.opens_to,
            "swing": None
            if self.swing is None
            else {"hinge": [round(v, ndigits) + 0.0 for v in self.swing.hinge], "hand": self.swing.hand, "angle_deg": round(self.swing.angle_deg, 1)},
            "confidence": {"level": self.confidence, "reason": self.confidence_reason},
        }
        return d


@dataclass(frozen=True, eq=False)
class _Near:
    """The near-vertical faces of the mesh around one opening (one pass over the mesh per
    opening; the tests below then look at a few thousand faces)."""

    xz: FloatArray
    y: FloatArray
    normal: FloatArray  # (k, 2) horizontal part
    area: FloatArray

    @classmethod
    def around(cls, every: _Near, center: FloatArray, radius: float) -> _Near:
        """The faces of ``every`` within ``radius`` (m, a square) of the plan point ``center``."""
        ok = np.flatnonzero((np.abs(every.xz[:, 0] - center[0]) <= radius) & (np.abs(every.xz[:, 1] - center[1]) <= radius))
        return cls(every.xz[ok], every.y[ok], every.normal[ok], every.area[ok])


def _hole_seen(near: _Near, walls: FlatWalls, face: int, u0: float, u1: float, bottom: float, top: float) -> bool:
    """Whether face ``face`` shows the opening ``[u0, u1] x [bottom, top]`` as a hole with wall
    beside both jambs (:data:`HOLE_EMPTY_SHARE`)."""
    if walls.u_min[face] > u0 - HOLE_INSET_M or walls.u_max[face] < u1 + HOLE_INSET_M:
        return False  # a jamb at the face's end: no wall seen beside it
    a, b = u0 + HOLE_INSET_M, u1 - HOLE_INSET_M
    lo, hi = bottom + HOLE_INSET_M, top - HOLE_INSET_M
    if b <= a or hi <= lo:
        return False
    n, t, off = walls.normal[face], walls.tangent[face], walls.offset[face]
    sel = (np.abs(near.xz @ n - off) <= HOLE_PLANE_M) & (near.normal @ n > 0.8)
    u = near.xz @ t
    sel &= (u >= a) & (u <= b) & (near.y >= lo) & (near.y <= hi)
    return float(near.area[sel].sum()) < HOLE_EMPTY_SHARE * (b - a) * (hi - lo)


def _hand(hinge: FloatArray, free: FloatArray, side: int, n: FloatArray) -> str:
    """Which hand a door is (``left``/``right``): seen from the room it opens into (on ``side``
    of the face with normal ``n``), facing the door, is the hinge left or right of the free end?"""
    # right of the viewer = the viewer's direction turned clockwise on the page (x right, z
    # down): (-d_z, d_x) for d = -side * n
    look = -side * n
    right = np.array([-look[1], look[0]])
    return "right" if float((hinge - free) @ right) > 0 else "left"


def _panel_line(p: FloatArray, normal: FloatArray, w: FloatArray) -> tuple[FloatArray, FloatArray, float]:
    """The line of a panel's faces (plan points ``p``, horizontal normals ``normal``, weights
    ``w``): ``(centroid, unit direction, rms distance of the points to the line)``. The
    direction is square to the faces' mean normal (the two sides of a leaf flipped to agree),
    not the points' principal axis, which tilts where one side of a leaf was seen further than
    the other."""
    c = np.average(p, axis=0, weights=w)
    ref = normal[int(np.argmax(w))]
    m = (normal * np.where(normal @ ref < 0, -1.0, 1.0)[:, None] * w[:, None]).sum(axis=0)
    d = np.array([-m[1], m[0]]) / max(float(np.linalg.norm(m)), 1e-12)
    q = p - c
    across = q @ np.array([-d[1], d[0]])
    return c, d, float(np.sqrt(np.average(across**2, weights=w)))


def _ajar_leaf(near: _Near, band: np.ndarray, n: FloatArray, t: FloatArray, off: float, u0: float, u1: float, thickness: float) -> tuple[int, Swing] | None:
    """A leaf standing ajar in the doorway ``[u0, u1]``
    (:data:`~meshplan.walls.flat.AJAR_MAX_TURN_DEG`): ``(side, swing)`` as :func:`door_leaf`
    gives, or ``None``."""
    width = u1 - u0
    u = near.xz @ t
    a = near.xz @ n - off
    cos_max = np.cos(np.radians(AJAR_MAX_TURN_DEG))
    sel = band & (u >= u0) & (u <= u1) & (a >= -thickness - AJAR_BEYOND_M) & (a <= AJAR_BEYOND_M) & (np.abs(near.normal @ n) >= cos_max)
    if not sel.any():
        return None
    us, as_, w = u[sel], a[sel], near.area[sel]
    if float(w.sum()) < LEAF_MIN_SHARE * width * (LEAF_BAND_M[1] - LEAF_BAND_M[0]) or float(us.max() - us.min()) < AJAR_LEAF_SPAN_SHARE * width:
        return None
    slope, icpt = np.polyfit(us, as_, 1, w=np.sqrt(w))
    rms = float(np.sqrt(np.average((as_ - (icpt + slope * us)) ** 2, weights=w)))
    angle = float(np.degrees(np.arctan(abs(slope))))
    # every face standing in the doorway is fitted (the leaf's edges too): within a leaf's thickness
    if rms > LEAF_THICKNESS_M or not AJAR_MIN_TURN_DEG <= angle <= AJAR_MAX_TURN_DEG:
        return None
    # the faces themselves must be turned that way (a closed leaf's noise fits no slope)
    turn = np.degrees(np.arctan2(-(near.normal[sel] @ t) * np.sign(near.normal[sel] @ n), np.abs(near.normal[sel] @ n)))
    if abs(float(np.average(turn, weights=w)) - float(np.degrees(np.arctan(slope)))) > AJAR_MIN_TURN_DEG:
        return None
    ends = (u0, icpt + slope * u0), (u1, icpt + slope * u1)
    middle = -thickness / 2
    free, hinge_end = sorted(ends, key=lambda e: -abs(e[1] - middle))
    side = 1 if free[1] > hinge_end[1] else -1
    hinge = hinge_end[0] * t + (off + hinge_end[1]) * n
    tip = free[0] * t + (off + free[1]) * n
    return side, Swing((float(hinge[0]), float(hinge[1])), _hand(hinge, tip, side, n), angle)


def door_leaf(
    near: _Near, walls: FlatWalls, face: int, u0: float, u1: float, thickness: float, floor: float, paired: bool = True
) -> tuple[int, Swing] | None:
    """The open leaf of a door ``[u0, u1]`` in face ``face`` of a wall ``thickness`` thick, if
    the scan shows it: ``(side, swing)`` with side +1 towards the face's normal, -1 beyond the
    wall; ``None`` when no leaf stands out (:data:`LEAF_MIN_SHARE`). ``paired``: the wall's
    thickness was measured (else the far face's plane is a default, and the hinge on it is
    placed from the leaf, :data:`LEAF_FIT_HINGE_MAX_DEG`). A leaf standing ajar is found by
    :func:`_ajar_leaf`."""
    n, t, off = walls.normal[face], walls.tangent[face], walls.offset[face]
    width = u1 - u0
    xz = near.xz
    band = (near.y >= floor + LEAF_BAND_M[0]) & (near.y <= floor + LEAF_BAND_M[1])
    sel = band & (np.abs(xz @ t - 0.5 * (u0 + u1)) <= 1.5 * width) & (np.abs(xz @ n - off + thickness / 2) <= thickness / 2 + width)
    idx = np.flatnonzero(sel)
    if not len(idx):
        return None
    p = xz[idx]
    nrm = near.normal[idx]
    area = near.area[idx]
    geometry = []
    for side in (1, -1):
        plane = off if side > 0 else off - thickness  # the face the leaf swings out of
        for u_h in (u0, u1):
            hinge = u_h * t + plane * n
            ray = p - hinge
            dist = np.linalg.norm(ray, axis=1)
            out = side * (p @ n - plane) > 0.02
            ok = out & (dist >= LEAF_REACH[0] * width) & (dist <= LEAF_REACH[1] * width)
            with np.errstate(invalid="ignore", divide="ignore"):
                cosr = np.abs(np.einsum("ij,ij->i", nrm, ray)) / np.maximum(dist, 1e-9)
            ok &= cosr <= LEAF_RAY_COS
            along = (ray @ t) * (1 if u_h == u0 else -1)  # towards the door's other jamb
            geometry.append((side, u_h, hinge, ok, along, dist))
    # a leaf within square first (it covers the doorway when closed); only where none is seen,
    # one opened past square, back over its wall: there it looks like the return of a wall
    # beside the jamb, which a door next to a corner has
    for max_open_deg in (90.0, LEAF_MAX_OPEN_DEG):
        scores = []
        for side, u_h, hinge, ok, along, dist in geometry:
            ok = ok & (along >= dist * np.cos(np.radians(max_open_deg)) - 0.05)
            scores.append((float(area[ok].sum()) / (width * (LEAF_BAND_M[1] - LEAF_BAND_M[0])), side, u_h, hinge, ok, along))
        scores.sort(key=lambda s: -s[0])
        best, second = scores[0], scores[1]
        if best[0] >= LEAF_MIN_SHARE and best[0] >= 2 * second[0]:
            break
    else:
        return _ajar_leaf(near, band, n, t, off, u0, u1, thickness)
    share, side, u_h, hinge, ok, along = best
    ray = p[ok] - hinge
    # the leaf's direction: the area-weighted median of the rays from the hinge (most of the
    # area is the leaf's; a wall or another leaf nearby is a minority), then the line fitted
    # through the faces near that ray
    each = np.arctan2((ray @ n) * side, along[ok])
    order = np.argsort(each)
    cum = np.cumsum(area[ok][order])
    angle = float(np.degrees(each[order][np.searchsorted(cum, 0.5 * cum[-1])]))
    sign_t = 1 if u_h == u0 else -1
    d0 = np.cos(np.radians(angle)) * sign_t * t + np.sin(np.radians(angle)) * side * n
    keep = np.abs(ray @ np.array([-d0[1], d0[0]])) <= 2 * LEAF_FIT_RMS_M
    if keep.sum() >= 3:
        c, d, rms = _panel_line(p[ok][keep], nrm[ok][keep], area[ok][keep])
        if rms <= LEAF_FIT_RMS_M:
            d = d if float(d @ d0) >= 0 else -d  # from the hinge to the leaf
            fitted = float(np.degrees(np.arctan2(float(d @ n) * side, float(d @ t) * sign_t)))
            if not paired and side < 0 and 0.0 < fitted <= LEAF_FIT_HINGE_MAX_DEG:
                # the far face was not scanned: the hinge is where the leaf meets the jamb. The
                # leaf turns about the corner of its face flush with the wall's face when closed:
                # its middle line meets the jamb half a leaf's thickness / cos(angle) short of it
                s_j = (u_h - float(c @ t)) / float(d @ t)
                hinge = c + s_j * d + side * n * (LEAF_THICKNESS_M / 2) / np.cos(np.radians(fitted))
            angle = fitted
    other = u1 if u_h == u0 else u0
    plane_h = float(hinge @ n)
    return side, Swing((float(hinge[0]), float(hinge[1])), _hand(hinge, other * t + plane_h * n, side, n), angle)


def opening_elements(
    openings: Openings,
    walls: FlatWalls,
    physical: tuple[PhysicalWall, ...],
    rooms: tuple[Room, ...],
    stories: tuple[Story, ...],
    mesh: Mesh,
    params: PlanParams | None = None,
) -> tuple[OpeningElement, ...]:
    """The :class:`OpeningElement` of every opening (``physical`` with their rooms, from
    :func:`wall_elements`); ``params`` are the detector's, whose size limits an opening's
    confidence reads."""
    params = params or PlanParams()
    door_w = (params.door_width_m[0], params.door_width_m[1] * (1 + ODD_WIDTH_MARGIN))
    window_w = (params.window_width_m[0], params.window_width_m[1] * (1 + ODD_WIDTH_MARGIN))
    carrier = wall_of_face(physical, len(walls))
    centers = openings.center(walls) if len(openings) else np.zeros((0, 2))
    #: faces standing within 30 degrees of vertical: walls, jambs and door leaves
    vertical = np.flatnonzero(np.abs(mesh.face_normals[:, 1]) < 0.5) if len(openings) else np.zeros(0, np.int64)
    c3 = mesh.face_centroids[vertical]
    every = _Near(c3[:, [0, 2]], c3[:, 1], mesh.face_normals[vertical][:, [0, 2]], mesh.face_areas[vertical])

    def element(i: int) -> OpeningElement:
        """The element of opening ``i``."""
        f = int(openings.wall[i])
        k = int(carrier[f]) if 0 <= f < len(carrier) else -1
        pw = physical[k] if k >= 0 else None
        story = stories[int(openings.story[i])]
        kind = openings.kind[i]
        thickness = pw.thickness if pw is not None else 0.0
        n = walls.normal[f]
        c = centers[i]
        sides: list[int | str | None] = []
        for pt in (c + OPENING_PROBE_M * n, c - (thickness + OPENING_PROBE_M) * n):
            beside = _rooms_near(rooms, int(openings.story[i]), pt[None, :], SIDE_SLACK_M)
            if beside:
                sides.append(min(beside, key=lambda j: float(rooms[j].polygon.distance(Point(pt)))))
            elif pw is not None and pw.exterior:
                sides.append("outside")
            else:
                sides.append(None)
        width = float(openings.u_max[i] - openings.u_min[i])
        height = float(openings.top[i] - openings.bottom[i])
        near = _Near.around(every, c, 2.0 * width + thickness + 0.5)
        swing = None
        opens_to: int | str | None = None
        if kind == "door":
            leaf = door_leaf(near, walls, f, float(openings.u_min[i]), float(openings.u_max[i]), thickness, story.floor, pw.paired if pw is not None else True)
            if leaf is not None:
                side, swing = leaf
                opens_to = sides[0] if side > 0 else sides[1]
        clear = width - (LEAF_THICKNESS_M if swing is not None else 0.0)  # to the open leaf's face
        # confidence: the hole in how many faces of the wall, and plausible sizes
        cuts = openings.faces[i] if i < len(openings.faces) and openings.faces[i] else ()
        if not cuts:
            cuts = ((f, openings.u_min[i], openings.u_max[i], openings.bottom[i], openings.top[i]),)
        seen_sides = {
            int(np.sign(float(walls.normal[g] @ n))) for g, u0, u1, b, t in cuts if _hole_seen(near, walls, int(g), float(u0), float(u1), float(b), float(t))
        }
        w_lo, w_hi = door_w if kind == "door" else window_w
        odd = not (w_lo <= width <= w_hi) or (kind == "door" and not params.door_height_m <= height <= DOOR_ODD_HEAD_M)
        if i < len(openings.source) and openings.source[i] == "parametric":
            level, why = "high", "the parametric model's own box"
        elif odd:
            level, why = "low", f"unusual size for a {kind} ({width:.2f} x {height:.2f} m)"
        elif i < len(openings.closed) and openings.closed[i]:
            # a recess of a door's shape: a closed door's leaf set back in its frame, or a niche
            level, why = "low", "a closed leaf set back in its frame, or a niche of a door's shape: check on site"
        elif i < len(openings.ragged) and openings.ragged[i]:
            level, why = "low", "part of its frame hidden by a hole in the scan: its width is an estimate"
        elif len(seen_sides) >= 2:
            level, why = "high", "frame seen on both faces of its wall"
        elif seen_sides:
            level, why = "medium", "frame seen on one face of its wall"
        else:
            level, why = "low", "no clear frame on either face (at the end of a scanned wall)"
        sill = float(openings.bottom[i] - story.floor) if kind == "window" else None
        return OpeningElement(k, clear, height, sill, (sides[0], sides[1]), opens_to, swing, level, why)

    # the openings looked at in threads (meshplan.geometry.SEARCH_THREADS: each looks at the
    # faces around it, numpy's and GEOS's work), the elements in the openings' order
    return tuple(in_threads(element, len(openings)))


def type_rooms(
    rooms: tuple[Room, ...], elements: tuple[OpeningElement, ...], kinds: tuple[str, ...], stairs: tuple[StairElement, ...] = ()
) -> tuple[Room, ...]:
    """The rooms with their type (a rooms.json type is kept) and confidence; a room holding one of
    the ``stairs`` found (:func:`meshplan.plan.stairs.find_stairs`) is a stairwell."""
    doors = [0] * len(rooms)
    for e, kind in zip(elements, kinds):
        if kind != "door":
            continue
        for k in {x for x in e.connects if isinstance(x, int)}:
            doors[k] += 1
    out = []
    for i, r in enumerate(rooms):
        level, why = ROOM_CONFIDENCE.get(r.closed_by, ("low", r.closed_by))
        held = [s for s in stairs if s.story == r.story and _holds_stair(r, s.footprint)]
        if r.type_reason == "rooms.json":
            kind, reason = r.type, "rooms.json"
        elif held:
            kind, reason = "stair", f"holds a stair of {held[0].risers} risers"
        else:
            kind, reason = room_type(r, doors[i])
        out.append(replace(r, type=kind, type_reason=reason, confidence=level, confidence_reason=why))
    # the upper end of a stair: the room above it
    for i, r in enumerate(out):
        if r.type_reason == "rooms.json" or r.type == "stair" or r.story == 0:
            continue
        for below in out:
            if below.story == r.story - 1 and below.type == "stair":
                share = r.polygon.intersection(below.polygon).area / max(min(r.area, below.area), 1e-9)
                if share >= STAIR_ABOVE_SHARE:
                    out[i] = replace(r, type="stair", type_reason=f"above the stair {below.number or below.label}")
                    break
    return tuple(out)


def _holds_stair(room: Room, footprint: Polygon) -> bool:
    """The room holds most of the stair and the stair a good share of it (its stairwell)."""
    common = room.polygon.intersection(footprint).area
    return common >= 0.5 * footprint.area and footprint.area >= STAIR_ROOM_SHARE * room.area


def rooms_document(rooms: tuple[Room, ...], ndigits: int = 4) -> dict[str, Any]:
    """A rooms.json to edit and pass back with ``--rooms``: number, name, type, story, centre
    and polygon of every room."""
    items = []
    for r in rooms:
        c = r.polygon.representative_point()
        items.append(
            {
                "story": r.story,
                "number": r.number,
                "name": r.name or r.label,
                "type": r.type,
                "center": [round(c.x, ndigits) + 0.0, round(c.y, ndigits) + 0.0],
                "polygon": (np.round(np.asarray(r.polygon.exterior.coords)[:-1], ndigits) + 0.0).tolist(),
            }
        )
    return {"rooms": items}


# --------------------------------------------------------------------------------------------
# The drafting plan, with what is low-confidence set apart


@dataclass(frozen=True, eq=False)
class MarkedDrafting(DraftingPlan):
    """A drafting plan whose low-confidence walls, rooms and openings are listed apart, so that
    the drawing shows them dashed (as RoomPlan does).

    Attributes
    ----------
    dashed
        ``(S, 2, 2)``: the cut segments (of ``slices``) of low-confidence walls.
    solid
        ``(S, 2, 2)``: the other cut segments.
    low_rooms
        Closed rings ``[x, z]`` of the low-confidence rooms.
    low_openings
        ``(N, 2, 2)``: each low-confidence opening as its span on its wall face.
    """

    dashed: FloatArray = field(default_factory=lambda: np.zeros((0, 2, 2)))
    solid: FloatArray = field(default_factory=lambda: np.zeros((0, 2, 2)))
    low_rooms: tuple[FloatArray, ...] = ()
    low_openings: FloatArray = field(default_factory=lambda: np.zeros((0, 2, 2)))


def mark_low_confidence(
    plan: DraftingPlan,
    walls: FlatWalls,
    physical: tuple[PhysicalWall, ...],
    rooms: tuple[Room, ...],
    openings: Openings,
    elements: tuple[OpeningElement, ...],
) -> MarkedDrafting:
    """``plan`` with its low-confidence elements set apart (:class:`MarkedDrafting`): each cut
    segment belongs to the face whose plane and span hold its middle."""
    story = plan.story.index
    seg = np.asarray(plan.slices.segments, dtype=np.float64).reshape(-1, 2, 2)
    carrier = wall_of_face(physical, len(walls))
    low_face = np.array([carrier[f] >= 0 and physical[carrier[f]].confidence == "low" for f in range(len(walls))], dtype=bool)
    low = np.zeros(len(seg), dtype=bool)
    mine = np.flatnonzero(walls.story == story)
    if len(seg) and len(mine):
        mid = seg.mean(axis=1)
        dist = np.abs(mid @ walls.normal[mine].T - walls.offset[mine][None, :])
        u = mid @ walls.tangent[mine].T
        inside = (u >= walls.u_min[mine][None, :] - 0.01) & (u <= walls.u_max[mine][None, :] + 0.01)
        dist = np.where(inside, dist, np.inf)
        best = np.argmin(dist, axis=1)
        ok = np.isfinite(dist[np.arange(len(seg)), best]) & (dist[np.arange(len(seg)), best] < 0.02)
        low[ok] = low_face[mine[best[ok]]]
    rings = tuple(np.asarray(r.polygon.exterior.coords) for r in rooms if r.story == story and r.confidence == "low")
    spans = []
    for i in np.flatnonzero(openings.story == story):
        if i < len(elements) and elements[i].confidence == "low":
            w = int(openings.wall[i])
            t, n, off = walls.tangent[w], walls.normal[w], walls.offset[w]
            spans.append([openings.u_min[i] * t + off * n, openings.u_max[i] * t + off * n])
    return MarkedDrafting(
        plan.story, plan.height, plan.slices, seg[low], seg[~low], rings, np.array(spans, dtype=np.float64).reshape(-1, 2, 2)
    )

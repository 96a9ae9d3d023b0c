"""Parametric room models, the way Apple RoomPlan (and Polycam's Room mode, Meta's scene model)
export them: no scanned surface at all, only boxes and polygons.

* every wall face is a thin box of 12 triangles, floor to ceiling, centred on the wall plane
  (0.1 mm thick by default: two coincident faces; with 0 thickness the four degenerate faces of
  its rim are left out, and 4 triangles remain);
* the floor of every room is its polygon, triangulated;
* no ceiling;
* doors and windows are boxes of their own in the wall plane (``openings="boxes"``, RoomPlan's
  USDZ), or holes: the wall is then several boxes around them (``openings="holes"``);
* every furniture item, stair step and door leaf is its bounding box.

No noise, no holes, no bevels: perfect planes.
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import Polygon

from ..geometry import BOX_CORNERS, BOX_FACES, FloatArray, IntArray
from .fixtures import Leaf, item_bounds
from .furniture import Item
from .layout import Building, Wall
from .tessellate import SURFACE_KINDS, Box

#: What a parametric model makes of doors and windows.
OPENING_MODES = ("boxes", "holes")

_UP = np.array([0.0, 1.0, 0.0])


def box_triangles(center: FloatArray, half: FloatArray, rotation: FloatArray) -> tuple[FloatArray, IntArray]:
    """The 8 corners and 12 outward triangles of a box (faces of a flat box whose rim has no
    area are left out)."""
    r = np.asarray(rotation, dtype=np.float64)
    if np.linalg.det(r) < 0:  # keep the triangles outward
        r = r * np.array([1.0, 1.0, -1.0])
    verts = np.asarray(center, dtype=np.float64) + (2.0 * BOX_CORNERS * np.asarray(half, dtype=np.float64)) @ r.T
    t = verts[BOX_FACES]
    area = 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1)
    return verts, BOX_FACES[area > 1e-12]


def _wall_box(w: Wall, u0: float, u1: float, y0: float, y1: float, thickness: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    a = np.array([w.direction[0], 0.0, w.direction[1]])
    n = np.array([w.normal[0], 0.0, w.normal[1]])
    c2 = w.point(0.5 * (u0 + u1))
    center = np.array([c2[0], 0.5 * (y0 + y1), c2[1]])
    return center, np.array([0.5 * (u1 - u0), 0.5 * (y1 - y0), 0.5 * thickness]), np.stack([a, _UP, n], axis=1)


def _wall_parts(b: Building, wi: int, holes: bool) -> list[tuple[float, float, float, float]]:
    """``(u0, u1, y0, y1)`` rectangles making up wall face ``wi`` (around its openings with ``holes``)."""
    w = b.walls[wi]
    if not holes:
        return [(0.0, w.length, w.bottom, w.top)]
    ops = sorted(b.wall_openings(wi), key=lambda o: o.u_m)
    parts, u = [], 0.0
    for o in ops:
        a, c = o.u_m - o.width_m / 2, o.u_m + o.width_m / 2
        if a > u:
            parts.append((u, a, w.bottom, w.top))
        if o.kind == "window" and o.bottom > w.bottom:
            parts.append((a, c, w.bottom, o.bottom))
        if o.top < w.top:
            parts.append((a, c, o.top, w.top))
        u = c
    if u < w.length:
        parts.append((u, w.length, w.bottom, w.top))
    return parts


def parametric_mesh(
    b: Building, items: list[Item], leaves: list[Leaf], thickness_m: float, openings: str
) -> tuple[FloatArray, IntArray, IntArray, list[str], IntArray, IntArray]:
    """The parametric model of the building (truth frame).

    Returns
    -------
    vertices, faces
        The mesh (every object has its own vertices).
    face_groups, group_names
        Object of every face: ``<room>`` (its floor), ``wall<i>``, an opening's label, a
        furniture item's name, ``stair<k>``, ``<door>_leaf``.
    face_kinds, face_walls
        Surface kind (index into :data:`SURFACE_KINDS`) and truth wall (-1 if none) of every face.
    """
    verts: list[FloatArray] = []
    faces: list[IntArray] = []
    groups: list[int] = []
    kinds: list[int] = []
    walls: list[int] = []
    names: list[str] = []
    count = 0

    def emit(v: FloatArray, f: IntArray, group: int, kind: str, wall: int = -1) -> None:
        nonlocal count
        verts.append(v)
        faces.append(f + count)
        count += len(v)
        groups.extend([group] * len(f))
        kinds.extend([SURFACE_KINDS.index(kind)] * len(f))
        walls.extend([wall] * len(f))

    def box(bx: Box, group: int, kind: str) -> None:
        v, f = box_triangles(bx.center, bx.half, bx.rotation)
        emit(v, f, group, kind)

    for r, room in enumerate(b.rooms):  # floors: each room's polygon, facing up
        names.append(room.label)
        floor = b.stories[room.story][0]
        tris = shapely.constrained_delaunay_triangles(Polygon(room.polygon))
        for tri in shapely.get_parts(tris):
            xz = np.asarray(tri.exterior.coords)[:3]
            v = np.c_[xz[:, 0], np.full(3, floor), xz[:, 1]]
            f = np.array([[0, 1, 2]])
            if np.cross(v[1] - v[0], v[2] - v[0])[1] < 0:
                f = f[:, ::-1]
            emit(v, f.copy(), r, "floor")
    for wi, w in enumerate(b.walls):
        g = len(names)
        names.append(f"wall{wi}")
        for u0, u1, y0, y1 in _wall_parts(b, wi, openings == "holes"):
            c, h, rot = _wall_box(w, u0, u1, y0, y1, thickness_m)
            v, f = box_triangles(c, h, rot)
            emit(v, f, g, "wall", wi)
    if openings == "boxes":
        for o in b.openings:
            if not o.primary:
                continue
            g = len(names)
            names.append(o.label)
            c, h, rot = _wall_box(b.walls[o.wall], o.u_m - o.width_m / 2, o.u_m + o.width_m / 2, o.bottom, o.top, thickness_m)
            v, f = box_triangles(c, h, rot)
            emit(v, f, g, "opening")
    for k, st in enumerate(b.stairs):
        g = len(names)
        names.append(f"stair{k + 1}")
        for bx in st.boxes:
            box(bx, g, "stair")
    for it in items:
        g = len(names)
        names.append(it.name)
        box(item_bounds(it.boxes), g, "furniture")
    for lf in leaves:
        g = len(names)
        names.append(f"{lf.label}_leaf")
        box(lf.box, g, "door_leaf")
    v = np.concatenate(verts)
    f = np.concatenate(faces)
    return v, f, np.array(groups, dtype=np.int64), names, np.array(kinds, dtype=np.int64), np.array(walls, dtype=np.int64)

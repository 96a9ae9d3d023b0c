"""A parametric model's own elements in the plan: RoomPlan's doors, windows, openings and objects.

A RoomPlan export (:class:`meshplan.io.usd.RoomPlanElements`) states what a scan leaves to be
found: where each door, window and opening is, how wide and how high, in which wall, and which
boxes are furniture. :func:`apply_parametric` uses them, in the plan frame, after the stages have
found the walls and the openings from the geometry (the same triangles a PLY conversion of the
export holds):

* **objects out of the wall evidence**: the faces of the object boxes (storage, tables, sofas,
  beds, televisions...) are taken out of the stories (:attr:`Orientation.face_story` -1) and the
  flat walls found again, so that a bookcase's front never becomes a wall. Only where a wall
  found leans on such faces: otherwise the walls, their pairing and the openings found stay
  exactly as they are. A face is an object's when its three corners lie within
  :data:`BOX_TOLERANCE_M` of the box and not within it of a wall box (the back of a cabinet
  against a wall is the wall's);
* **doors and windows from their boxes**: each door, window and opening box is put on the flat
  wall face that holds it (parallel, its plane through the box, the box's middle on the face) with
  its width along the wall, its bottom and top (so the sill), and cut out of every face of that
  wall it passes through. RoomPlan's ``opening`` (a doorway without a leaf) is a door when it
  reaches down to the floor (:data:`DOORWAY_SILL_M`), else a window. Boxes of one opening listed
  twice (RoomPlan does so on coincident walls) are one. An opening found in the geometry that a
  box overlaps is replaced by the box's; one no box explains is kept (``source`` "detected").

The result's openings say where each came from (:attr:`~meshplan.plan.openings.Openings.source`:
``parametric`` or ``detected``); a parametric one is a high-confidence element (the model's own
box, :func:`meshplan.plan.elements.opening_elements`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace

import numpy as np

from ..geometry import FloatArray, IntArray, Mesh
from ..io.usd import RoomPlanElements
from ..orient import Orientation
from ..orient.stories import assign_faces
from ..walls import FlatWalls, PhysicalWall, WallParams, find_flat_walls, physical_walls
from .openings import PARALLEL_DEG, SAME_OPENING_OVERLAP, Openings

log = logging.getLogger(__name__)

__all__ = ["BOX_TOLERANCE_M", "DOORWAY_SILL_M", "OPENING_PLANE_M", "ParametricPlan", "apply_parametric", "object_faces"]

#: A face belongs to a box when its three corners lie within this distance (metres) of it: 1 cm,
#: far above the float32 rounding of RoomPlan's coordinates (a few micrometres at 10 m) and far
#: below any furniture's size; a large floor or wall triangle passing under or behind a box has
#: corners far outside it.
BOX_TOLERANCE_M = 0.01

#: Largest distance (metres) from an opening box's middle to the plane of the flat wall face
#: that holds it: RoomPlan's door and window boxes are 0.5 mm deep and lie in their wall's
#: 0.1 mm box, so a few millimetres in practice; 15 cm also takes in a wall face found a wall's
#: thickness away (the other side of a paired wall).
OPENING_PLANE_M = 0.15

#: RoomPlan's ``opening`` is a door (a doorway) when its bottom is at most this far (metres)
#: above the story's floor, else a window (a pass-through with a sill): a threshold is a few
#: centimetres, the lowest sill of a pass-through some 0.5 m.
DOORWAY_SILL_M = 0.1

#: RoomPlan's kinds of the openings in a wall and the kind each is in the plan (``opening`` by
#: its sill, :data:`DOORWAY_SILL_M`).
_OPENING_KINDS = {"door": "door", "window": "window", "opening": None}

#: Point-box pairs tested at a time: 1 million keep the temporary arrays (3 coordinates of 8
#: bytes a pair, twice) near 50 MB whatever the numbers of faces and boxes.
_CHUNK_PAIRS = 1_000_000


@dataclass(frozen=True, eq=False)
class ParametricPlan:
    """What the pipeline uses from a parametric model (see the module docstring).

    Attributes
    ----------
    walls, physical
        The flat wall faces and their pairing into physical walls (found again without the
        object faces where any wall leaned on them, else those given).
    openings
        The doors and windows: the model's boxes, and the openings found that no box explains.
    object_faces
        ``(F,)`` whether each face of the mesh is part of an object box.
    walls_refound
        Whether the walls were found again without the object faces.
    """

    walls: FlatWalls
    physical: tuple[PhysicalWall, ...]
    openings: Openings
    object_faces: np.ndarray
    walls_refound: bool


def _to_plan(corners: FloatArray, scale_to_m: float, transform: FloatArray) -> FloatArray:
    """Box corners from input coordinates (file units) into the plan frame."""
    return (corners * scale_to_m) @ transform[:3, :3].T + transform[:3, 3]


def _frames(corners: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Each box's origin corner, unit edge directions ``(B, 3, 3)`` and edge lengths ``(B, 3)``
    (corner order of :data:`meshplan.geometry.BOX_CORNERS`)."""
    origin = corners[:, 0]
    edges = np.stack([corners[:, 4] - origin, corners[:, 2] - origin, corners[:, 1] - origin], axis=1)
    length = np.linalg.norm(edges, axis=2)
    return origin, edges / np.maximum(length, 1e-12)[..., None], length


def _inside(points: FloatArray, corners: FloatArray, tol: float) -> np.ndarray:
    """``(P,)`` whether each point lies within ``tol`` of any of the boxes (whole-array, in
    chunks of :data:`_CHUNK_PAIRS` point-box pairs)."""
    out = np.zeros(len(points), dtype=bool)
    if not len(corners) or not len(points):
        return out
    origin, axes, length = _frames(corners)
    step = max(1, _CHUNK_PAIRS // len(corners))
    for lo in range(0, len(points), step):
        rel = points[lo : lo + step, None, :] - origin[None]
        s = np.einsum("pbk,bjk->pbj", rel, axes)
        out[lo : lo + step] = np.any(np.all((s >= -tol) & (s <= length[None] + tol), axis=2), axis=1)
    return out


def object_faces(mesh: Mesh, object_corners: FloatArray, wall_corners: FloatArray, tol: float = BOX_TOLERANCE_M) -> np.ndarray:
    """``(F,)`` whether each face of ``mesh`` is part of an object box: its three corners within
    ``tol`` of one of ``object_corners`` and not all within ``tol`` of one of ``wall_corners``
    (boxes as ``(B, 8, 3)`` corners in the mesh's frame)."""
    tri = mesh.triangles.reshape(-1, 3)
    in_object: np.ndarray = np.asarray(_inside(tri, object_corners, tol).reshape(-1, 3).all(axis=1))
    if not in_object.any():
        return in_object
    cand = np.flatnonzero(in_object)
    in_wall = _inside(mesh.triangles[cand].reshape(-1, 3), wall_corners, tol).reshape(-1, 3).all(axis=1)
    in_object[cand[in_wall]] = False
    return in_object


def _leaning_walls(walls: FlatWalls, mesh: Mesh, objects: np.ndarray) -> np.ndarray:
    """``(W,)`` whether each flat wall's faces include object faces."""
    fw = walls.face_walls()
    if len(fw) != mesh.n_faces or not len(walls):
        return np.zeros(len(walls), dtype=bool)
    hit = fw[objects & (fw >= 0)]
    return np.bincount(hit, minlength=len(walls)) > 0


@dataclass(frozen=True)
class _Box:
    """One opening box placed on its wall face."""

    story: int
    kind: str
    wall: int
    u_min: float
    u_max: float
    bottom: float
    top: float
    cuts: tuple[tuple[int, float, float, float, float], ...]


def _holding_faces(walls: FlatWalls, story: int, centre: FloatArray, along: FloatArray, half_width: float) -> IntArray:
    """The flat wall faces of ``story`` that could hold an opening whose middle is ``centre``
    ([x, z]) and whose width (``2 half_width``) runs along ``along`` (unit [x, z]): parallel, the
    plane within :data:`OPENING_PLANE_M`, the opening overlapping the face's extent. Faces whose
    extent holds the middle come first, then the others, each nearest plane first."""
    if not len(walls):
        return np.zeros(0, np.int64)
    sin_tol = np.sin(np.radians(PARALLEL_DEG))
    dist = np.abs(walls.normal @ centre - walls.offset)
    u = walls.tangent @ centre
    ok = (
        (walls.story == story)
        & (np.abs(walls.normal @ along) <= sin_tol)
        & (dist <= OPENING_PLANE_M)
        & (u + half_width >= walls.u_min)
        & (u - half_width <= walls.u_max)
    )
    idx = np.flatnonzero(ok)
    outside = (u[idx] < walls.u_min[idx]) | (u[idx] > walls.u_max[idx])
    return idx[np.lexsort((dist[idx], outside))]


def _on_walls(
    walls: FlatWalls, physical: tuple[PhysicalWall, ...], story: int, xz: FloatArray, along: FloatArray, bottom: float, top: float
) -> tuple[int, float, float, tuple[tuple[int, float, float, float, float], ...]] | None:
    """An opening spanning the plan points ``xz`` (its corners or ends) along ``along``, put on
    the flat wall face that holds it: ``(face, u_min, u_max, cuts)`` with the rectangle to cut
    out of every face it passes through (those holding it and their partners in a physical
    wall, as :func:`meshplan.plan.openings.find_openings` lists them); ``None`` where no face
    holds it (its wall was not found)."""
    centre = xz.mean(axis=0)
    half = 0.5 * float(np.ptp(xz @ along))
    faces = _holding_faces(walls, story, centre, along, half)
    if not len(faces):
        return None
    wall = int(faces[0])
    u = xz @ walls.tangent[wall]
    partner = {int(f): tuple(int(g) for g in pw.faces) for pw in physical for f in pw.faces}
    cut_faces = [wall] + [int(f) for f in faces[1:]]
    for f in list(cut_faces):
        cut_faces.extend(g for g in partner.get(f, ()) if g not in cut_faces)
    cuts = []
    for f in cut_faces:
        proj = xz @ walls.tangent[f]  # the opening's span along face f, clipped to the face
        a, b = max(float(proj.min()), float(walls.u_min[f])), min(float(proj.max()), float(walls.u_max[f]))
        if b > a:
            cuts.append((f, a, b, bottom, top))
    return wall, float(u.min()), float(u.max()), tuple(cuts)


def _place(walls: FlatWalls, physical: tuple[PhysicalWall, ...], orientation: Orientation, kind: str, corners: FloatArray) -> _Box | None:
    """An opening box (plan-frame corners) on the flat wall face holding it; ``None`` where no
    face does (its wall was not found)."""
    bottom, top = float(corners[:, 1].min()), float(corners[:, 1].max())
    story = int(assign_faces(np.array([0.5 * (bottom + top)]), orientation.stories)[0])
    xz = corners[:, [0, 2]]
    # the width runs along the box's longest horizontal edge (x, y, z edges: corners 4, 2, 1 from 0)
    edges = xz[[4, 2, 1]] - xz[0]
    along = edges[int(np.argmax(np.linalg.norm(edges, axis=1)))]
    along = along / max(float(np.linalg.norm(along)), 1e-12)
    placed = _on_walls(walls, physical, story, xz, along, bottom, top)
    if placed is None:
        return None
    if kind not in ("door", "window"):
        kind = "door" if bottom - orientation.stories[story].floor <= DOORWAY_SILL_M else "window"
    wall, u0, u1, cuts = placed
    return _Box(story, kind, wall, u0, u1, bottom, top, cuts)


def _same_opening(walls: FlatWalls, a_wall: int, a: tuple[float, float], b_wall: int, b: tuple[float, float], story_a: int, story_b: int) -> bool:
    """Whether two openings (their faces and spans along them) are one: same story, parallel
    faces within :data:`OPENING_PLANE_M` of each other, spans overlapping by at least
    :data:`~meshplan.plan.openings.SAME_OPENING_OVERLAP` of the narrower."""
    if story_a != story_b:
        return False
    if abs(float(walls.normal[a_wall] @ walls.normal[b_wall])) < np.cos(np.radians(PARALLEL_DEG)):
        return False
    mid_b = walls.offset[b_wall] * walls.normal[b_wall] + 0.5 * (b[0] + b[1]) * walls.tangent[b_wall]
    if abs(float(walls.normal[a_wall] @ mid_b) - walls.offset[a_wall]) > OPENING_PLANE_M:
        return False
    ends = [float(walls.tangent[a_wall] @ (walls.offset[b_wall] * walls.normal[b_wall] + u * walls.tangent[b_wall])) for u in b]
    lo, hi = min(ends), max(ends)
    overlap = min(a[1], hi) - max(a[0], lo)
    return overlap >= SAME_OPENING_OVERLAP * min(a[1] - a[0], hi - lo)


def _remap_openings(openings: Openings, old_walls: FlatWalls, new_walls: FlatWalls, physical: tuple[PhysicalWall, ...]) -> Openings:
    """Openings found on ``old_walls`` put on the faces of ``new_walls`` (the walls found again,
    paired into ``physical``) that hold them; those on no face of ``new_walls`` dropped."""
    rows = []
    for i in range(len(openings)):
        w = int(openings.wall[i])
        ends = old_walls.offset[w] * old_walls.normal[w] + np.outer([openings.u_min[i], openings.u_max[i]], old_walls.tangent[w])
        b, t = float(openings.bottom[i]), float(openings.top[i])
        placed = _on_walls(new_walls, physical, int(openings.story[i]), ends, old_walls.tangent[w], b, t)
        if placed is not None:
            f, u0, u1, cuts = placed
            rows.append((int(openings.story[i]), openings.kind[i], f, u0, u1, b, t, cuts))
    return _openings(rows, ["detected"] * len(rows))


def _openings(rows: list[tuple], source: list[str]) -> Openings:
    """Rows ``(story, kind, wall, u_min, u_max, bottom, top, cuts)`` sorted by story, wall and
    position, as :class:`~meshplan.plan.openings.Openings` with their ``source``."""
    order = sorted(range(len(rows)), key=lambda i: (rows[i][0], rows[i][2], rows[i][3]))
    rows, source = [rows[i] for i in order], [source[i] for i in order]
    return Openings(
        story=np.array([r[0] for r in rows], dtype=np.int64),
        kind=tuple(r[1] for r in rows),
        wall=np.array([r[2] for r in rows], dtype=np.int64),
        u_min=np.array([r[3] for r in rows], dtype=np.float64),
        u_max=np.array([r[4] for r in rows], dtype=np.float64),
        bottom=np.array([r[5] for r in rows], dtype=np.float64),
        top=np.array([r[6] for r in rows], dtype=np.float64),
        faces=tuple(r[7] for r in rows),
        source=tuple(source),
    )


def apply_parametric(
    elements: RoomPlanElements,
    scale_to_m: float,
    mesh: Mesh,
    orientation: Orientation,
    walls: FlatWalls,
    physical: tuple[PhysicalWall, ...],
    openings: Openings,
    wall_params: WallParams | None = None,
) -> ParametricPlan:
    """The walls, their pairing and the openings of a parametric model, from its own elements.

    Parameters
    ----------
    elements
        The model's boxes, in input coordinates (:class:`meshplan.io.usd.RoomPlanElements`).
    scale_to_m
        Metres per input unit (:attr:`meshplan.io.LoadStats.scale_to_m`).
    mesh
        The model in the plan frame.
    orientation
        Its transform (input metres to the plan frame), stories and wall directions.
    walls, physical, openings
        What the stages found in the geometry.
    wall_params
        The flat wall parameters (to find the walls again, and pair them).

    Returns
    -------
    ParametricPlan
    """
    wall_params = wall_params or WallParams()
    corners = _to_plan(np.asarray(elements.corners, np.float64), scale_to_m, orientation.transform)
    wall_rows, object_rows = elements.of_kind("wall"), elements.objects
    objects = object_faces(mesh, corners[object_rows], corners[wall_rows])
    leaning = _leaning_walls(walls, mesh, objects)
    refound = bool(leaning.any())
    detected: Openings = openings
    if refound:
        masked = replace(orientation, face_story=np.where(objects, -1, orientation.face_story))
        new_walls = find_flat_walls(mesh, masked, wall_params)
        physical = physical_walls(new_walls, wall_params.max_wall_thickness_m, wall_params.default_wall_thickness_m)
        detected = _remap_openings(openings, walls, new_walls, physical)
        walls = new_walls
        log.info("parametric model: %d object faces left out of the walls (%d walls leaned on them)", int(objects.sum()), int(leaning.sum()))
    boxes: list[_Box] = []
    unplaced = []
    for i in elements.of_kind(*_OPENING_KINDS):
        box = _place(walls, physical, orientation, elements.kind[i], corners[i])
        if box is None:
            unplaced.append(elements.name[i])
            continue
        if any(b.kind == box.kind and _same_opening(walls, b.wall, (b.u_min, b.u_max), box.wall, (box.u_min, box.u_max), b.story, box.story) for b in boxes):
            continue  # listed twice (on coincident walls)
        boxes.append(box)
    if unplaced:
        log.warning("parametric model: no wall found for %s; not placed", ", ".join(unplaced))
    rows = [(b.story, b.kind, b.wall, b.u_min, b.u_max, b.bottom, b.top, b.cuts) for b in boxes]
    source = ["parametric"] * len(rows)
    for i in range(len(detected)):
        w, span, st = int(detected.wall[i]), (float(detected.u_min[i]), float(detected.u_max[i])), int(detected.story[i])
        if any(_same_opening(walls, b.wall, (b.u_min, b.u_max), w, span, b.story, st) for b in boxes):
            continue  # the box's measures replace the geometry's
        b, t = float(detected.bottom[i]), float(detected.top[i])
        cuts = detected.faces[i] if i < len(detected.faces) and detected.faces[i] else ((w, span[0], span[1], b, t),)
        rows.append((st, detected.kind[i], w, span[0], span[1], b, t, cuts))
        source.append("detected")
    return ParametricPlan(walls=walls, physical=physical, openings=_openings(rows, source), object_faces=objects, walls_refound=refound)

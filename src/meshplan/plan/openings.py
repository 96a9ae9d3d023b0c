"""Doors and windows: openings in the flat walls (not in the paper, which left them to future work).

Each flat wall face is searched for openings by :mod:`meshplan.plan.doors`: gaps in a raster of
the wall's slab (both its faces and collinear pieces, so a door between two pieces of wall, seen
from one side only, or next to a corner is found) and, in parametric models, separate door panels
in the wall plane. The bands next to the floor and the ceiling are ignored (scanners round the
corners off there).

* a *door* reaches down to the floor, is ``door_width_m`` wide, has straight jambs and a head at
  least ``door_height_m`` high with wall above it; where the scan missed the lintel, a gap up to
  the ceiling is a door only when the floor is seen through it (a full-height gap in an outer
  wall is a missing piece of scan, not a door);
* a *window* has wall below it (a sill at least ``window_sill_m`` above the floor) and above it,
  and straight edges all round.

Random holes in a scan are ragged and are left alone. The opening's edges are refined from the
triangle corners along them, well below the grid cell.

A wall seen from both rooms shows each of its openings on both faces: the finds of the faces of
one physical wall (and of collinear pieces) that overlap along it are one opening, with the
clear width and height where both were measured (the narrower jambs, the lower head), listed on
one face and cut out of every face it passes through (``faces``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import FloatArray, IntArray, Mesh, in_threads
from ..orient import Orientation
from ..walls import FlatWalls, PhysicalWall, WallParams, physical_walls
from ..walls.flat import AJAR_MIN_TURN_DEG, segment_distances
from .doors import EDGE_CELLS, LEAF_MIN_TURN_DEG, Candidate, WallEvidence, wall_candidates
from .params import PlanParams

#: Two finds on parallel faces are one opening when their intervals along the wall overlap by
#: at least this share of the narrower (the two faces of a doorway measure nearly the same
#: jambs; two doors side by side do not overlap at all).
SAME_OPENING_OVERLAP = 0.5
#: Faces within this angle (degrees) are parallel for merging: the faces of one wall share a
#: wall direction, whose members are exactly parallel.
PARALLEL_DEG = 10.0


@dataclass(frozen=True, eq=False)
class Openings:
    """Doors and windows, one row each (parallel arrays); ``u_min``/``u_max`` are along the
    wall's tangent, ``bottom``/``top`` heights in the plan frame."""

    story: IntArray
    kind: tuple[str, ...]
    wall: IntArray
    u_min: FloatArray
    u_max: FloatArray
    bottom: FloatArray
    top: FloatArray
    #: Per opening, the flat wall faces it passes through, each with the rectangle
    #: ``(face, u_min, u_max, bottom, top)`` to cut out of it (in that face's own ``u``); the
    #: listed ``wall`` first. Empty: only ``wall`` (openings made by hand).
    faces: tuple[tuple[tuple[int, float, float, float, float], ...], ...] = ()
    #: Per opening, where it came from: ``detected`` (found in the geometry) or ``parametric``
    #: (a door, window or opening box of a parametric model, :mod:`meshplan.plan.parametric`).
    #: Empty: every opening detected.
    source: tuple[str, ...] = ()
    #: Per opening, whether every find of it was a closed leaf set back in its frame
    #: (:data:`meshplan.plan.doors.LEAF_SET_BACK_M`): a recess of a door's shape, which a
    #: closed door and a niche of that shape both are. Empty: none was.
    closed: tuple[bool, ...] = ()
    #: Per opening, whether a hole in the scan hid part of its frame in every face it was found
    #: in (:attr:`meshplan.plan.doors.Candidate.ragged`): its width is an estimate. Empty: none.
    ragged: tuple[bool, ...] = ()

    def __len__(self) -> int:
        return int(len(self.wall))

    @property
    def width(self) -> FloatArray:
        return self.u_max - self.u_min

    def center(self, walls: FlatWalls) -> FloatArray:
        """``(N, 2)`` plan position [x, z] of each opening's middle on its wall."""
        u = 0.5 * (self.u_min + self.u_max)
        return u[:, None] * walls.tangent[self.wall] + walls.offset[self.wall][:, None] * walls.normal[self.wall]

    def holes(self) -> dict[int, list[tuple[float, float, float, float]]]:
        """Wall index -> rectangles ``(u_min, u_max, bottom, top)`` to cut out of the flat walls."""
        out: dict[int, list] = {}
        for i in range(len(self)):
            cuts = self.faces[i] if i < len(self.faces) and self.faces[i] else ((int(self.wall[i]), self.u_min[i], self.u_max[i], self.bottom[i], self.top[i]),)
            for face, u0, u1, b, t in cuts:
                out.setdefault(int(face), []).append((u0, u1, b, t))
        return out

    def reindexed(self, new_index: IntArray) -> Openings:
        """The openings on walls renumbered by ``new_index`` (old wall -> new, -1 where the wall
        was dropped, :meth:`meshplan.walls.FlatWalls.without`): an opening whose listed wall was
        dropped is dropped, and a dropped face is no longer cut."""
        keep = np.flatnonzero(new_index[self.wall] >= 0) if len(self) else np.zeros(0, np.int64)

        def per_row(values: tuple) -> tuple:
            return tuple(values[i] for i in keep) if values else ()

        faces = tuple(
            tuple((int(new_index[f]), *rest) for f, *rest in cuts if new_index[f] >= 0) for cuts in per_row(self.faces)
        )
        return Openings(
            story=self.story[keep],
            kind=tuple(self.kind[i] for i in keep),
            wall=new_index[self.wall[keep]],
            u_min=self.u_min[keep],
            u_max=self.u_max[keep],
            bottom=self.bottom[keep],
            top=self.top[keep],
            faces=faces,
            source=per_row(self.source),
            closed=per_row(self.closed),
            ragged=per_row(self.ragged),
        )

    def to_list(self, walls: FlatWalls, ndigits: int = 4) -> list[dict]:
        c = self.center(walls)
        return [
            {
                "story": int(self.story[i]),
                "kind": self.kind[i],
                "wall": int(self.wall[i]),
                "center": (np.round(c[i], ndigits) + 0.0).tolist(),
                "width": round(float(self.width[i]), ndigits),
                "bottom": round(float(self.bottom[i]), ndigits),
                "top": round(float(self.top[i]), ndigits),
            }
            for i in range(len(self))
        ]


def _empty() -> Openings:
    z = np.zeros(0)
    return Openings(np.zeros(0, np.int64), (), np.zeros(0, np.int64), z, z, z, z, ())


def find_openings(
    mesh: Mesh,
    orientation: Orientation,
    walls: FlatWalls,
    params: PlanParams | None = None,
    physical: tuple[PhysicalWall, ...] | None = None,
) -> Openings:
    """Doors and windows in every flat wall, one per physical opening.

    Parameters
    ----------
    mesh
        The mesh in the plan frame.
    orientation
        Its stories (floors and ceilings).
    walls
        The flat wall faces searched.
    params
        Thresholds (:class:`PlanParams`).
    physical
        The faces paired into physical walls (:func:`meshplan.walls.physical_walls`), whose
        faces' openings are one; by default paired here with the default wall parameters.
    """
    params = params or PlanParams()
    if not len(walls):
        return _empty()
    if physical is None:
        wp = WallParams()
        physical = physical_walls(walls, wp.max_wall_thickness_m, wp.default_wall_thickness_m)
    thickness = np.full(len(walls), np.nan)
    for pw in physical:
        thickness[list(pw.faces)] = pw.thickness
    ev = WallEvidence(mesh, walls, params, thickness)

    def search(w: int) -> list[Candidate]:
        story = orientation.stories[int(walls.story[w])]
        return wall_candidates(ev, w, story.floor, story.ceiling)

    # the walls searched in threads (meshplan.geometry.SEARCH_THREADS), the candidates taken
    # in the walls' order, as one thread finds them
    found: list[Candidate] = [c for cands in in_threads(search, len(walls)) for c in cands]
    found = _without_leaf_windows(found, walls, params)
    if not found:
        return _empty()
    rows = _merge(found, walls, physical, params)
    rows.sort(key=lambda r: (int(walls.story[r[1]]), r[1], r[2]))
    return Openings(
        story=np.array([walls.story[r[1]] for r in rows], dtype=np.int64),
        kind=tuple(r[0] for r in rows),
        wall=np.array([r[1] for r in rows], dtype=np.int64),
        u_min=np.array([r[2] for r in rows]),
        u_max=np.array([r[3] for r in rows]),
        bottom=np.array([r[4] for r in rows]),
        top=np.array([r[5] for r in rows]),
        faces=tuple(r[6] for r in rows),
        closed=tuple(bool(r[7]) for r in rows),
        ragged=tuple(bool(r[8]) for r in rows),
    )


#: A leaf's hinge lies this close (m) to the flat wall found on the leaf: the hinge stands on a
#: jamb of the door, on either face of the wall, and that flat wall stops 5-15 cm short of it
#: where the scan rounds the corner between leaf and frame.
LEAF_HINGE_M = 0.2
#: A leaf standing ajar (turned from its wall by :data:`~meshplan.walls.flat.AJAR_MIN_TURN_DEG`
#: up to :data:`LEAF_MIN_TURN_DEG`) lies within its wall's depth across at least this share of
#: its door's width (cos 10 degrees, less the rounded corners at hinge and frame): a piece of a
#: drifting wall beside the door does not.
AJAR_SPAN_SHARE = 0.8
#: A leaf's free end meets no other wall within this distance (m): a return wall or a closet's
#: side beside a door, as short as a leaf, meets the wall across at its far end.
LEAF_FREE_END_M = 0.15


def door_leaves(walls: FlatWalls, openings: Openings, params: PlanParams | None = None) -> np.ndarray:
    """``(W,)`` which flat walls are the leaves of doors standing open, not walls.

    A door leaf open by :data:`LEAF_MIN_TURN_DEG` or more is a vertical panel as tall as a
    door, and the wall stage takes it for a short wall at an angle (drawn across the room it
    opens into, it splits that room). It is a leaf of a door found in a wall when it turns from
    that wall, passes within :data:`LEAF_HINGE_M` of one of the door's jambs (the line across
    the wall's depth at either side of the door, where the hinge stands on one face), lies
    within the door's width of that jamb (inside the leaf's swing), and its end away from the
    jamb meets no other wall (:data:`LEAF_FREE_END_M`; a leaf already found is none, nor is
    another face within the swing of a leaf at the same jamb: the leaf's other face): a short
    return or a closet's side beside a door meets the wall across.
    """
    params = params or PlanParams()
    out = np.zeros(len(walls), dtype=bool)
    if not len(walls) or not len(openings):
        return out
    start, end = walls.start, walls.end
    cos_turn, cos_ajar = np.cos(np.radians(LEAF_MIN_TURN_DEG)), np.cos(np.radians(AJAR_MIN_TURN_DEG))
    front, back = params.opening_slab_m, params.opening_wall_depth_m + params.opening_slab_m
    for i in np.flatnonzero(np.array(openings.kind) == "door"):
        f = int(openings.wall[i])
        n, t, off = walls.normal[f], walls.tangent[f], float(walls.offset[f])
        width = float(openings.u_max[i] - openings.u_min[i])
        # the two jambs, each across the wall's depth (the slab the door was found in)
        jamb_s = np.array([u * t + (off + front) * n for u in (openings.u_min[i], openings.u_max[i])])
        jamb_e = np.array([u * t + (off - back) * n for u in (openings.u_min[i], openings.u_max[i])])
        story = walls.story == openings.story[i]
        cos_n = np.abs(walls.normal @ n)
        turned = cos_n < cos_turn
        # the door's own wall: parallel faces within its depth
        mid = 0.5 * (start + end)
        within = (mid @ n - off <= front + 1e-9) & (mid @ n - off >= -back - 1e-9)
        own = ~turned & within
        # a leaf standing ajar lies in the doorway, across most of its width
        lo_t, hi_t = np.minimum(start @ t, end @ t), np.maximum(start @ t, end @ t)
        spans = np.minimum(hi_t, openings.u_max[i]) - np.maximum(lo_t, openings.u_min[i]) >= AJAR_SPAN_SHARE * width
        ajar = ~turned & (cos_n < cos_ajar) & within & spans
        cand = np.flatnonzero(story & (turned | ajar) & ~out)
        if not len(cand):
            continue
        hinge = segment_distances(start[cand], end[cand], jamb_s, jamb_e)  # (candidates, 2 jambs)
        # the candidates within the swing of a leaf hinged at each jamb: by it, and no farther
        # from it than the door is wide
        to_start = segment_distances(start[cand], start[cand], jamb_s, jamb_e)  # (candidates, 2 jambs)
        to_end = segment_distances(end[cand], end[cand], jamb_s, jamb_e)
        swung = (hinge <= LEAF_HINGE_M) & (np.maximum(to_start, to_end) <= width + LEAF_HINGE_M)
        # twice: a piece of a leaf whose end meets the leaf's main face (the corner at its
        # hinge, clustered apart) is taken once that face is known to be a leaf
        for k, L in [*enumerate(cand), *enumerate(cand)]:
            if out[L]:
                continue
            j = int(np.argmin(hinge[k]))
            if not swung[k, j]:
                continue
            free = end[L] if to_end[k, j] > to_start[k, j] else start[L]
            # other walls the free end may meet: not the door's own wall, not a face parallel
            # to this one, nor another face within the same leaf's swing: the leaf's other face,
            # whose short pieces by the hinge may turn 10-12 degrees from this one (hard seed 1:
            # both faces of a leaf's first 0.45 m kept as walls, each meeting the other)
            others = story & ~own & ~ajar & ~out & (np.abs(walls.normal @ walls.normal[L]) < cos_turn)
            others[cand[swung[:, j]]] = False
            if not np.any(segment_distances(free[None], free[None], start[others], end[others]) <= LEAF_FREE_END_M):
                out[L] = True
    return out


def _along(walls: FlatWalls, src: int, dst: int, u: float) -> float:
    """``u`` along face ``src`` at its plane, as ``u`` along face ``dst``."""
    p = walls.offset[src] * walls.normal[src] + u * walls.tangent[src]
    return float(walls.tangent[dst] @ p)


def _without_leaf_windows(found: list[Candidate], walls: FlatWalls, params: PlanParams) -> list[Candidate]:
    """``found`` without the windows whose head was not scanned (:func:`meshplan.plan.doors._headless_windows`)
    that stand between the jambs of a door found on a parallel face of the same wall: a leaf
    closed flush with one face and scanned lower than the wall beside it leaves the band above it
    empty there, a "window" on its sill, while the other face shows the doorway."""
    tol = EDGE_CELLS * params.opening_cell_m
    depth = params.opening_wall_depth_m + 2 * params.opening_slab_m
    cos = np.cos(np.radians(PARALLEL_DEG))
    doors = [c for c in found if c.kind == "door"]

    def explained(c: Candidate) -> bool:
        for d in doors:
            if walls.story[d.wall] != walls.story[c.wall] or abs(float(walls.normal[d.wall] @ walls.normal[c.wall])) < cos:
                continue
            mid = walls.offset[c.wall] * walls.normal[c.wall] + 0.5 * (c.u_min + c.u_max) * walls.tangent[c.wall]
            if abs(float(walls.normal[d.wall] @ mid) - walls.offset[d.wall]) > depth:
                continue
            lo, hi = sorted((_along(walls, c.wall, d.wall, c.u_min), _along(walls, c.wall, d.wall, c.u_max)))
            if abs(lo - d.u_min) <= tol and abs(hi - d.u_max) <= tol:
                return True
        return False

    return [c for c in found if not (c.kind == "window" and c.how == "head unseen" and explained(c))]


def _merge(found: list[Candidate], walls: FlatWalls, physical: tuple[PhysicalWall, ...], params: PlanParams) -> list[tuple]:
    """One row ``(kind, wall, u_min, u_max, bottom, top, cuts, closed, ragged)`` per physical opening.

    Finds of one kind on parallel faces of a story whose planes lie within a wall's depth and
    whose intervals overlap, along the wall and in height, are the same opening (union-find
    over the pairs).
    """
    n = len(found)
    parent = list(range(n))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    depth = params.opening_wall_depth_m + 2 * params.opening_slab_m
    cos = np.cos(np.radians(PARALLEL_DEG))
    for i in range(n):
        a = found[i]
        for j in range(i + 1, n):
            b = found[j]
            if a.kind != b.kind or walls.story[a.wall] != walls.story[b.wall]:
                continue
            if abs(float(walls.normal[a.wall] @ walls.normal[b.wall])) < cos:
                continue
            mid_b = walls.offset[b.wall] * walls.normal[b.wall] + 0.5 * (b.u_min + b.u_max) * walls.tangent[b.wall]
            if abs(float(walls.normal[a.wall] @ mid_b) - walls.offset[a.wall]) > depth:
                continue
            lo_b, hi_b = sorted((_along(walls, b.wall, a.wall, b.u_min), _along(walls, b.wall, a.wall, b.u_max)))
            overlap = min(a.u_max, hi_b) - max(a.u_min, lo_b)
            # and over each other's heights: two finds one above the other (the spaces between
            # shelves) are not one opening, whose merged sill would stand above its head
            rise = min(a.top, b.top) - max(a.bottom, b.bottom)
            if overlap >= SAME_OPENING_OVERLAP * min(a.u_max - a.u_min, hi_b - lo_b) and rise >= SAME_OPENING_OVERLAP * min(a.top - a.bottom, b.top - b.bottom):
                parent[root(j)] = root(i)
    groups: dict[int, list[int]] = {}
    for i in range(n):
        groups.setdefault(root(i), []).append(i)
    partner: dict[int, tuple[int, ...]] = {}
    for pw in physical:
        for f in pw.faces:
            partner[int(f)] = tuple(int(g) for g in pw.faces)
    rows = []
    for members in groups.values():
        cands = [found[i] for i in members]
        rows.append(_one_opening(cands, walls, partner, params))
    return rows


def _one_opening(cands: list[Candidate], walls: FlatWalls, partner: dict[int, tuple[int, ...]], params: PlanParams) -> tuple:
    """The merged opening of the finds ``cands`` of one physical opening."""
    # listed on a face that holds it (its centre on the face), the lowest index among those
    ref = cands[0].wall
    lo = [_along(walls, c.wall, ref, c.u_min) for c in cands]
    hi = [_along(walls, c.wall, ref, c.u_max) for c in cands]
    spans = [sorted(p) for p in zip(lo, hi)]
    mid = float(np.median([0.5 * (a + b) for a, b in spans]))
    faces = sorted({c.wall for c in cands})

    def holds(f: int) -> bool:
        u = _along(walls, ref, f, mid)
        return bool(walls.u_min[f] - params.opening_cell_m <= u <= walls.u_max[f] + params.opening_cell_m)

    wall = next((f for f in faces if holds(f)), faces[0])
    spans = [sorted((_along(walls, c.wall, wall, c.u_min), _along(walls, c.wall, wall, c.u_max))) for c in cands]
    # the clear opening: the narrower jambs and the lower head that any face measured, unless
    # the finds disagree so much that they barely overlap (then their medians)
    u0, u1 = max(s[0] for s in spans), min(s[1] for s in spans)
    if u1 - u0 < SAME_OPENING_OVERLAP * float(np.median([s[1] - s[0] for s in spans])):
        u0, u1 = float(np.median([s[0] for s in spans])), float(np.median([s[1] for s in spans]))
    kind = cands[0].kind
    bottom = max(c.bottom for c in cands)
    top = min(c.top for c in cands)
    cut_faces = [wall] + [f for f in faces if f != wall]
    for f in list(cut_faces):
        cut_faces.extend(g for g in partner.get(f, ()) if g not in cut_faces)
    cuts = []
    for f in cut_faces:
        a, b = sorted((_along(walls, wall, f, u0), _along(walls, wall, f, u1)))
        a, b = max(a, float(walls.u_min[f])), min(b, float(walls.u_max[f]))
        if b > a:
            cuts.append((int(f), a, b, float(bottom), float(top)))
    closed = all(c.how == "leaf" for c in cands)
    ragged = all(c.ragged for c in cands)
    return (kind, int(wall), float(u0), float(u1), float(bottom), float(top), tuple(cuts), closed, ragged)

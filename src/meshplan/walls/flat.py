"""Flat walls (paper, Algorithm 3, lines 2-13): wall directions, box DBSCAN, filtering, plane
fitting, rectangle construction and mesh replacement.

For each story and wall direction, the centroids of the triangles facing that way are clustered
by :func:`~meshplan.walls.boxdbscan.box_dbscan` in wall coordinates (along the wall, across it,
up). A cluster is a *wall segment*. The paper keeps a segment when it is long enough and reaches
near the floor and near the ceiling; here (issue 9) each segment is cut into columns and only
its runs of columns with the evidence of a wall are kept (:mod:`meshplan.walls.evidence`): a top
that reaches the ceiling or, where none was scanned near it, the top of what was scanned around
it, a height above any work surface, no counter or desk top attached behind its top edge, no
surface facing the same way behind it (or, above the first story, a continuation of a wall of
the story below in the same plane: a double-height wall whose top the scanner did not reach).
A run must be long enough and come near the floor. The boxes of parametric models thicker than
a wall (their furniture, :mod:`~meshplan.walls.solids`) are no evidence; pieces standing out
of a longer wall (pilasters), pillars with the ceiling scanned all round them, free-standing
panels and short fragments connected to no wall with their tops lost below door height are
dropped (:func:`_pilasters`, :func:`_free_standing`), and so are the fronts and sides of cupboards
and wardrobes against a wall (:func:`_pilasters`, :func:`_box_sides`) and the outer faces of a
parametric model's exterior walls (:func:`_outer_faces`); a segment is cut where a wall crosses it
(:func:`_split_at_crossings`), and a story whose walls stop short of its scanned ceiling is judged
as one without a ceiling (:func:`_walls_short_of`). Its plane faces the wall direction and
passes through the area-weighted median of the centroids across the wall; its rectangle spans
its triangles along the wall and in height. Faces larger than half a box are split first, so
that the centroids of parametric models (two triangles a wall) sample their surfaces. Coplanar rectangles of one direction
separated by less than ``merge_gap_m`` are one wall, so that a door or a missing strip does not split it (an addition to the paper).

Why one long module: the stage is one pipeline of array steps over the same segment tables
(cluster, judge, straighten, merge, build rectangles), each feeding the next its intermediate
arrays; split, they would pass a dozen parallel arrays across module boundaries. The per-strip
evidence lives in :mod:`~meshplan.walls.evidence`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import partial

import numpy as np
from scipy.special import fdtri, stdtrit  # F and Student t quantiles, without importing scipy.stats (0.4 s)

from .._kernels import centroids_areas, scatter_max, scatter_min
from ..geometry import FloatArray, IntArray, Mesh, in_threads, max3
from ..orient import Orientation, Story
from .boxdbscan import box_dbscan
from .evidence import (
    CEILING_TOLERANCE_M,
    EDGE_WALL_MIN_SEEN_M,
    EDGE_WALL_MIN_TOP_M,
    FLOOR_CLEARANCE_M,
    MIN_COLUMN_SPAN_SHARE,
    MIN_TOP_SHARE,
    RASTER_M,
    SPLIT_SHARE,
    Columns,
    StoryRaster,
    behind_top,
    ceiling_behind,
    columns,
    floor_behind,
    group_weighted_median,
    hidden_behind,
    local_top,
    neighbour_max,
    runs,
    seen_in_front,
    story_raster,
    subdivide,
    top_around,
    top_attached,
    work_surface_height,
    work_surface_in_front,
)
from .params import WallParams
from .solids import object_boxes

#: A wall keeps the direction of its cluster unless its own direction differs from it
#: significantly (besides ``snap_deg``), at this two-sided confidence: a short or wavy piece,
#: whose few columns do not tell its direction better than its cluster does, is drawn along
#: the cluster. The bound is Student's t quantile for the columns' degrees of freedom times
#: the standard error of the fitted angle: three columns (0.7 m) need a 13 times larger
#: deviation than the error, ten columns 2.3 times.
SNAP_CONFIDENCE = 0.95

#: Two pieces of wall are one plane only when their directions differ by at most this angle
#: (degrees): the scatter of the directions fitted to pieces of one wall on either side of a
#: door (0.3-1 degree), far below the kinks of a drifted scan (3-8 degrees), which stay chords.
MERGE_DEG = 2.0

#: Two walls are connected when they come this close in plan (m): the corners that scans leave
#: open or rounded (headset meshes bevel corners over 0.1-0.2 m, and the segments stop where
#: the faces turn past the facing tolerance), plus a partition's thickness for a return that
#: meets the other face of a wall.
CONNECT_M = 0.3

#: A piece of wall with the floor scanned behind it along at least this share of its length
#: has been walked around: half of it, so that a wall with a short gap of floor seen through a
#: door behind it is not taken for a free-standing panel.
FLOOR_BEHIND_SHARE = 0.5

#: Deepest protrusion of a pilaster (m; :func:`_pilasters`): pilasters, engaged columns, chimney
#: breasts and the wardrobes and cupboards that stand against a wall stand out of it by 0.1-0.65 m
#: (fitted wardrobes and kitchen units are 0.6 m deep, plus a door's or a worktop's overhang and
#: the scan's noise); a room behind a wall, or a corridor, lies deeper (0.8 m and more), and a
#: step of a wall has the wall behind it on one side only.
PILASTER_DEPTH_M = 0.7

#: Longest front standing out of a wall that is taken for a cupboard or a wardrobe against it
#: (m; :func:`_pilasters`): free-standing wardrobes and cupboard runs are 1.0-2.4 m wide. A
#: longer piece in front of a wall is a wall of its own (a lining, the wall of a corridor).
BUILT_IN_FRONT_M = 2.4

#: A piece of wall and the wall behind it face the same way when their directions differ by at
#: most this angle (degrees): a wall drifted by the scanner over its length bends by 3-8 degrees.
PILASTER_PARALLEL_DEG = 10.0

#: Vertical faces facing no wall direction (farther than the facing tolerance from every one)
#: get a direction of their own when this much area (m2) faces within 5 degrees of one
#: azimuth: a wall 0.8 m long (a chamfered corner, a single wall at an odd angle) seen floor
#: to ceiling in a 2.5 m storey, more than the side of a wardrobe or an open door leaf.
FILL_MIN_AREA_M2 = 2.0

#: ... and when that area is at least this many times what the faces facing no direction
#: hold on average per 10 degrees: the normals of headset meshes scatter over every azimuth
#: (1-2 m2 per 10 degrees in a large hall), and only a wall stands out of that scatter.
FILL_PEAK_RATIO = 3.0

#: Lowest top of a parapet under a window (m above the floor; :func:`_wall_columns`): window
#: sills stand 0.4-1.2 m high (0.3 m is the lowest :class:`~meshplan.plan.params.PlanParams`
#: takes), above a skirting board's or a step's top.
PARAPET_MIN_M = 0.3

#: A face is vertical for the direction search when its normal is within this angle of the
#: horizontal (degrees), as in the wall alignment.
VERTICAL_DEG = 10.0


@dataclass(frozen=True, eq=False)
class FlatWalls:
    """Flat wall rectangles of every story, as parallel arrays (one row per wall).

    A wall lies in the vertical plane ``normal . (x, z) = offset`` and spans ``[u_min, u_max]``
    along ``tangent = (-normal_z, normal_x)`` and ``[bottom, top]`` in height. ``normal`` points
    into the room the face was scanned from.

    Attributes
    ----------
    face_segment
        ``(F,)`` DBSCAN segment of every face of the mesh, -1 for faces in none (for the
        segment drawings); ``segment_kept`` says which segments became walls and
        ``segment_wall`` which wall each became (-1 for dropped segments).
    """

    story: IntArray
    direction: IntArray
    normal: FloatArray
    offset: FloatArray
    u_min: FloatArray
    u_max: FloatArray
    bottom: FloatArray
    top: FloatArray
    support: IntArray
    area: FloatArray
    directions: FloatArray
    face_segment: IntArray
    segment_story: IntArray
    segment_kept: np.ndarray
    segment_wall: IntArray

    def __len__(self) -> int:
        return int(len(self.story))

    @classmethod
    def from_rows(
        cls,
        rows: list[dict],
        directions: FloatArray,
        face_segment: IntArray | None = None,
        segment_story: IntArray | None = None,
        segment_kept: np.ndarray | None = None,
        segment_wall: IntArray | None = None,
    ) -> FlatWalls:
        """The walls of the wall stage's rows (dicts with the attributes' keys and ``normal`` a
        pair), in their order; the segments none where not given."""
        col = lambda key, dtype=np.float64: np.array([r[key] for r in rows], dtype=dtype)  # noqa: E731
        none = np.zeros(0, dtype=np.int64)
        return cls(
            story=col("story", np.int64),
            direction=col("direction", np.int64),
            normal=np.array([r["normal"] for r in rows], dtype=np.float64).reshape(-1, 2),
            offset=col("offset"),
            u_min=col("u_min"),
            u_max=col("u_max"),
            bottom=col("bottom"),
            top=col("top"),
            support=col("support", np.int64),
            area=col("area"),
            directions=np.asarray(directions, dtype=np.float64),
            face_segment=none if face_segment is None else face_segment,
            segment_story=none if segment_story is None else segment_story,
            segment_kept=np.zeros(0, dtype=bool) if segment_kept is None else segment_kept,
            segment_wall=none if segment_wall is None else segment_wall,
        )

    @property
    def tangent(self) -> FloatArray:
        """``(W, 2)`` unit tangents, ``(-normal_z, normal_x)`` (``np.stack``: ``np.c_`` costs
        0.3 ms a call, and the opening search asks for it hundreds of times)."""
        return np.stack([-self.normal[:, 1], self.normal[:, 0]], axis=1)

    @property
    def start(self) -> FloatArray:
        """``(W, 2)`` plan coordinates [x, z] of one end."""
        return self.u_min[:, None] * self.tangent + self.offset[:, None] * self.normal

    @property
    def end(self) -> FloatArray:
        return self.u_max[:, None] * self.tangent + self.offset[:, None] * self.normal

    @property
    def length(self) -> FloatArray:
        return self.u_max - self.u_min

    def face_walls(self) -> IntArray:
        """``(F,)`` wall of every face of the mesh, -1 for faces in no wall."""
        seg = self.face_segment
        out = np.full(len(seg), -1, dtype=np.int64)
        ok = seg >= 0
        out[ok] = self.segment_wall[seg[ok]]
        return out

    def without(self, drop: np.ndarray) -> tuple[FlatWalls, IntArray]:
        """These walls without the rows where ``drop`` is true, and the new index of every old
        row (-1 where dropped); the segments of the dropped rows are kept as dropped segments
        (for the segment drawings)."""
        keep = ~np.asarray(drop, dtype=bool)
        new_index = np.where(keep, np.cumsum(keep) - 1, -1).astype(np.int64)
        seg_wall = np.where(self.segment_wall >= 0, new_index[np.maximum(self.segment_wall, 0)], -1) if len(self) else self.segment_wall
        rows = {name: getattr(self, name)[keep] for name in ("story", "direction", "normal", "offset", "u_min", "u_max", "bottom", "top", "support", "area")}
        return replace(self, **rows, segment_kept=self.segment_kept & (seg_wall >= 0), segment_wall=seg_wall), new_index

    def mesh(self, story: int | None = None, holes: dict[int, list[tuple[float, float, float, float]]] | None = None) -> Mesh:
        """The mesh replacement: two triangles per rectangle, normals into the rooms.

        Parameters
        ----------
        story
            Only the walls of this story.
        holes
            Openings to cut out: wall index -> ``(u_min, u_max, bottom, top)`` rectangles. The
            wall is cut into vertical strips at the openings' sides and each strip keeps what is
            not in an opening.
        """
        idx = np.flatnonzero(np.ones(len(self), bool) if story is None else self.story == story)
        pieces = []  # (wall, u0, u1, y0, y1)
        for i in idx:
            cuts = sorted((holes or {}).get(int(i), []))
            if not cuts:
                pieces.append((i, self.u_min[i], self.u_max[i], self.bottom[i], self.top[i]))
                continue
            xs = sorted({self.u_min[i], self.u_max[i], *[min(max(c[k], self.u_min[i]), self.u_max[i]) for c in cuts for k in (0, 1)]})
            for u0, u1 in zip(xs[:-1], xs[1:]):
                if u1 - u0 <= 1e-9:
                    continue
                mid = 0.5 * (u0 + u1)
                gaps = sorted((c[2], c[3]) for c in cuts if c[0] < mid < c[1])
                y = self.bottom[i]
                for g0, g1 in gaps:
                    if g0 > y:
                        pieces.append((i, u0, u1, y, min(g0, self.top[i])))
                    y = max(y, g1)
                if y < self.top[i]:
                    pieces.append((i, u0, u1, y, self.top[i]))
        if not pieces:
            return Mesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64))
        arr = np.array(pieces, dtype=np.float64)
        w = arr[:, 0].astype(np.int64)
        tan, nor, off = self.tangent[w], self.normal[w], self.offset[w]
        s = arr[:, 1, None] * tan + off[:, None] * nor
        e = arr[:, 2, None] * tan + off[:, None] * nor
        b, t = arr[:, 3], arr[:, 4]
        n = len(s)
        v = np.empty((n, 4, 3))
        v[:, 0] = np.c_[s[:, 0], b, s[:, 1]]
        v[:, 1] = np.c_[e[:, 0], b, e[:, 1]]
        v[:, 2] = np.c_[e[:, 0], t, e[:, 1]]
        v[:, 3] = np.c_[s[:, 0], t, s[:, 1]]
        base = (np.arange(n) * 4)[:, None]
        # (start, top, end) turns the normal towards +normal: see tests
        faces = np.concatenate([base + [0, 3, 2], base + [0, 2, 1]])
        return Mesh(v.reshape(-1, 3), faces)

    def to_list(self, ndigits: int = 4) -> list[dict]:
        """JSON-ready walls for plan.json."""
        r = lambda a: np.round(np.asarray(a, dtype=np.float64), ndigits).tolist()  # noqa: E731
        s, e = self.start, self.end
        return [
            {
                "story": int(self.story[i]),
                "start": r(s[i]),
                "end": r(e[i]),
                "normal": r(self.normal[i]),
                "length": round(float(self.length[i]), ndigits),
                "bottom": round(float(self.bottom[i]), ndigits),
                "top": round(float(self.top[i]), ndigits),
                "points": int(self.support[i]),
            }
            for i in range(len(self))
        ]


def wall_directions(
    orientation: Orientation,
    mode: str,
    normals: FloatArray | None = None,
    areas: FloatArray | None = None,
    facing_tolerance_deg: float = 25.0,
    centroids: FloatArray | None = None,
) -> FloatArray:
    """``(D, 2)`` unit plan normals [nx, nz] the DBSCAN runs on.

    The principal directions are the exact axes (the alignment put the dominant walls on
    them); other directions are the k-means centres. With ``normals`` and ``areas`` (the faces
    of the stories, plan frame) and a mode other than ``principal``, vertical faces that face
    none of these directions (beyond ``facing_tolerance_deg``) add a direction wherever
    :data:`FILL_MIN_AREA_M2` of them face one azimuth: a wall at any angle has a direction to
    be found in, even one too small to make a cluster of the alignment's k-means.
    """
    axes = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
    others = [d.normal[[0, 2]] for d in orientation.alignment.directions if not d.principal]
    out = [a for a in axes]
    if mode != "principal":
        for o in others:
            o = o / np.linalg.norm(o)
            if all(o @ a < np.cos(np.radians(10.0)) for a in out):
                out.append(o)
    if mode == "principal" or normals is None or areas is None:
        return np.array(out) if mode != "principal" and (mode == "all" or others) else axes
    vertical = np.abs(normals[:, 1]) < np.sin(np.radians(VERTICAL_DEG))
    plan = normals[vertical][:, [0, 2]]
    plan = plan / np.maximum(np.sqrt(plan[:, 0] * plan[:, 0] + plan[:, 1] * plan[:, 1]), 1e-12)[:, None]  # np.linalg.norm(plan, axis=1)
    w = areas[vertical]
    cos_tol = np.cos(np.radians(facing_tolerance_deg))
    az = np.degrees(np.arctan2(plan[:, 1], plan[:, 0])) % 360.0
    found = len(out) > 4 or mode == "all"
    centres = np.radians(np.arange(360) + 0.5)
    compass = np.c_[np.cos(centres), np.sin(centres)]
    where = centroids[vertical][:, [0, 2]] if centroids is not None else None
    for _ in range(16):  # at most 16 directions more: one every 22 degrees
        left = _row_max(plan @ np.array(out).T) < cos_tol
        if not left.any():
            break
        hist = np.bincount(np.floor(az[left]).astype(np.int64) % 360, weights=w[left], minlength=360)
        smooth = np.sum([np.roll(hist, k) for k in range(-5, 6)], axis=0)  # +-5 degrees
        uncovered = _row_max(compass @ np.array(out).T) < cos_tol
        background = 11.0 * float(hist[uncovered].mean()) if uncovered.any() else 0.0
        chosen = None
        # the peaks in order of area: the first that stands out of the scatter, or (given
        # the faces' positions) whose faces lie in one plane, as a wall's do
        least = FILL_MIN_PLANE_M2 if where is not None else FILL_MIN_AREA_M2
        peaks = np.flatnonzero((smooth >= np.roll(smooth, 1)) & (smooth > np.roll(smooth, -1)) & (smooth >= least))
        for j in peaks[np.argsort(-smooth[peaks], kind="stable")]:
            near = left & (np.abs((az - (j + 0.5) + 180.0) % 360.0 - 180.0) <= 5.0)
            mean = np.arctan2((w[near] * plan[near, 1]).sum(), (w[near] * plan[near, 0]).sum())
            d = np.array([np.cos(mean), np.sin(mean)])
            if (smooth[j] >= FILL_MIN_AREA_M2 and smooth[j] >= FILL_PEAK_RATIO * background) or (
                where is not None and _planar_area(where[near], w[near], d) >= FILL_MIN_PLANE_M2
            ):
                chosen = d
                break
            if where is None:
                break  # the largest peak only, as without positions
        if chosen is None:
            break
        out.append(chosen)
        found = True
    return np.array(out) if found else axes


#: ... or when this much area (m2) of them lies in one plane (:func:`_planar_area`): a wall 0.8 m
#: long seen to 1.5 m (a scan that stopped there), more than a door leaf's one face.
FILL_MIN_PLANE_M2 = 1.2

#: Width (m) of the band across a direction in which faces count as one plane for
#: :func:`_planar_area`: the scatter of a wall's faces on a noisy, decimated scan (1-2 cm of
#: noise, 25 cm triangles) and the bow of a drifted one.
FILL_PLANE_BAND_M = 0.15


def _planar_area(points: FloatArray, weights: FloatArray, direction: FloatArray) -> float:
    """The largest area of faces (plan ``points``, ``weights``) whose positions along
    ``direction`` lie within one band :data:`FILL_PLANE_BAND_M` wide: what of them one plane holds."""
    if not len(points):
        return 0.0
    v = np.sort(points @ direction)
    order = np.argsort(points @ direction, kind="stable")
    cw = np.r_[0.0, np.cumsum(weights[order])]
    hi = np.searchsorted(v, v + FILL_PLANE_BAND_M, side="right")
    return float(np.max(cw[hi] - cw[np.arange(len(v))]))


def _row_max(a: FloatArray) -> FloatArray:
    """``a.max(axis=1)`` of a few columns, column by column (numpy's reduction over a short
    last axis is many times slower; the maxima are the same numbers)."""
    out = a[:, 0].copy()
    for j in range(1, a.shape[1]):
        np.maximum(out, a[:, j], out=out)
    return out


def _group_minmax(labels: IntArray, values: FloatArray, k: int) -> tuple[FloatArray, FloatArray]:
    lo = np.full(k, np.inf)
    hi = np.full(k, -np.inf)
    v = np.ascontiguousarray(values, dtype=np.float64)
    scatter_min(lo, labels, v)
    scatter_max(hi, labels, v)
    return lo, hi


def _line_fit(u: FloatArray, v: FloatArray, w: FloatArray) -> tuple[float, float]:
    """Weighted total least squares line through the points ``(u, v)``: its angle from the
    ``u`` axis (radians, in (-pi/2, pi/2]) and the standard error of that angle (radians; inf
    from fewer than three points)."""
    total = w.sum()
    du, dv = u - (w * u).sum() / total, v - (w * v).sum() / total
    suu, svv, suv = (w * du * du).sum() / total, (w * dv * dv).sum() / total, (w * du * dv).sum() / total
    angle = 0.5 * float(np.arctan2(2.0 * suv, suu - svv))
    along = du * np.cos(angle) + dv * np.sin(angle)
    across = dv * np.cos(angle) - du * np.sin(angle)
    spread = float(np.sqrt((w * along**2).sum() / total))
    if len(u) < 3 or spread <= 0:
        return angle, np.inf
    rms = float(np.sqrt((w * across**2).sum() / total))
    return angle, rms / (spread * np.sqrt(len(u) - 2))


def _deviation(u: FloatArray, v: FloatArray) -> FloatArray:
    """Distances of the points ``(u, v)`` from the chord joining the first and the last."""
    d = np.array([u[-1] - u[0], v[-1] - v[0]])
    norm = float(np.hypot(*d))
    if norm <= 0:
        return np.zeros(len(u))
    return np.abs((u - u[0]) * d[1] - (v - v[0]) * d[0]) / norm


#: A surface turned from a wall by this angle (degrees) or more may be a door leaf standing ajar
#: rather than a piece of the wall; below it a leaf is closed as far as a scan can tell (its free
#: end 4 cm or less off the wall's plane across a 0.8 m door: a frame's depth and a scan's
#: noise), within the 3 degrees the pieces of one drifting wall scatter by. Read here
#: (:func:`_kinked`), by the openings (:mod:`meshplan.plan.doors`) and by the leaves' swings
#: (:mod:`meshplan.plan.elements`).
AJAR_MIN_TURN_DEG = 3.0
#: ... up to this angle (degrees): beyond, a leaf reaches a box's depth (10 cm) from its wall
#: within its first 0.4 m, leaves the wall's depth, and is an open leaf at an angle.
AJAR_MAX_TURN_DEG = 15.0

#: The longest leaf ajar (m; see :func:`_kinked`): a wide single door's leaf.
KINK_LEAF_MAX_M = 1.2

#: Confidence at which two lines must fit a run's columns better than one for a leaf ajar to be
#: cut from its wall (:func:`_kinked`): with few columns the cut falls a column off the hinge (a
#: column holds both wall and leaf), and the wall's piece, carried 0.3 m into the doorway, was
#: taken for the face across it while the leaf's rest was too far from the jamb to be a leaf
#: (hard seed 6: six columns, F 69 where 999 is asked; seed 10's eleven give F 217 over 22).
KINK_CONFIDENCE = 0.999

#: Columns each piece of a run cut for a leaf ajar needs (:func:`_kinked`): a line through two
#: columns fits them exactly, whatever the noise.
KINK_MIN_COLUMNS = 3


def _moment_sse(c: FloatArray) -> FloatArray:
    """The weighted sum of squared distances of points from their total least squares line,
    from their moments ``c`` (rows of sums of ``w, wu, wv, wuu, wvv, wuv``)."""
    sw = np.maximum(c[:, 0], 1e-300)
    mu, mv = c[:, 1] / sw, c[:, 2] / sw
    suu, svv, suv = c[:, 3] - sw * mu * mu, c[:, 4] - sw * mv * mv, c[:, 5] - sw * mu * mv
    # the smaller eigenvalue of [[suu, suv], [suv, svv]]
    return np.maximum(0.5 * (suu + svv) - np.sqrt(0.25 * (suu - svv) ** 2 + suv * suv), 0.0)


def _cut_sse(u: FloatArray, v: FloatArray, w: FloatArray) -> tuple[FloatArray, float]:
    """For every cut ``i`` of the columns (``1 .. n-1``): the residual (:func:`_moment_sse`) of
    the columns before it plus that of the columns from it; and the residual of all of them.
    One pass over cumulative moments, not two fits per cut."""
    m = np.cumsum(np.c_[w, w * u, w * v, w * u * u, w * v * v, w * u * v], axis=0)
    return _moment_sse(m[:-1]) + _moment_sse(m[-1] - m[:-1]), float(_moment_sse(m[-1:])[0])


def _kinked(
    u: FloatArray, v: FloatArray, w: FloatArray, lo: FloatArray, hi: FloatArray, cut: int, sse: tuple[float, float], ends: tuple[bool, bool], snap_rad: float
) -> bool:
    """Whether the columns ``(u, v)`` (weights ``w``, spans ``lo`` to ``hi``) are a wall in
    the cluster's direction and a door leaf standing ajar at one of the run's ends, meeting at
    ``cut``: ``sse`` the residuals of the two pieces' lines and of one line (:func:`_cut_sse`),
    ``ends`` tells whether the columns start and end their run, ``snap_rad`` is the walls'
    snap angle.

    One piece keeps the cluster's direction (as in :func:`_own_normal`); the other, at an end
    of the run (a doorway ends it) and no longer than :data:`KINK_LEAF_MAX_M`, turns from it
    by :data:`AJAR_MIN_TURN_DEG` to :data:`AJAR_MAX_TURN_DEG`, significantly for its columns;
    and two lines fit the columns better than one at :data:`KINK_CONFIDENCE`. A leaf ajar by
    3-15 degrees reaches 4-7 cm past the wall's face over its 0.8 m, so that no column strays a
    box's half-depth from the chord of the run, and the leaf was drawn with the wall as one
    piece at the angle between them (hard seed 10: 1.85 degrees, across the doorway). A wall bent by
    the scanner's drift turns along its length, by less, or turns both of its pieces: it stays
    one piece, as before.
    """
    n = len(u)
    if cut < KINK_MIN_COLUMNS or n - cut < KINK_MIN_COLUMNS or n <= 4:
        return False
    parts = [slice(0, cut), slice(cut, n)]
    fits = [_line_fit(u[p], v[p], w[p]) for p in parts]
    keeps = [_keeps_direction(a, s, p.stop - p.start, snap_rad) for (a, s), p in zip(fits, parts)]
    lo_turn, hi_turn = np.radians([AJAR_MIN_TURN_DEG, AJAR_MAX_TURN_DEG])
    if not any(
        ends[k] and not keeps[k] and keeps[1 - k] and lo_turn <= abs(fits[k][0]) <= hi_turn and hi[parts[k].stop - 1] - lo[parts[k].start] <= KINK_LEAF_MAX_M
        for k in (0, 1)
    ):
        return False
    # an F test of two lines against one (two more parameters): the best of every cut, hence
    # the strict level
    sse_two, sse_one = sse
    if sse_two <= 0.0:
        return sse_one > 0.0
    f = ((sse_one - sse_two) / 2.0) / (sse_two / (n - 4))
    return bool(f > fdtri(2, n - 4, KINK_CONFIDENCE))


def _chords(
    u: FloatArray, v: FloatArray, w: FloatArray, lo: FloatArray, hi: FloatArray, tol_m: float, min_length_m: float, snap_rad: float = 0.0
) -> list[tuple[int, int]]:
    """Split a run of columns (sorted along the wall) into straight pieces: a piece whose
    columns stray more than ``tol_m`` from the chord joining its first and last columns (as in
    Douglas-Peucker), or that is a wall with a door leaf ajar at the run's end
    (:func:`_kinked`; ``snap_rad`` is the walls' snap angle), is cut where two straight lines
    fit its columns best (the least total squared distance, so that a corner is cut at the
    corner and a step at the step), when both parts keep ``min_length_m`` and two columns. A
    wall bent by the drift of the scanner, or curved, becomes chords that each stay on it.
    Returns ``[start, stop)`` column ranges."""
    out = []
    stack = [(0, len(u))]
    while stack:
        a, b = stack.pop()
        if b - a >= 4:
            cuts = np.arange(a + 2, b - 1)
            cuts = cuts[(hi[cuts - 1] - lo[a] >= min_length_m) & (hi[b - 1] - lo[cuts] >= min_length_m)]
            if len(cuts):
                per_cut, whole = _cut_sse(u[a:b], v[a:b], w[a:b])
                total = per_cut[cuts - a - 1]  # cut i is the piece's (i - a)th
                best = int(np.argmin(total))
                i = int(cuts[best])
                if _deviation(u[a:b], v[a:b]).max() > tol_m or _kinked(
                    u[a:b], v[a:b], w[a:b], lo[a:b], hi[a:b], i - a, (float(total[best]), whole), (a == 0, b == len(u)), snap_rad
                ):
                    stack.extend([(i, b), (a, i)])
                    continue
        out.append((a, b))
    return sorted(out)


def _ends(r: dict) -> tuple[FloatArray, FloatArray]:
    """Plan ends ``(start, end)`` of a wall row."""
    n = np.asarray(r["normal"])
    t = np.array([-n[1], n[0]])
    return r["u_min"] * t + r["offset"] * n, r["u_max"] * t + r["offset"] * n


@dataclass(frozen=True, eq=False)
class _Rows:
    """The wall rows of a story as arrays: each row's ``normal`` and ``tangent`` (``(n, 2)``),
    ``offset``, span ``lo`` to ``hi`` along its tangent and ``length``, and its plan ``ends``
    (``(n, 2 ends, 2)``, :func:`_ends`)."""

    normal: FloatArray
    tangent: FloatArray
    offset: FloatArray
    lo: FloatArray
    hi: FloatArray
    ends: FloatArray

    @property
    def length(self) -> FloatArray:
        return self.hi - self.lo

    @classmethod
    def of(cls, rows: list[dict]) -> _Rows:
        nor = np.array([r["normal"] for r in rows], dtype=np.float64).reshape(-1, 2)
        lo, hi = np.array([r["u_min"] for r in rows], dtype=np.float64), np.array([r["u_max"] for r in rows], dtype=np.float64)
        ends = np.array([_ends(r) for r in rows], dtype=np.float64).reshape(-1, 2, 2)
        return cls(nor, np.c_[-nor[:, 1], nor[:, 0]], np.array([r["offset"] for r in rows], dtype=np.float64), lo, hi, ends)


def _mergeable(o: dict, r: dict, depth_half: float, gap: float, cos_merge: float) -> bool:
    """Whether two rectangles are pieces of one plane: directions within :data:`MERGE_DEG`,
    the ends of the shorter within ``depth_half`` of the longer's plane, and at most ``gap``
    apart along it."""
    no, nr = np.asarray(o["normal"]), np.asarray(r["normal"])
    if no @ nr < cos_merge:
        return False
    long, short = (o, r) if o["u_max"] - o["u_min"] >= r["u_max"] - r["u_min"] else (r, o)
    n = np.asarray(long["normal"])
    t = np.array([-n[1], n[0]])
    ends = np.array(_ends(short))
    if np.any(np.abs(ends @ n - long["offset"]) > depth_half):
        return False
    a, b = sorted(ends @ t)
    return bool(a <= long["u_max"] + gap and long["u_min"] <= b + gap)


def _absorb(o: dict, r: dict) -> None:
    """Merge row ``r`` into ``o``: the area-weighted direction and plane, the union of extents."""
    total = o["area"] + r["area"]
    n = o["area"] * np.asarray(o["normal"]) + r["area"] * np.asarray(r["normal"])
    n = n / np.linalg.norm(n)
    t = np.array([-n[1], n[0]])
    mid_o, mid_r = (np.add(*_ends(o)) / 2), (np.add(*_ends(r)) / 2)
    u = np.array(_ends(o) + _ends(r)) @ t
    o["offset"] = float((o["area"] * (n @ mid_o) + r["area"] * (n @ mid_r)) / total)
    o["normal"] = (float(n[0]), float(n[1]))
    o["u_min"], o["u_max"] = float(u.min()), float(u.max())
    o["bottom"], o["top"] = min(o["bottom"], r["bottom"]), max(o["top"], r["top"])
    if r["area"] > o["area"]:
        o["direction"] = r["direction"]
    o["support"] += r["support"]
    o["area"] = total
    o["segments"] = o["segments"] + r["segments"]


#: A wall crosses the line of two coplanar pieces when it runs on past that line by at least this
#: much (m) on both sides: a wall of the rooms on either side, not a return, a jamb's stub or a
#: door leaf that ends on the line.
CROSSING_THROUGH_M = 0.3


def _crossed(o: dict, r: dict, walls: tuple[FloatArray, FloatArray]) -> bool:
    """Whether one of ``walls`` (plan ends ``(starts, ends)``) crosses the line of pieces ``o``
    and ``r`` (running on past it by :data:`CROSSING_THROUGH_M` on both sides) in the gap
    between them or at its ends (within :data:`CONNECT_M`: a partition as thick as the gap
    stands in it with its faces on the gap's ends). The pieces then lie in two rooms on either
    side of that wall, not on either side of a door."""
    if not len(walls[0]):
        return False
    n = np.asarray(o["normal"])
    t = np.array([-n[1], n[0]])
    (a0, a1), (b0, b1) = sorted((sorted(np.array(_ends(o)) @ t), sorted(np.array(_ends(r)) @ t)))
    if b0 <= a1:  # they overlap along the line: no gap
        return False
    s, e = walls
    ds, de = s @ n - o["offset"], e @ n - o["offset"]  # each end's side of the line
    through = (np.minimum(ds, de) <= -CROSSING_THROUGH_M) & (np.maximum(ds, de) >= CROSSING_THROUGH_M)
    k = ds / np.where(through, ds - de, 1.0)  # where each meets the line
    u = s @ t + k * ((e - s) @ t)
    return bool(np.any(through & (u >= a1 - CONNECT_M) & (u <= b0 + CONNECT_M)))


def _crossings(rows: list[dict], i: int) -> FloatArray:
    """Where the other rows cross row ``i`` (positions along its tangent, sorted): walls turned
    from it that run on past its line by :data:`CROSSING_THROUGH_M` on both sides and meet it
    inside its span."""
    r = rows[i]
    n = np.asarray(r["normal"])
    t = np.array([-n[1], n[0]])
    cos_par = np.cos(np.radians(PILASTER_PARALLEL_DEG))
    cuts = []
    for j, o in enumerate(rows):
        if j == i or abs(float(np.asarray(o["normal"]) @ n)) >= cos_par:
            continue
        s, e = _ends(o)
        ds, de = float(s @ n - r["offset"]), float(e @ n - r["offset"])
        if min(ds, de) > -CROSSING_THROUGH_M or max(ds, de) < CROSSING_THROUGH_M:
            continue
        u = float(s @ t + ds / (ds - de) * ((e - s) @ t))
        if r["u_min"] < u < r["u_max"]:
            cuts.append(u)
    return np.sort(np.array(cuts, dtype=np.float64))


def _split_at_crossings(rows: list[dict], min_length_m: float) -> list[dict]:
    """The rows cut where another wall crosses them (:func:`_crossings`): a wall's face ends
    where a wall of the rooms on its side meets it, and what lies in its line beyond (the face
    of the next room's wall, a cupboard's side, scanned close enough to be one DBSCAN segment
    across the junction) is judged on its own. Pieces shorter than ``min_length_m`` (the
    crossing wall's own thickness between its faces, the few centimetres a face overshoots the
    wall it meets) are dropped; each piece keeps its share of the row's support and area by
    length."""
    out: list[dict] = []
    for i, r in enumerate(rows):
        cuts = _crossings(rows, i)
        if not len(cuts):
            out.append(r)
            continue
        bounds = np.r_[r["u_min"], cuts, r["u_max"]]
        length = r["u_max"] - r["u_min"]
        for lo, hi in zip(bounds[:-1], bounds[1:]):
            if hi - lo < min_length_m:
                continue
            share = (hi - lo) / length
            out.append({**r, "u_min": float(lo), "u_max": float(hi), "support": int(round(r["support"] * share)), "area": r["area"] * share})
    return out


def _merge(rows: list[dict], depth_half: float, gap: float) -> list[dict]:
    """Merge the rectangles of one story that are pieces of one plane (see :func:`_mergeable`):
    coplanar pieces on either side of a door, and the same wall found in two overlapping
    wall directions; but not pieces on either side of a wall that crosses the gap between them
    (:func:`_crossed`: they belong to two rooms)."""
    cos_merge = np.cos(np.radians(MERGE_DEG))
    changed = True
    while changed:
        changed = False
        rows.sort(key=lambda r: (r["direction"], r["offset"], r["u_min"]))
        g = _Rows.of(rows)
        ends, nor = g.ends, g.normal
        out: list[dict] = []
        for r in rows:
            for o in out:
                if _mergeable(o, r, depth_half, gap, cos_merge):
                    turned = np.abs(nor @ np.asarray(o["normal"])) < np.cos(np.radians(PILASTER_PARALLEL_DEG))
                    if _crossed(o, r, (ends[turned, 0], ends[turned, 1])):
                        continue
                    _absorb(o, r)
                    changed = True
                    break
            else:
                out.append(dict(r))
        rows = out
    return rows


def _continues(below: list[dict], direction: int, d: FloatArray, offset: FloatArray, u_lo: FloatArray, u_hi: FloatArray, params: WallParams) -> np.ndarray:
    """Segments that continue, in the same plane, a wall of the story below reaching its
    ceiling: the upper part of a double-height wall (a void, a stair well), whose top the
    scanner rarely reached. They are walls although they stop short of this story's ceiling."""
    out = np.zeros(len(offset), dtype=bool)
    t = np.array([-d[1], d[0]])
    centre = 0.5 * (u_lo + u_hi)[:, None] * t + offset[:, None] * d
    for r in below:
        if r["direction"] != direction:
            continue
        n = np.asarray(r["normal"])
        a, b = sorted(np.array(_ends(r)) @ t)
        overlap = np.minimum(u_hi, b) - np.maximum(u_lo, a)
        out |= (np.abs(centre @ n - r["offset"]) <= params.box_depth_m / 2) & (overlap >= 0.5 * (u_hi - u_lo))
    return out


def _keeps_direction(angle: float, sigma: float, n: int, snap_rad: float) -> bool:
    """Whether a piece of wall whose ``n`` columns' line turns ``angle`` (radians, standard
    error ``sigma``, :func:`_line_fit`) from its cluster's direction keeps that direction:
    within ``snap_rad`` of it, or not significantly off it (:data:`SNAP_CONFIDENCE`)."""
    bound = sigma * float(stdtrit(n - 2, 0.5 + SNAP_CONFIDENCE / 2)) if n > 2 else np.inf
    return abs(angle) <= max(snap_rad, bound)


def _own_normal(u: FloatArray, v: FloatArray, w: FloatArray, d: FloatArray, snap_rad: float) -> FloatArray | None:
    """The plan normal of a straight piece of wall from its columns ``(u, v)`` (along and
    across its cluster's direction ``d``, weights ``w``), or ``None`` where it keeps ``d``
    (:func:`_keeps_direction`)."""
    angle, sigma = _line_fit(u, v, w)
    if _keeps_direction(angle, sigma, len(u), snap_rad):
        return None
    t = np.array([-d[1], d[0]])
    return np.cos(angle) * d - np.sin(angle) * t


def _pieces(cols: Columns, run: IntArray, keep_run: np.ndarray, d: FloatArray, params: WallParams) -> tuple[IntArray, list[FloatArray]]:
    """Cut each kept run of columns into straight pieces and give each its own direction.

    Each piece's direction is the weighted total least squares line through its columns'
    planes; it keeps the direction ``d`` of its cluster when the two differ by less than
    ``snap_deg`` or not significantly (:data:`SNAP_CONFIDENCE`).

    Returns
    -------
    piece_of_col, normals
        ``(m,)`` piece of every column (-1 outside kept runs) and the plan normal of each piece.
    """
    piece_of_col = np.full(len(cols), -1, dtype=np.int64)
    normals: list[FloatArray] = []
    snap = np.radians(params.snap_deg)
    kept = np.flatnonzero(keep_run[np.maximum(run, 0)] & (run >= 0))
    if not len(kept):
        return piece_of_col, normals
    order = kept[np.lexsort((cols.bin[kept], run[kept]))]
    bounds = np.flatnonzero(np.r_[True, run[order][1:] != run[order][:-1], True])
    for a0, b0 in zip(bounds[:-1], bounds[1:]):
        c = order[a0:b0]
        u, v, w = cols.u[c], cols.offset[c], cols.area[c]
        chords = _chords(u, v, w, cols.u_lo[c], cols.u_hi[c], params.box_depth_m / 2, params.min_wall_length_m, snap)
        own = [_own_normal(u[a:b], v[a:b], w[a:b], d, snap) for a, b in chords]
        # a step between two pieces that both keep the cluster's direction is no corner: it is
        # as often a curtain, a shelf's side or a radiator the segment chained through as a jog
        # of the wall, and the pieces stay one plane in the cluster's direction through their
        # median (as in the paper)
        i = 0
        while i + 1 < len(chords):
            if own[i] is None and own[i + 1] is None:
                chords[i : i + 2] = [(chords[i][0], chords[i + 1][1])]
                del own[i + 1]
            else:
                i += 1
        for (a, b), n in zip(chords, own):
            normals.append(d if n is None else n)
            piece_of_col[c[a:b]] = len(normals) - 1
    return piece_of_col, normals


def segment_distances(s0: FloatArray, e0: FloatArray, s1: FloatArray, e1: FloatArray) -> FloatArray:
    """``(n, m)`` plan distances between the segments ``s0-e0`` (n) and ``s1-e1`` (m)."""

    def point_seg(p, a, b):  # (n, 2) points to (m,) segments
        d = b - a
        dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-24)
        rel = p[:, None, :] - a[None, :, :]
        k = np.clip(np.einsum("nmk,mk->nm", rel, d) / dd, 0.0, 1.0)
        return np.linalg.norm(rel - k[..., None] * d[None], axis=2)

    out = np.minimum.reduce([point_seg(s0, s1, e1), point_seg(e0, s1, e1), point_seg(s1, s0, e0).T, point_seg(e1, s0, e0).T])
    # crossing segments touch although no end is near the other
    cross = lambda o, p, q: (p[..., 0] - o[..., 0]) * (q[..., 1] - o[..., 1]) - (p[..., 1] - o[..., 1]) * (q[..., 0] - o[..., 0])  # noqa: E731
    A, B, C, D = s0[:, None], e0[:, None], s1[None], e1[None]
    hit = (np.sign(cross(A, B, C)) * np.sign(cross(A, B, D)) < 0) & (np.sign(cross(C, D, A)) * np.sign(cross(C, D, B)) < 0)
    return np.where(hit, 0.0, out)


def _free_standing(rows: list[dict], raster: StoryRaster, floor: float, ceiling: float | None, params: WallParams) -> np.ndarray:
    """Rows of one story that are free-standing objects, not walls: pieces that, with the
    walls they connect to (within :data:`CONNECT_M`), span no more than ``free_standing_m``
    (a panel, a pillar, a desk's screen: the network of a room's walls is larger), that have
    the floor scanned right behind them along :data:`FLOOR_BEHIND_SHARE` of their length (the
    scanner went round them; behind a wall lies its other face, another room, or nothing seen)
    and that are seen down to the floor (within :data:`FLOOR_CLEARANCE_M`: what the scanner went
    round it saw to its foot, where a wall seen only above a desk or a sill has its foot hidden
    by what stands against it). A short return at a corner or a door jamb's stub is connected
    to a longer wall and stays.

    Pillars and columns too, where the story has a ceiling: pieces connected to no piece
    longer than ``free_standing_m`` (a room's walls are longer; a column's sides and a booth
    built round it are not), all reaching the ceiling (within ``ceiling_reach_m``), seen down
    to the floor, with the ceiling scanned behind their tops along :data:`FLOOR_BEHIND_SHARE`
    of their length on both sides (beyond a wall's thickness and within ``free_standing_m``,
    :data:`~meshplan.walls.evidence.CEILING_TOLERANCE_M`): the space goes on all round them,
    their footprint is a hole in the scanned ceiling, where behind a wall lies its other face,
    then another room or nothing seen.

    And fragments: pieces connected to no piece longer than ``free_standing_m``, whose tops
    stay below door height (:data:`EDGE_WALL_MIN_TOP_M`) and are lost in unscanned space
    (nothing scanned around them higher, within ``context_m``): clutter seen through a door,
    furniture, or a wall seen too little to tell that it bounds anything (a wall that meets a
    soffit or a lower ceiling has that ceiling scanned above it). Where the story has no
    ceiling, every wall's top may be lost below door height, and a fragment is dropped only
    where a work surface stands against it along :data:`FLOOR_BEHIND_SHARE` of its length and
    it rises no more than :data:`SCREEN_RISE_M` above that surface (a desk's screen, a shelf's
    back, :func:`~meshplan.walls.evidence.work_surface_in_front`)."""
    n = len(rows)
    out = np.zeros(n, dtype=bool)
    if not n:
        return out
    ends = [_ends(r) for r in rows]
    s, e = np.array([a for a, _ in ends]), np.array([b for _, b in ends])
    near = segment_distances(s, e, s, e) <= CONNECT_M
    # connected components (labels propagated to the smallest index)
    comp = np.arange(n)
    for _ in range(n):
        new = np.min(np.where(near, comp[None, :], n), axis=1)
        new = np.minimum(new, comp)
        if np.array_equal(new, comp):
            break
        comp = new
    normals = np.array([r["normal"] for r in rows])
    behind = floor_behind(raster, s, e, normals, params.max_wall_thickness_m, params.context_m)
    length = np.linalg.norm(e - s, axis=1)
    around = top_around(raster, s, e, normals, params.max_wall_thickness_m, params.context_m)
    desk = work_surface_in_front(raster, s, e, normals, floor, params.max_work_surface_m)
    desk_top = work_surface_height(raster, s, e, normals, floor, params.max_work_surface_m)
    if ceiling is not None:
        # the ceiling scanned on both sides of each piece, beyond a wall's thickness
        at_ceiling = ceiling - CEILING_TOLERANCE_M
        over = np.minimum(
            ceiling_behind(raster, s, e, normals, params.max_wall_thickness_m, params.free_standing_m, at_ceiling),
            ceiling_behind(raster, s, e, -normals, params.max_wall_thickness_m, params.free_standing_m, at_ceiling),
        )
    for c in np.unique(comp):
        members = np.flatnonzero(comp == c)
        pts = np.r_[s[members], e[members]]
        span = float(np.max(np.linalg.norm(pts[:, None] - pts[None], axis=2)))
        weights = length[members] / max(length[members].sum(), 1e-12)
        share = float((behind[members] * weights).sum())
        foot = all(rows[i]["bottom"] <= floor + FLOOR_CLEARANCE_M for i in members)
        walked_round = span <= params.free_standing_m and share >= FLOOR_BEHIND_SHARE
        pillar = (
            ceiling is not None
            and float(length[members].max()) <= params.free_standing_m
            and all(rows[i]["top"] >= ceiling - params.ceiling_reach_m for i in members)
            and float((over[members] * weights).sum()) >= FLOOR_BEHIND_SHARE
        )
        # a fragment: connected to no wall of a room, its top below door height
        # (EDGE_WALL_MIN_TOP_M) and lost in unscanned space (nothing scanned around it higher,
        # CEILING_TOLERANCE_M): clutter or furniture seen through a door, or a wall seen too
        # little to tell that it bounds anything. Without a scanned ceiling the height alone
        # says nothing (a story scanned to 1.2-1.8 m has every wall's top lost below door height)
        fragment = (
            float(length[members].max()) <= params.free_standing_m
            and all(rows[i]["top"] < floor + EDGE_WALL_MIN_TOP_M for i in members)
            and all(around[i] < rows[i]["top"] + CEILING_TOLERANCE_M for i in members)
            # without a ceiling, only where it rises out of a desk or a counter (a screen, a
            # shelf's back): a work surface against it along most of its length, which it rises
            # above by no more than a screen does (SCREEN_RISE_M); a wall seen higher above the
            # desk against it goes on beyond what was scanned
            and (
                ceiling is not None
                or (
                    float((desk[members] * weights).sum()) >= FLOOR_BEHIND_SHARE
                    and all(rows[i]["top"] <= desk_top[i] + SCREEN_RISE_M for i in members)
                )
            )
        )
        out[members] = (foot and (walked_round or pillar)) or fragment
    return out


#: How far (m) a desk's screen or a low shelf's back rises above the work surface it stands on
#: or against (:func:`_free_standing`): office screens rise 0.3-0.65 m above the desk; a piece
#: of wall seen higher above the desk against it is a wall (a sparse headset scan sees the walls
#: of a room without a ceiling to 1.2-1.8 m, the desks' screens of the real scans rise 0.5 m).
SCREEN_RISE_M = 0.7

#: Two wall faces facing each other closer than this (m) are one surface, not the two sides of
#: a gap: the two faces of a thin box (a RoomPlan wall is one box 0.1 mm thick), each facing
#: the room on its side, whichever way the box is wound.
CORE_MIN_M = 0.02

#: Share of the shorter of two faces facing each other that the other must run alongside for
#: the space between them to be a wall's core.
CORE_OVERLAP_SHARE = 0.5


def _wall_cores(rows: list[dict], params: WallParams) -> np.ndarray:
    """Rows of one story that face another row across less than a wall's thickness
    (from :data:`CORE_MIN_M` to ``max_wall_thickness_m``), the two running alongside each other
    over :data:`CORE_OVERLAP_SHARE` of the shorter: the inside faces of a wall modelled by its
    two surfaces (a parametric model's thin boxes, one on each side of the wall), which face
    into the wall's core. A space is wider than a wall is thick, so no room lies between them;
    the wall's outer faces bound the rooms."""
    if len(rows) < 2:
        return np.zeros(len(rows), dtype=bool)
    facing_back, d, overlap = _facing_back(rows)
    # a core lies behind the face along most of the face itself: a short patch facing back a
    # few centimetres in front of a long wall (a headset's second layer of the same surface,
    # wound the other way) is the patch's core, not the wall's
    length = _Rows.of(rows).length
    core = facing_back & (d >= CORE_MIN_M) & (d <= params.max_wall_thickness_m) & (overlap >= CORE_OVERLAP_SHARE * length[:, None])
    return np.asarray(core.any(axis=1))


def _facing_back(rows: list[dict]) -> tuple[np.ndarray, FloatArray, FloatArray]:
    """``(n, n)`` which rows face back at each other's (parallel within
    :data:`PILASTER_PARALLEL_DEG`, facing the other way, running alongside each other over
    :data:`CORE_OVERLAP_SHARE` of the shorter), how far ``d[i, j]`` row ``j``'s plane lies in
    front of row ``i``'s (m; negative behind), and how long they run alongside (m)."""
    g = _Rows.of(rows)
    nor, off, lo, hi = g.normal, g.offset, g.lo, g.hi
    opposite = nor @ nor.T <= -np.cos(np.radians(PILASTER_PARALLEL_DEG))
    # with n_j = -n_i, j's plane lies d = -off_j - off_i in front of i's; j's tangent is -i's,
    # so j runs over [-hi_j, -lo_j] along i
    d = -off[None, :] - off[:, None]
    overlap = np.minimum(hi[:, None], -lo[None, :]) - np.maximum(lo[:, None], -hi[None, :])
    shorter = np.minimum((hi - lo)[:, None], (hi - lo)[None, :])
    return opposite & (overlap >= CORE_OVERLAP_SHARE * shorter), d, overlap


#: The outer face of a modelled wall looks at nothing scanned along at least this share of it
#: (:func:`_outer_faces`); its inner face sees the room.
OUTSIDE_SHARE = 0.9

#: ... from this far in front of it (m): past the box's own other face and its corners.
OUTSIDE_NEAR_M = 0.1


def _outer_faces(rows: list[dict], raster: StoryRaster, params: WallParams) -> np.ndarray:
    """Rows of one story that are the outer faces of a modelled exterior wall: a face that
    coincides with one facing the other way (a parametric model's wall is one box 0.1 mm thick,
    each of its sides a face; within :data:`CORE_MIN_M`, along half of the shorter), with
    nothing scanned in front of it along :data:`OUTSIDE_SHARE` of it (beyond
    :data:`OUTSIDE_NEAR_M` and within ``context_m``) while the other face sees the scan. It looks
    out of the building and bounds no space; the wall is its inner face. A scan never shows a
    wall's two sides in one plane."""
    out = np.zeros(len(rows), dtype=bool)
    if len(rows) < 2:
        return out
    facing_back, d, _ = _facing_back(rows)
    twin = facing_back & (np.abs(d) <= CORE_MIN_M)
    if not twin.any():
        return out
    g = _Rows.of(rows)
    seen = seen_in_front(raster, g.ends[:, 0], g.ends[:, 1], g.normal, OUTSIDE_NEAR_M, params.context_m)
    outside = seen <= 1.0 - OUTSIDE_SHARE
    return outside & np.any(twin & ~outside[None, :], axis=1)


def _pilasters(rows: list[dict], params: WallParams, raster: StoryRaster | None = None) -> np.ndarray:
    """Rows of one story that stand out of a wall: pieces no longer than
    :data:`BUILT_IN_FRONT_M` in front of a longer wall parallel to them (within
    :data:`PILASTER_PARALLEL_DEG`, facing either way), more than half the DBSCAN box's depth and at most
    :data:`PILASTER_DEPTH_M` in front of its plane along their whole length, with that wall going
    on beyond both of their ends (by a column, half a box length), and the sides of such a
    front: pieces turned from it that run from its ends back to the wall behind. They are
    pilasters, engaged columns, chimney breasts, or cupboards and wardrobes against the wall
    (whose tops the scan may not show, so that they rise as high as the walls were scanned):
    the wall behind bounds the room and is drawn across them. A step of a wall (the wall
    behind on one side only) and a niche (a piece behind the wall) stay.

    Where the front hides the face of the wall behind it, that wall may have been found by its
    other face only, scanned from the next room: a longer wall turned away from the front
    (within :data:`PILASTER_PARALLEL_DEG` of opposite), which the front stands in front of by
    more than a wall's thickness and at most :data:`PILASTER_DEPTH_M` plus one
    (``max_wall_thickness_m``; :func:`_behind_wall`), is the wall behind too."""
    n = len(rows)
    out = np.zeros(n, dtype=bool)
    if n < 2:
        return out
    cos_par = np.cos(np.radians(PILASTER_PARALLEL_DEG))
    margin = params.box_length_m / 2
    g = _Rows.of(rows)
    nor, tan, off, lo, hi, length, ends = g.normal, g.tangent, g.offset, g.lo, g.hi, g.length, g.ends
    fronts = []
    for i in np.flatnonzero(length <= BUILT_IN_FRONT_M):
        depth = ends[i] @ nor.T - off[None, :]  # how far each end stands in front of each plane
        u = ends[i] @ tan.T
        # parallel either way: a scan's faces on a cupboard's front may be turned into the box
        # (the facing of a closed box, seen from one side, is a guess)
        ok = (length > length[i]) & (np.abs(nor @ nor[i]) >= cos_par)
        front_of = np.all((depth > params.box_depth_m / 2) & (depth <= PILASTER_DEPTH_M), axis=0)
        ok &= front_of | ((nor @ nor[i] <= -cos_par) & np.all(_behind_wall(-depth, params), axis=0))
        ok &= (u.min(axis=0) >= lo + margin) & (u.max(axis=0) <= hi - margin)
        ok[i] = False
        if ok.any():
            out[i] = True
            fronts.append((i, int(np.flatnonzero(ok)[np.argmax(length[ok])])))
    # the sides of each front: turned from it, both ends between its plane and the wall's
    # behind (within CONNECT_M) and at its ends along it
    turned = np.abs(nor @ nor.T) < cos_par
    for i, b in fronts:
        side = turned[i] & ~out & (length <= PILASTER_DEPTH_M + CONNECT_M)
        for j in np.flatnonzero(side):
            across = ends[j] @ nor[b] - off[b]
            along = ends[j] @ tan[i]
            at_end = np.minimum(np.abs(along - lo[i]), np.abs(along - hi[i])) <= CONNECT_M
            front = ends[i, 0] @ nor[b] - off[b]
            # measured towards the front: behind b's plane where b is the wall's other face
            way = 1.0 if front >= 0 else -1.0
            across, front = way * across, way * front
            if np.all((across >= -CONNECT_M) & (across <= front + CONNECT_M) & at_end):
                out[j] = True
    return out | _box_sides(rows, out, params, raster)


def _box_sides(rows: list[dict], dropped: np.ndarray, params: WallParams, raster: StoryRaster | None = None) -> np.ndarray:
    """Rows of one story that are the two sides of a box against a wall whose front is no wall
    (its front was not kept, or was dropped as a pilaster's, ``dropped``): pairs of short pieces
    (at most :data:`PILASTER_DEPTH_M` plus :data:`CONNECT_M` long) turned from a longer wall,
    each with one end at that wall's plane (within :data:`CONNECT_M`, inside its extent) and the
    other in front of it, at most :data:`PILASTER_DEPTH_M` deep, the two free ends level with
    each other (within :data:`CONNECT_M`), at most :data:`BUILT_IN_FRONT_M` apart along the wall,
    and meeting no kept wall parallel to it: the sides of a wardrobe or a cupboard. A pier of
    the wall has its front kept, the jambs of a doorway through a thick wall meet its other
    face, and a corridor's walls are longer. With the story's ``raster``, one such side alone
    is a box's too where its front, as high as the side, runs on from its free end along the
    wall (:func:`_front_at`; the front itself no wall, hidden by the wall behind it). The wall
    may be the one behind the box found by its other face only (the box hides this one), the
    sides then standing behind it by more than a wall's thickness (:func:`_behind_wall`)."""
    n = len(rows)
    out = np.zeros(n, dtype=bool)
    if n < (2 if raster is not None else 3):  # a wall and one side, or two
        return out
    cos_par = np.cos(np.radians(PILASTER_PARALLEL_DEG))
    g = _Rows.of(rows)
    nor, tan, off, lo, hi, length, ends = g.normal, g.tangent, g.offset, g.lo, g.hi, g.length, g.ends
    short = np.flatnonzero(~dropped & (length <= PILASTER_DEPTH_M + CONNECT_M))
    if len(short) < (1 if raster is not None else 2):
        return out
    kept = ~dropped
    dist = segment_distances(ends[:, 0], ends[:, 1], ends[:, 0], ends[:, 1])
    for b in np.flatnonzero(kept & (length > PILASTER_DEPTH_M + CONNECT_M)):
        side = short[np.abs(nor[short] @ nor[b]) < np.sin(np.radians(PILASTER_PARALLEL_DEG))]  # square to the wall
        if not len(side):
            continue
        depth = ends[side] @ nor[b] - off[b]  # (k, 2): each end's depth in front of b's plane
        foot = np.argmin(np.abs(depth), axis=1)
        k = np.arange(len(side))
        at_wall = np.abs(depth[k, foot]) <= CONNECT_M
        tip = depth[k, 1 - foot]
        along = ends[side, 0] @ tan[b]
        ok = at_wall & ((tip > params.box_depth_m / 2) & (tip <= PILASTER_DEPTH_M) | _behind_wall(-tip, params)) & (along >= lo[b]) & (along <= hi[b])
        tip = np.abs(tip)  # how far the box stands out, from either face (levelled below)
        # the free end meets no kept wall parallel to b (a front: the box is a pier of the
        # wall; the other face of a thick wall: the jambs of a doorway through it)
        tips = ends[side, 1 - foot]
        fronts = kept & (np.abs(nor @ nor[b]) >= cos_par)
        fronts[b] = False
        if fronts.any():
            ok &= ~np.any(segment_distances(tips, tips, ends[fronts, 0], ends[fronts, 1]) <= CONNECT_M, axis=1)
        idx = np.flatnonzero(ok)
        for a in idx:
            for c in idx:
                if c <= a or dist[side[a], side[c]] > BUILT_IN_FRONT_M or abs(tip[a] - tip[c]) > CONNECT_M:
                    continue
                if abs(along[a] - along[c]) >= params.box_depth_m:  # two sides, not two faces of one
                    out[side[a]] = out[side[c]] = True
        # one side alone, where the box's front (not kept: hidden by the wall behind it) shows
        # in the scan, running on from its free end along the wall as high as the side
        if raster is not None:
            for a in idx[~out[side[idx]]]:
                if _front_at(raster, tips[a], tan[b], float(rows[side[a]]["top"])):
                    out[side[a]] = True
    return out


def _behind_wall(depth: FloatArray, params: WallParams) -> np.ndarray:
    """Whether points ``depth`` (m) behind a wall's face stand out of the wall's other face as
    a box's front would (:func:`_pilasters`, :func:`_box_sides`): deeper than the thickest wall
    (``max_wall_thickness_m``) plus half a DBSCAN box's depth, so that the wall's own other face
    is never one, and at most :data:`PILASTER_DEPTH_M` beyond the thickest wall."""
    t = params.max_wall_thickness_m
    return (depth > t + params.box_depth_m / 2) & (depth <= PILASTER_DEPTH_M + t)


#: Where a box's front is looked for beside the free end of one of its sides (m along the wall
#: from the end; :func:`_front_at`): past the corner's rounding, within the narrowest cupboard.
FRONT_SEARCH_M = (0.15, 0.6)

#: The front rises this close (m) to the top of the side: a box's top is level, and the scan
#: cuts its front and sides at one height.
FRONT_TOP_M = 0.2

#: Share of the search beside a side's free end (:func:`_front_at`) that the front must fill.
SIDE_COVER_FRONT = 0.75


def _front_at(raster: StoryRaster, tip: FloatArray, tangent: FloatArray, top: float) -> bool:
    """Whether a surface as high as ``top`` (within :data:`FRONT_TOP_M`) was scanned along most
    (:data:`SIDE_COVER_FRONT`) of :data:`FRONT_SEARCH_M` from the plan point ``tip`` along
    ``tangent``, one way or the other: the front of the box whose side ends at ``tip``. Beside
    the free end of a stub wall with a door past it lies the free floor of the rooms it parts."""
    steps = np.arange(FRONT_SEARCH_M[0], FRONT_SEARCH_M[1] + 1e-9, RASTER_M / 2)
    across = np.array([-tangent[1], tangent[0]])
    for sign in (1.0, -1.0):
        p = tip[None, None, :] + sign * steps[:, None, None] * tangent + np.array([-1.0, 0.0, 1.0])[None, :, None] * (RASTER_M / 2) * across
        tops = raster.sample(raster.top, p[..., 0], p[..., 1], -np.inf).max(axis=1)
        if float(np.mean(tops >= top - FRONT_TOP_M)) >= SIDE_COVER_FRONT:
            return True
    return False


@dataclass(frozen=True, eq=False)
class _DirectionPieces:
    """The pieces of wall :func:`find_flat_walls` found facing one direction of a story: the
    ``faces`` (or their pieces) in a DBSCAN segment and the sub-segment of each (``segment``:
    the sub-segments that have faces numbered from 0, the straight pieces first, then the other
    runs, then the rest of each DBSCAN segment), whether each of those sub-segments is a piece
    (``kept``), and the pieces' rows, each naming its sub-segment (numbered from 0 here, after
    the segments so far once joined)."""

    faces: IntArray
    segment: IntArray
    kept: np.ndarray
    rows: list[dict]


def find_flat_walls(mesh: Mesh, orientation: Orientation, params: WallParams | None = None) -> FlatWalls:
    """Flat walls of every story of an oriented mesh.

    Each DBSCAN segment is cut into columns and only its runs of columns that show the evidence
    of a wall become walls (see :mod:`meshplan.walls.evidence`): a top that reaches the ceiling
    or, where none was scanned near it, the top of what was scanned around it; a height above
    any work surface; no counter or desk top attached behind its top edge; no surface facing
    the same way behind it. Each run is cut into straight pieces, each drawn in its own
    direction (not its cluster's, unless within ``snap_deg``); pieces of one plane are merged,
    and free-standing objects (short, connected to no wall, floor behind them), pilasters and
    the faces toward a wall's core (:func:`_wall_cores`) dropped.

    Parameters
    ----------
    mesh
        The mesh in the plan frame, normals facing into the rooms.
    orientation
        Stories and wall directions from :func:`meshplan.orient.orient`.
    params
        Wall parameters; the paper's defaults when omitted.
    """
    params = params or WallParams()
    in_stories = orientation.face_story >= 0
    # (every face is in a story but where a caller marked some out: no copies then)
    every = bool(in_stories.all())
    dirs = wall_directions(
        orientation, params.wall_directions,
        mesh.face_normals if every else mesh.face_normals[in_stories], mesh.face_areas if every else mesh.face_areas[in_stories],
        params.facing_tolerance_deg, mesh.face_centroids if every else mesh.face_centroids[in_stories],
    )
    width = params.box_length_m / 2  # columns: the resolution along the wall of a DBSCAN box
    cos_tol = np.cos(np.radians(params.facing_tolerance_deg))
    # DBSCAN counts centroids: faces larger than the box (parametric models) are split so that
    # the centroids sample the surface evenly; dense scans are left as they are
    tri, parent = subdivide(mesh.triangles, SPLIT_SHARE * params.box_length_m)
    split = len(tri) != mesh.n_faces
    normals = mesh.face_normals[parent] if split else mesh.face_normals
    # tri.mean(axis=1) and |(t1 - t0) x (t2 - t0)| / 2, the same numbers in one compiled pass
    centroids, areas = centroids_areas(np.ascontiguousarray(tri))
    face_story = orientation.face_story[parent] if split else orientation.face_story
    # the objects of a parametric model (boxes thicker than a wall) are no wall evidence
    objects = object_boxes(mesh, params.max_wall_thickness_m)
    objects = objects[parent] if split else objects
    # the faces facing each wall direction, the same in every story
    facing = [normals @ np.array([d[0], 0.0, d[1]]) >= cos_tol for d in dirs]

    def direction_pieces(
        story: Story, ceiling: float | None, raster: StoryRaster, below: list[dict], in_story: np.ndarray, half: FloatArray, d_index: int
    ) -> _DirectionPieces | None:
        """The straight pieces of wall of ``story`` (its scanned ``ceiling``, None where the
        walls stop short of it; ``below``: the walls of the story below that reach its ceiling;
        ``in_story``: which faces or pieces are its wall evidence; ``half``: the DBSCAN box's half
        extents) facing direction ``d_index``, from its DBSCAN segments (``None`` where it has too
        few faces or no segment)."""
        d = dirs[d_index]
        n3 = np.array([d[0], 0.0, d[1]])
        t3 = np.array([-d[1], 0.0, d[0]])
        idx = np.flatnonzero(in_story & facing[d_index])
        if len(idx) < params.min_points:
            return None
        c = centroids[idx]
        pts = np.c_[c @ t3, c @ n3, c[:, 1]]
        labels, _ = box_dbscan(pts, half, params.min_points)
        k = int(labels.max()) + 1
        if k == 0:
            return None
        ok = labels >= 0
        lab, fidx = labels[ok], idx[ok]
        verts = tri[fidx]  # (n, 3, 3)
        vu = verts @ t3
        across_c = pts[ok, 1]
        across_order = np.argsort(across_c, kind="stable")  # shared by the two medians
        offset = group_weighted_median(lab, across_c, areas[fidx], k, across_order)
        u_lo, u_hi = _group_minmax(np.repeat(lab, 3), vu.reshape(-1), k)
        cols = columns(lab, pts[ok, 0], vu, verts[..., 1], across_c, areas[fidx], width, across_order)
        wall, neutral, edge, grazed = _wall_columns(cols, raster, d, story.floor, ceiling, width, params)
        wall |= _continues(below, d_index, d, offset, u_lo, u_hi, params)[cols.segment]
        wall |= _in_line_of_walls(cols, wall, grazed, offset, u_lo, u_hi, params)
        run = runs(cols, wall, neutral, grazed)
        n_runs = int(run.max()) + 1
        # the runs long enough and coming near the floor
        run_face = run[cols.face_column]
        r_ok = run_face >= 0
        r_lo, r_hi = _group_minmax(np.repeat(run_face[r_ok], 3), vu[r_ok].reshape(-1), max(n_runs, 1))
        r_bottom, _ = _group_minmax(np.repeat(run_face[r_ok], 3), verts[r_ok][..., 1].reshape(-1), max(n_runs, 1))
        # a run at the edge of the scan (nothing behind any of its wall columns) may have its
        # foot hidden by what stands against it: seen over half the height is enough there
        r_edge = np.ones(max(n_runs, 1), dtype=bool)
        np.logical_and.at(r_edge, run[wall & (run >= 0)], edge[wall & (run >= 0)])
        keep_run = (r_hi - r_lo >= params.min_wall_length_m) & ((r_bottom <= story.floor + params.floor_reach_m) | r_edge[: max(n_runs, 1)])
        piece_of_col, piece_normals = _pieces(cols, run, keep_run, d, params)
        n_pieces = len(piece_normals)
        # sub-segments: each straight piece of a kept run, then the other runs, then the
        # rest of each DBSCAN segment
        sub_of_col = np.where(piece_of_col >= 0, piece_of_col, np.where(run >= 0, n_pieces + run, n_pieces + n_runs + cols.segment))
        sub = sub_of_col[cols.face_column]
        m = n_pieces + n_runs + k
        # each piece in its own frame: along its tangent and across its normal
        pn = np.array(piece_normals).reshape(-1, 2)
        own = sub < n_pieces
        fn = np.where(own[:, None], pn[np.minimum(sub, max(n_pieces - 1, 0))] if n_pieces else d, d)
        ft = np.c_[-fn[:, 1], fn[:, 0]]
        along = np.einsum("fkj,fj->fk", verts[..., [0, 2]], ft)  # (n, 3) corners along
        across = np.einsum("fj,fj->f", centroids[fidx][:, [0, 2]], fn)
        p_lo, p_hi = _group_minmax(np.repeat(sub, 3), along.reshape(-1), m)
        y_lo, y_hi = _group_minmax(np.repeat(sub, 3), verts[..., 1].reshape(-1), m)
        p_off = group_weighted_median(sub, across, areas[fidx], m)
        # support: the faces of the mesh (not their pieces) in each sub-segment
        if split:
            pairs = np.unique(sub * np.int64(mesh.n_faces) + parent[fidx])
            support = np.bincount(pairs // mesh.n_faces, minlength=m)
        else:  # every piece is a face of its own
            support = np.bincount(sub, minlength=m)
        area = np.bincount(sub, weights=areas[fidx], minlength=m)
        present = np.bincount(sub, minlength=m) > 0
        local = np.cumsum(present) - 1  # the sub-segments present, numbered from 0
        rows = [
            {
                "story": story.index,
                "direction": d_index,
                "normal": (float(pn[j, 0]), float(pn[j, 1])),
                "offset": float(p_off[j]),
                "u_min": float(p_lo[j]),
                "u_max": float(p_hi[j]),
                "bottom": float(y_lo[j]),
                "top": float(y_hi[j]),
                "support": int(support[j]),
                "area": float(area[j]),
                "segments": [int(local[j])],
            }
            for j in range(n_pieces)
            if present[j]
        ]
        return _DirectionPieces(fidx, local[sub], np.flatnonzero(present) < n_pieces, rows)

    piece_segment = np.full(len(tri), -1, dtype=np.int64)
    seg_story: list[int] = []
    seg_kept: list[bool] = []
    rows: list[dict] = []
    below: list[dict] = []  # walls of the story below that reach its ceiling
    for story in orientation.stories:
        ceiling = story.ceiling if story.ceiling_found else None
        story_faces = np.flatnonzero(face_story == story.index)
        # the story's faces (the scan's own arrays when they are all of them: a single story's
        # corners copied were 216 MB at 3M faces, twice)
        story_tri, story_normals = (tri, normals) if len(story_faces) == len(tri) else (tri[story_faces], normals[story_faces])
        if ceiling is not None and _walls_short_of(story_tri, story_normals, story.floor, ceiling):
            # the ceiling was scanned but no wall up to it (a user who looked up in the middle
            # of the rooms only): the walls' tops are lost in the band under it, as in a story
            # without a ceiling, which is what they are judged against (the ceiling and what
            # rounds into it, the band WALLS_SHORT_M under it, left out of the rasters)
            story_faces = story_faces[centroids[story_faces, 1] <= ceiling - WALLS_SHORT_M]
            story_tri, story_normals = tri[story_faces], normals[story_faces]
            ceiling = None
        # without a scanned ceiling the assumed one bounds nothing: the story's faces go up to
        # its top boundary (the next story, or the top of the scan)
        story_top = story.ceiling if ceiling is not None else story.top
        in_story = (face_story == story.index) & ~objects & (centroids[:, 1] > story.floor) & (centroids[:, 1] < story_top)
        raster = story_raster(story_tri, story_normals, story.floor, ceiling)
        height = params.box_height_m or story.height
        half = np.array([params.box_length_m / 2, params.box_depth_m / 2, height / 2])
        # the directions searched in threads (meshplan.geometry.SEARCH_THREADS), their pieces
        # numbered in the directions' order, as one thread finds them
        found: list[dict] = []
        for part in in_threads(partial(direction_pieces, story, ceiling, raster, below, in_story, half), len(dirs)):
            if part is None:
                continue
            # the sub-segments that exist, numbered after the segments so far (the pieces kept)
            first = len(seg_story)
            piece_segment[part.faces] = part.segment + first
            seg_story.extend([story.index] * len(part.kept))
            seg_kept.extend(part.kept.tolist())
            for row in part.rows:
                row["segments"] = [row["segments"][0] + first]
            found.extend(part.rows)
        found = _split_at_crossings(_merge(found, params.box_depth_m / 2, params.merge_gap_m), params.min_wall_length_m)
        free = (
            _free_standing(found, raster, story.floor, ceiling, params) | _pilasters(found, params, raster) | _wall_cores(found, params)
            | _outer_faces(found, raster, params)
        )
        for r in (r for r, f in zip(found, free) if f):
            for sid in r["segments"]:
                seg_kept[sid] = False
        found = [r for r, f in zip(found, free) if not f]
        rows.extend(found)
        below = [r for r in found if r["top"] >= story.ceiling - params.ceiling_reach_m]
    rows.sort(key=lambda r: (r["story"], r["direction"], r["offset"], r["u_min"]))
    segment_wall = np.full(len(seg_story), -1, dtype=np.int64)
    for w, r in enumerate(rows):
        segment_wall[r["segments"]] = w
    # a face split into pieces takes the segment of its first piece in a segment
    face_segment = np.full(mesh.n_faces, -1, dtype=np.int64)
    labelled = np.flatnonzero(piece_segment >= 0)[::-1]
    face_segment[parent[labelled]] = piece_segment[labelled]
    return FlatWalls.from_rows(rows, dirs, face_segment, np.array(seg_story, dtype=np.int64), np.array(seg_kept, dtype=bool), segment_wall)


#: The walls of a story stop short of its scanned ceiling when nothing vertical was scanned
#: within this distance (m) under it (:func:`_walls_short_of`): headsets round a wall into the
#: ceiling over 10-20 cm, and a scan that looked at the walls reaches that band; a user who did
#: not look up scans them to 1.4-2.0 m.
WALLS_SHORT_M = 0.4

#: Share of a story's wall area (vertical faces) that must lie below the band under its ceiling
#: for its walls to stop short of it: a few patches of wall near the ceiling (a cupboard's top,
#: a door's head) do not make walls scanned up to it.
WALLS_SHORT_SHARE = 0.98


def _walls_short_of(tri: FloatArray, normals: FloatArray, floor: float, ceiling: float) -> bool:
    """Whether the vertical faces of a story (``tri``, ``normals``; a wall's faces, those of the
    furniture) stop :data:`WALLS_SHORT_M` or more under its ``ceiling``, all but
    (1 - :data:`WALLS_SHORT_SHARE`) of their area: the walls were not scanned up to it."""
    vertical = np.flatnonzero(np.abs(normals[:, 1]) < np.sin(np.radians(VERTICAL_DEG)))
    if not len(vertical):
        return False
    t = tri[vertical]
    area = 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1)
    y = t[:, :, 1]
    top = max3(y)
    high = top > ceiling - WALLS_SHORT_M
    above = top > floor + WALLS_SHORT_M  # the walls, not the skirting
    total = float(area[above].sum())
    return total > 0 and float(area[high].sum()) <= (1.0 - WALLS_SHORT_SHARE) * total


def _wall_columns(
    cols: Columns, raster: StoryRaster, normal: FloatArray, floor: float, ceiling: float | None, width: float, params: WallParams
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Which columns show the evidence of a wall, which are neutral (see
    :mod:`meshplan.walls.evidence`), which stand at the edge of the scan (nothing scanned
    behind them within ``context_m``), and which are grazed (a wall's end at the edge of the
    scan, seen lower than its top: they continue a wall but start none).

    The top a column must reach is the highest thing scanned in front of it or behind it (the
    ceiling near it, capped at the story's ceiling, or the top of the scan where there is no
    ceiling), or its own top where nothing around is higher: a top lost in unscanned space.
    A column that reaches it with nothing against it but too short a height seen (the lintel
    over a door, a wall seen only near its top) is neutral.
    """
    top = neighbour_max(cols, cols.top)
    target = np.maximum(local_top(raster, normal, cols, width, params.context_m, params.max_wall_thickness_m), top)
    if ceiling is not None:
        target = np.minimum(target, ceiling)
    reaches = top >= target - params.ceiling_reach_m
    # at the edge of the scan a wall's top may be lost under the ceiling (EDGE_WALL_MIN_TOP_M)
    edge = np.isneginf(behind_top(raster, normal, cols, width, params.context_m, params.max_wall_thickness_m))
    reaches |= edge & (top >= floor + EDGE_WALL_MIN_TOP_M)
    above_work = top > floor + params.max_work_surface_m
    seen = cols.top - cols.bottom >= MIN_COLUMN_SPAN_SHARE * (target - floor)
    top_share = top_attached(raster, normal, cols, width)
    furniture_top = top_share >= MIN_TOP_SHARE
    hidden = hidden_behind(cols, params.context_m, params.max_wall_thickness_m, params.max_work_surface_m)
    # at the edge of the scan, with no top attached and nothing flush behind it (a thin box
    # against a wall), a column seen above seat backs is a wall whose top the scan did not
    # reach (a story scanned to 1.2-1.8 m): EDGE_WALL_MIN_SEEN_M
    flush = hidden_behind(cols, params.context_m, params.box_depth_m, params.max_work_surface_m)
    above_work |= edge & ~furniture_top & ~flush & (top > floor + EDGE_WALL_MIN_SEEN_M)
    plausible = reaches & above_work & ~furniture_top & ~hidden
    # a wall under a window (a parapet) has the window's sill on its top, as a counter's front
    # has its worktop: too little to tell alone, it neither starts nor breaks a run of wall
    # columns in its plane (:func:`meshplan.walls.evidence.runs`); a front 0.6 m before the
    # wall it stands against lies in a plane of its own
    # (its sill judged over a box length, as its top: a hole in the scanned sill, often against
    # a jamb, does not make the column under it a break in the wall)
    sill = neighbour_max(cols, top_share) >= MIN_TOP_SHARE
    parapet = sill & ~hidden & (cols.top >= floor + PARAPET_MIN_M) & (cols.top <= floor + params.max_work_surface_m)
    # a wall grazed at the edge of the scan: the sensor's rays met it ever more obliquely, so its
    # end is seen lower and lower (1.5-2 m where the rest reaches the ceiling). Such a column,
    # risen above the work surfaces with no top attached and nothing behind it, and seen over
    # half its own height, is no evidence of a wall alone (a wardrobe at the scan's edge looks
    # the same) but continues one (see :func:`meshplan.walls.evidence.runs` and
    # :func:`_in_line_of_walls`)
    grazed = edge & ~reaches & ~furniture_top & ~hidden & (cols.top > floor + params.max_work_surface_m)
    grazed &= cols.top - cols.bottom >= MIN_COLUMN_SPAN_SHARE * (cols.top - floor)
    return plausible & seen, (plausible & ~seen) | (parapet & ~plausible), edge, grazed


def _in_line_of_walls(
    cols: Columns, wall: np.ndarray, grazed: np.ndarray, offset: FloatArray, u_lo: FloatArray, u_hi: FloatArray, params: WallParams
) -> np.ndarray:
    """Columns of the segments without a wall column whose grazed columns continue, across a
    gap no wider than ``merge_gap_m`` (a door), the plane of a segment that holds wall columns
    (its offset within ``box_depth_m``): the far side of a door at the edge of the scan, seen
    only to 1.5-2 m. Nothing else stands in a wall's own plane beyond its door; a counter or a
    wardrobe stands in front of its wall."""
    k = len(offset)
    has_wall = np.bincount(cols.segment[wall], minlength=k) > 0
    has_grazed = np.bincount(cols.segment[grazed], minlength=k) > 0
    cand = np.flatnonzero(has_grazed & ~has_wall)
    walls = np.flatnonzero(has_wall)
    if not len(cand) or not len(walls):
        return np.zeros(len(cols), dtype=bool)
    near = np.abs(offset[cand][:, None] - offset[walls][None, :]) <= params.box_depth_m
    gap = np.maximum(u_lo[walls][None, :] - u_hi[cand][:, None], u_lo[cand][:, None] - u_hi[walls][None, :])
    ok = np.zeros(k, dtype=bool)
    ok[cand[(near & (gap <= params.merge_gap_m)).any(axis=1)]] = True
    return grazed & ok[cols.segment]

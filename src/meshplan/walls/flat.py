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
A run must be long enough and come near the floor. Its plane faces the wall direction and
passes through the area-weighted median of the centroids across the wall; its rectangle spans
its triangles along the wall and in height. Faces larger than half a box are split first, so
that the centroids of parametric models (two triangles a wall) sample their surfaces. Coplanar rectangles of one direction
separated by less than ``merge_gap_m`` are one wall, so that a door or a missing strip does not split it (an addition to the paper).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import FloatArray, IntArray, Mesh
from ..orient import Orientation
from .boxdbscan import box_dbscan
from .evidence import (
    MIN_COLUMN_SPAN_SHARE,
    MIN_TOP_SHARE,
    SPLIT_SHARE,
    Columns,
    StoryRaster,
    columns,
    hidden_behind,
    local_top,
    neighbour_max,
    runs,
    story_raster,
    subdivide,
    top_attached,
)
from .params import WallParams


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

    @property
    def tangent(self) -> FloatArray:
        return np.c_[-self.normal[:, 1], self.normal[:, 0]]

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


def wall_directions(orientation: Orientation, mode: str) -> FloatArray:
    """``(D, 2)`` unit plan normals [nx, nz] the DBSCAN runs on.

    The principal directions are the exact axes (the alignment put the dominant walls on
    them); other directions are the k-means centres.
    """
    axes = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
    others = [d.normal[[0, 2]] for d in orientation.alignment.directions if not d.principal]
    if mode == "principal" or (mode == "auto" and not others):
        return axes
    out = [a for a in axes]
    for o in others:
        o = o / np.linalg.norm(o)
        if all(o @ a < np.cos(np.radians(10.0)) for a in out):
            out.append(o)
    return np.array(out)


def _group_minmax(labels: IntArray, values: FloatArray, k: int) -> tuple[FloatArray, FloatArray]:
    lo = np.full(k, np.inf)
    hi = np.full(k, -np.inf)
    np.minimum.at(lo, labels, values)
    np.maximum.at(hi, labels, values)
    return lo, hi


def _group_weighted_median(labels: IntArray, values: FloatArray, weights: FloatArray, k: int) -> FloatArray:
    order = np.lexsort((values, labels))
    lab, val, w = labels[order], values[order], weights[order]
    cw = np.cumsum(w)
    start = np.searchsorted(lab, np.arange(k))
    end = np.searchsorted(lab, np.arange(k), side="right")
    before = np.where(start > 0, cw[np.maximum(start - 1, 0)], 0.0)
    total = cw[end - 1] - before
    target = before + 0.5 * total
    idx = np.searchsorted(cw, target)
    return val[np.clip(idx, start, end - 1)]


def _merge(rows: list[dict], depth_half: float, gap: float) -> list[dict]:
    """Merge coplanar rectangles (one story, one direction) whose ends are close."""
    rows = sorted(rows, key=lambda r: (r["offset"], r["u_min"]))
    changed = True
    while changed:
        changed = False
        rows.sort(key=lambda r: (r["u_min"], r["offset"]))
        out: list[dict] = []
        for r in rows:
            for o in out:
                if abs(o["offset"] - r["offset"]) <= depth_half and r["u_min"] <= o["u_max"] + gap and o["u_min"] <= r["u_max"] + gap:
                    total = o["area"] + r["area"]
                    o["offset"] = (o["offset"] * o["area"] + r["offset"] * r["area"]) / total
                    o["u_min"], o["u_max"] = min(o["u_min"], r["u_min"]), max(o["u_max"], r["u_max"])
                    o["bottom"], o["top"] = min(o["bottom"], r["bottom"]), max(o["top"], r["top"])
                    o["support"] += r["support"]
                    o["area"] = total
                    o["segments"] = o["segments"] + r["segments"]
                    changed = True
                    break
            else:
                out.append(dict(r))
        rows = out
    return rows


def _continues(below: list[dict], direction: int, offset: FloatArray, u_lo: FloatArray, u_hi: FloatArray, params: WallParams) -> np.ndarray:
    """Segments that continue, in the same plane, a wall of the story below reaching its
    ceiling: the upper part of a double-height wall (a void, a stair well), whose top the
    scanner rarely reached. They are walls although they stop short of this story's ceiling."""
    out = np.zeros(len(offset), dtype=bool)
    for r in below:
        if r["direction"] != direction:
            continue
        overlap = np.minimum(u_hi, r["u_max"]) - np.maximum(u_lo, r["u_min"])
        out |= (np.abs(offset - r["offset"]) <= params.box_depth_m / 2) & (overlap >= 0.5 * (u_hi - u_lo))
    return out


def find_flat_walls(mesh: Mesh, orientation: Orientation, params: WallParams | None = None) -> FlatWalls:
    """Flat walls of every story of an oriented mesh.

    Each DBSCAN segment is cut into columns and only its runs of columns that show the evidence
    of a wall become walls (see :mod:`meshplan.walls.evidence`): a top that reaches the ceiling
    or, where none was scanned near it, the top of what was scanned around it; a height above
    any work surface; no counter or desk top attached behind its top edge; no surface facing
    the same way behind it.

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
    dirs = wall_directions(orientation, params.wall_directions)
    # DBSCAN counts centroids: faces larger than the box (parametric models) are split so that
    # the centroids sample the surface evenly; dense scans are left as they are
    tri, parent = subdivide(mesh.triangles, SPLIT_SHARE * params.box_length_m)
    normals = mesh.face_normals[parent]
    centroids = tri.mean(axis=1)
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    areas = 0.5 * np.linalg.norm(cross, axis=1)
    face_story = orientation.face_story[parent]
    width = params.box_length_m / 2  # columns: the resolution along the wall of a DBSCAN box
    cos_tol = np.cos(np.radians(params.facing_tolerance_deg))
    piece_segment = np.full(len(tri), -1, dtype=np.int64)
    seg_story: list[int] = []
    seg_kept: list[bool] = []
    rows: list[dict] = []
    below: list[dict] = []  # walls of the story below that reach its ceiling
    for story in orientation.stories:
        first = len(rows)
        ceiling = story.ceiling if story.ceiling_found else None
        # without a scanned ceiling the assumed one bounds nothing: the story's faces go up to
        # its top boundary (the next story, or the top of the scan)
        in_story = (face_story == story.index) & (centroids[:, 1] > story.floor) & (centroids[:, 1] < (story.ceiling if ceiling is not None else story.top))
        story_faces = np.flatnonzero(face_story == story.index)
        raster = story_raster(tri[story_faces], normals[story_faces], story.floor, ceiling)
        height = params.box_height_m or story.height
        half = np.array([params.box_length_m / 2, params.box_depth_m / 2, height / 2])
        for d_index, d in enumerate(dirs):
            n3 = np.array([d[0], 0.0, d[1]])
            t3 = np.array([-d[1], 0.0, d[0]])
            idx = np.flatnonzero(in_story & (normals @ n3 >= cos_tol))
            if len(idx) < params.min_points:
                continue
            c = centroids[idx]
            pts = np.c_[c @ t3, c @ n3, c[:, 1]]
            labels, _ = box_dbscan(pts, half, params.min_points)
            k = int(labels.max()) + 1
            if k == 0:
                continue
            ok = labels >= 0
            lab, fidx = labels[ok], idx[ok]
            verts = tri[fidx]  # (n, 3, 3)
            vu = verts @ t3
            offset = _group_weighted_median(lab, pts[ok, 1], areas[fidx], k)
            u_lo, u_hi = _group_minmax(np.repeat(lab, 3), vu.reshape(-1), k)
            cols = columns(lab, pts[ok, 0], vu, verts[..., 1], offset, width)
            wall, neutral = _wall_columns(cols, raster, d, story.floor, ceiling, width, params)
            wall |= _continues(below, d_index, offset, u_lo, u_hi, params)[cols.segment]
            run = runs(cols, wall, neutral)
            n_runs = int(run.max()) + 1
            # sub-segments: each run of wall columns, then the rest of each DBSCAN segment
            sub_of_col = np.where(run >= 0, run, n_runs + cols.segment)
            sub = sub_of_col[cols.face_column]
            m = n_runs + k
            p_lo, p_hi = _group_minmax(np.repeat(sub, 3), vu.reshape(-1), m)
            y_lo, y_hi = _group_minmax(np.repeat(sub, 3), verts[..., 1].reshape(-1), m)
            p_off = _group_weighted_median(sub, pts[ok, 1], areas[fidx], m)
            # support: the faces of the mesh (not their pieces) in each sub-segment
            pairs = np.unique(sub * np.int64(mesh.n_faces) + parent[fidx])
            support = np.bincount(pairs // mesh.n_faces, minlength=m)
            area = np.bincount(sub, weights=areas[fidx], minlength=m)
            present = np.bincount(sub, minlength=m) > 0
            keep = np.zeros(m, dtype=bool)
            keep[:n_runs] = (p_hi[:n_runs] - p_lo[:n_runs] >= params.min_wall_length_m) & (y_lo[:n_runs] <= story.floor + params.floor_reach_m)
            # ids of the sub-segments that exist, in order
            ids = np.cumsum(present) - 1 + len(seg_story)
            piece_segment[fidx] = ids[sub]
            seg_story.extend([story.index] * int(present.sum()))
            seg_kept.extend(keep[present].tolist())
            found = [
                {
                    "story": story.index,
                    "direction": d_index,
                    "offset": float(p_off[j]),
                    "u_min": float(p_lo[j]),
                    "u_max": float(p_hi[j]),
                    "bottom": float(y_lo[j]),
                    "top": float(y_hi[j]),
                    "support": int(support[j]),
                    "area": float(area[j]),
                    "segments": [int(ids[j])],
                }
                for j in np.flatnonzero(keep)
            ]
            rows.extend(_merge(found, params.box_depth_m / 2, params.merge_gap_m))
        below = [r for r in rows[first:] if r["top"] >= story.ceiling - params.ceiling_reach_m]
    rows.sort(key=lambda r: (r["story"], r["direction"], r["offset"], r["u_min"]))
    segment_wall = np.full(len(seg_story), -1, dtype=np.int64)
    for w, r in enumerate(rows):
        segment_wall[r["segments"]] = w
    # a face split into pieces takes the segment of its first piece in a segment
    face_segment = np.full(mesh.n_faces, -1, dtype=np.int64)
    labelled = np.flatnonzero(piece_segment >= 0)[::-1]
    face_segment[parent[labelled]] = piece_segment[labelled]
    col = lambda key, dtype=np.float64: np.array([r[key] for r in rows], dtype=dtype)  # noqa: E731
    return FlatWalls(
        story=col("story", np.int64),
        direction=col("direction", np.int64),
        normal=dirs[col("direction", np.int64)] if rows else np.zeros((0, 2)),
        offset=col("offset"),
        u_min=col("u_min"),
        u_max=col("u_max"),
        bottom=col("bottom"),
        top=col("top"),
        support=col("support", np.int64),
        area=col("area"),
        directions=dirs,
        face_segment=face_segment,
        segment_story=np.array(seg_story, dtype=np.int64),
        segment_kept=np.array(seg_kept, dtype=bool),
        segment_wall=segment_wall,
    )


def _wall_columns(
    cols: Columns, raster: StoryRaster, normal: FloatArray, floor: float, ceiling: float | None, width: float, params: WallParams
) -> tuple[np.ndarray, np.ndarray]:
    """Which columns show the evidence of a wall, and which are neutral (see
    :mod:`meshplan.walls.evidence`).

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
    above_work = top > floor + params.max_work_surface_m
    seen = cols.top - cols.bottom >= MIN_COLUMN_SPAN_SHARE * (target - floor)
    furniture_top = top_attached(raster, normal, cols, width) >= MIN_TOP_SHARE
    hidden = hidden_behind(cols, params.context_m, params.max_wall_thickness_m)
    plausible = reaches & above_work & ~furniture_top & ~hidden
    return plausible & seen, plausible & ~seen

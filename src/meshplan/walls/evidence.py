"""Evidence that a DBSCAN wall segment is a wall, column by column ("walls are walls").

The paper keeps a segment when it reaches from near the floor to near the ceiling. On real scans
that test fails both ways: a story without a scanned ceiling gets an assumed one (``--default-
ceiling-height``) that its walls need not reach (the scan ends at 1.4-1.8 m, RoomPlan walls are
2.8 m tall), and a counter front in the plane of a tall cupboard makes one segment that reaches
the ceiling. A wall is a vertical surface that bounds a space, so each segment is cut into
*columns* (vertical strips ``column_m`` wide along the wall) and a column is a wall where

* its top reaches what is above it: the ceiling where the story has one, else the top of what
  was scanned in front of and behind it (a wall whose top is lost in unscanned space reaches;
  a counter front with the wall behind it scanned higher does not); a column at the edge of
  the scan, with nothing scanned behind it, reaches when it rises above door height
  (:data:`EDGE_WALL_MIN_TOP_M`): its top is lost in the band under the ceiling that headsets
  miss;
* it rises above the highest work surface (``max_work_surface_m``), or, at the edge of the
  scan with no top attached and nothing flush behind it, above :data:`EDGE_WALL_MIN_SEEN_M`
  (the scan ended below the work-surface height);
* it is seen over at least :data:`MIN_COLUMN_SPAN_SHARE` of the height it must rise to (not a
  beam, a lintel or a shelf board alone);
* nothing horizontal is attached to its top edge behind it (the top of a counter, a desk, a
  bed, a sideboard: a front's top surface lies right behind its upper edge, on the side its
  normal points away from);
* no other surface facing the same way stands behind it, deeper than a wall is thick and within
  ``context_m`` (the wall behind a cupboard or a shelf: a surface in front of a scanned wall
  does not bound the space).

The wall is then made of the runs of consecutive wall columns of each segment. Everything is
measured on rasters of the story (:class:`StoryRaster`) and on per-column reductions, with no
per-triangle Python loop.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from .._kernels import centroids_areas, max_corner_distance, plan_rasters, scatter_max, scatter_min, stable_argsort_f64, stable_group_order
from ..geometry import FloatArray, IntArray

#: Cell of the plan rasters of a story (m): finer than a counter's depth (0.6 m) and a wall's
#: thickness, coarser than the triangles of phone and headset scans (4-10 cm), so that each
#: scanned surface fills its cells (every face marks the cells of its corners and centroid).
RASTER_M = 0.1

#: A face is horizontal when its normal is within this angle of up (degrees): the tops of
#: counters, desks and beds are level to a few degrees even in a noisy scan.
HORIZONTAL_DEG = 15.0

#: Horizontal surfaces this close to the floor (m) are the floor itself (sunken parts, noise),
#: not the top of furniture.
FLOOR_CLEARANCE_M = 0.2

#: Largest height difference (m) between a front's top edge and the horizontal surface behind
#: it that still makes them one piece of furniture: rounded edges and the noise of headset scans
#: (2-5 cm), not the gap between a wall's top and a shelf.
TOP_EDGE_TOLERANCE_M = 0.08

#: Where the top of a piece of furniture is sought behind its front (m across, behind the face):
#: from just behind the front (its edge is rounded over about 5 cm) to the depth of a shallow
#: desk (0.5 m); shelves (0.3 m) and counters (0.6 m) cover most of it.
TOP_SEARCH_M = (0.05, 0.5)

#: Share of the search strip behind a column's top edge that a horizontal surface at that
#: height must cover for the column to be a front of furniture: a counter or desk top covers
#: nearly all of it, the odd level triangle of a noisy wall top very little.
MIN_TOP_SHARE = 0.3

#: A column is seen over at least this share of the height it must rise to (from the floor to
#: the top it must reach): a wall behind furniture is hidden below counter height at most, a
#: beam, a lintel or a shelf board is a thin band.
MIN_COLUMN_SPAN_SHARE = 0.5

#: A surface behind a column hides it only when it is seen over at least this height (m): a
#: strip of the wall behind a counter (its backsplash) or a cupboard, not a skirting board or a
#: window sill.
MIN_BEHIND_SPAN_M = 0.3

#: Something scanned this close below the story's ceiling (m) is the ceiling: headset meshes
#: scatter a ceiling by 2-5 cm, while wardrobes and tall cupboards stop 0.2 m or more below it.
CEILING_TOLERANCE_M = 0.1

#: A column at the edge of the scan (nothing scanned behind it) whose top is at least this high
#: above the floor (m) reaches: its top is lost in the unscanned band under the ceiling, which
#: headsets often miss on walls (their rays graze it). Door heads (2.0-2.1 m) and furniture
#: (rarely above 2 m, see ``WallParams.ceiling_reach_m``) stay below it; a wardrobe or a screen
#: this tall has the wall or the ceiling scanned behind it.
EDGE_WALL_MIN_TOP_M = 2.1

#: A column at the edge of the scan with no horizontal top attached behind its upper edge and no
#: surface flush behind it rises above the work surfaces when its top is this high above the
#: floor (m): where nothing was scanned beyond it, a top below ``max_work_surface_m`` is where
#: the scan ended (stories scanned to 1.2-1.8 m), while the fronts that low (sofa and seat
#: backs, beds, sideboards: 0.4-0.9 m) either show their top or stand against a wall.
EDGE_WALL_MIN_SEEN_M = 1.0

#: Faces are split until no edge is longer than this share of the DBSCAN box length: DBSCAN
#: counts triangle centroids, which stand for the scanned surface only when triangles are
#: smaller than the box (a parametric RoomPlan or Quest wall is two triangles).
SPLIT_SHARE = 0.5

#: Most pieces an edge of one face is split into (n^2 triangles per face): a 64-way split of a
#: 0.23 m target covers edges up to 15 m, longer than any single wall rectangle.
MAX_SPLIT = 64


def subdivide(triangles: FloatArray, max_edge_m: float) -> tuple[FloatArray, IntArray]:
    """Split every face with an edge longer than ``max_edge_m`` into ``n^2`` equal triangles.

    Parameters
    ----------
    triangles
        ``(F, 3, 3)`` corners.
    max_edge_m
        Longest edge wanted (m); each face is split ``n = ceil(longest edge / max_edge_m)``
        ways along each edge (at most :data:`MAX_SPLIT`).

    Returns
    -------
    pieces, parent
        ``(P, 3, 3)`` corners of the pieces (faces that needed no split are kept first, in
        order) and ``(P,)`` the face each piece comes from.
    """
    edges = longest_edge(triangles)
    n_split = np.clip(np.ceil(edges / max_edge_m), 1, MAX_SPLIT).astype(np.int64)
    if not np.any(n_split > 1):  # dense scans: nothing to split (no copy of the mesh)
        return triangles, np.arange(len(triangles), dtype=np.int64)
    keep = np.flatnonzero(n_split == 1)
    pieces = [triangles[keep]]
    parents = [keep]
    for n in np.unique(n_split[n_split > 1]):
        idx = np.flatnonzero(n_split == n)
        bary = _split_template(int(n))  # (n^2, 3, 3) barycentric corners
        sub = np.einsum("pkj,fjd->fpkd", bary, triangles[idx]).reshape(-1, 3, 3)
        pieces.append(sub)
        parents.append(np.repeat(idx, len(bary)))
    return np.concatenate(pieces), np.concatenate(parents).astype(np.int64)


def longest_edge(triangles: FloatArray) -> FloatArray:
    """``(F,)`` length of the longest edge of each face: the numbers of
    ``np.linalg.norm(t - np.roll(t, 1, axis=1), axis=2).max(axis=1)``, in one compiled pass."""
    tri = np.ascontiguousarray(triangles, dtype=np.float64)
    return max_corner_distance(tri, tri, 2)


def _split_template(n: int) -> FloatArray:
    """Barycentric corners ``(n^2, 3, 3)`` of the regular ``n``-way split of a triangle."""
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    up = i + j < n  # upright triangles (i, j), (i+1, j), (i, j+1)
    down = i + j < n - 1  # inverted ones (i+1, j), (i+1, j+1), (i, j+1)
    corners = []
    for di, dj, mask in (((0, 1, 0), (0, 0, 1), up), ((1, 1, 0), (0, 1, 1), down)):
        a = np.stack([i[mask] + di[k] for k in range(3)], axis=1)
        b = np.stack([j[mask] + dj[k] for k in range(3)], axis=1)
        corners.append(np.stack([n - a - b, a, b], axis=2) / n)  # weights of corners 0, 1, 2
    return np.concatenate(corners).astype(np.float64)


@dataclass(frozen=True)
class StoryRaster:
    """Plan rasters (x, z) of one story, :data:`RASTER_M` cells.

    Attributes
    ----------
    top
        Highest scanned point in each cell (m; ``-inf`` where nothing was scanned), capped at
        the ceiling where the story has one (stray triangles above it are not the room).
    shelf
        Highest level, upward-facing surface in each cell above the floor and below the ceiling
        (m; ``nan`` where none): the tops of counters, desks, beds and shelves.
    floor
        Cells where the floor itself was scanned (a level, upward-facing surface within
        :data:`FLOOR_CLEARANCE_M` of the floor height), as 1.0, else 0.0: what lies on the far
        side of a piece of wall (:func:`floor_behind`).
    """

    x0: float
    z0: float
    top: FloatArray
    shelf: FloatArray
    floor: FloatArray

    def sample(self, grid: FloatArray, x: FloatArray, z: FloatArray, outside: float) -> FloatArray:
        """Values of ``grid`` at plan points, ``outside`` beyond the raster."""
        i = np.floor((x - self.x0) / RASTER_M).astype(np.int64)
        k = np.floor((z - self.z0) / RASTER_M).astype(np.int64)
        ok = (i >= 0) & (i < grid.shape[0]) & (k >= 0) & (k < grid.shape[1])
        out = np.full(np.shape(x), outside, dtype=np.float64)
        out[ok] = grid[i[ok], k[ok]]
        return out


def story_raster(triangles: FloatArray, normals: FloatArray, floor: float, ceiling: float | None) -> StoryRaster:
    """The rasters of a story from its faces.

    Parameters
    ----------
    triangles, normals
        ``(F, 3, 3)`` corners and ``(F, 3)`` unit normals of the story's faces (plan frame).
    floor
        Floor height (m).
    ceiling
        Ceiling height where one was scanned, else ``None``.
    """
    if not len(triangles):
        return StoryRaster(0.0, 0.0, np.full((1, 1), -np.inf), np.full((1, 1), np.nan), np.zeros((1, 1)))
    tri = np.ascontiguousarray(triangles, dtype=np.float64)
    centroid = centroids_areas(tri)[0]
    level = normals[:, 1] >= np.cos(np.radians(HORIZONTAL_DEG))
    level &= centroid[:, 1] > floor + FLOOR_CLEARANCE_M
    if ceiling is not None:
        level &= centroid[:, 1] < ceiling - FLOOR_CLEARANCE_M
    on_floor = (normals[:, 1] >= np.cos(np.radians(HORIZONTAL_DEG))) & (np.abs(centroid[:, 1] - floor) <= FLOOR_CLEARANCE_M)
    # corners and centroid mark cells, in one compiled pass per raster step (no (4F,) arrays)
    x0, z0, top, shelf, floor_cells = plan_rasters(tri, centroid, level, on_floor, np.inf if ceiling is None else float(ceiling), ceiling is not None, RASTER_M)
    shelf[np.isinf(shelf)] = np.nan
    return StoryRaster(float(x0), float(z0), top, shelf, floor_cells)


@dataclass(frozen=True)
class Columns:
    """Vertical strips of the segments of one wall direction (one row per column).

    ``segment``, ``bin`` (index along the wall, ``floor(u / width)``), ``u_lo``/``u_hi``
    (extent along the wall of its faces), ``bottom``/``top`` (heights of its faces),
    ``offset`` (the plane of the column itself: the area-weighted median of its faces across
    the wall, so that a wall a few degrees off its direction is followed along its length, not
    sampled where its segment's mean plane passes), ``u`` (area-weighted mean position of its
    faces along the wall) and ``area`` (of its faces, m2); ``face_column`` is the column of
    every face.
    """

    segment: IntArray
    bin: IntArray
    u_lo: FloatArray
    u_hi: FloatArray
    bottom: FloatArray
    top: FloatArray
    offset: FloatArray
    u: FloatArray
    area: FloatArray
    face_column: IntArray

    def __len__(self) -> int:
        return int(len(self.segment))


def columns(
    labels: IntArray, u: FloatArray, vertex_u: FloatArray, vertex_y: FloatArray, v: FloatArray, area: FloatArray, width_m: float,
    v_order: IntArray | None = None,
) -> Columns:
    """Cut segments into columns ``width_m`` wide along the wall.

    Parameters
    ----------
    labels
        ``(n,)`` segment of each face.
    u
        ``(n,)`` position of each face's centroid along the wall (m): it picks the column.
    vertex_u, vertex_y
        ``(n, 3)`` positions along the wall and heights of each face's corners.
    v
        ``(n,)`` position of each face's centroid across the wall (m).
    area
        ``(n,)`` area of each face (m2): the weights of the column's plane and centre.
    width_m
        Column width (m).
    v_order
        ``np.argsort(v, kind="stable")``, where the caller has it.
    """
    b = np.floor(u / width_m).astype(np.int64)
    span = int(b.max() - b.min()) + 1
    flat, face_column = np.unique(labels * span + (b - b.min()), return_inverse=True)  # 1-D keys: fast
    face_column = face_column.reshape(-1)
    keys = np.c_[flat // span, flat % span + b.min()]
    m = len(keys)
    rep = np.repeat(face_column, 3)
    u_lo, u_hi, y_lo, y_hi = np.full(m, np.inf), np.full(m, -np.inf), np.full(m, np.inf), np.full(m, -np.inf)
    vu, vy = np.ascontiguousarray(vertex_u, dtype=np.float64).reshape(-1), np.ascontiguousarray(vertex_y, dtype=np.float64).reshape(-1)
    scatter_min(u_lo, rep, vu)
    scatter_max(u_hi, rep, vu)
    scatter_min(y_lo, rep, vy)
    scatter_max(y_hi, rep, vy)
    col_area = np.bincount(face_column, weights=area, minlength=m).astype(np.float64)
    centre = np.bincount(face_column, weights=area * u, minlength=m) / np.maximum(col_area, 1e-300)
    offset = group_weighted_median(face_column, v, area, m, v_order)
    return Columns(keys[:, 0], keys[:, 1], u_lo, u_hi, y_lo, y_hi, offset, centre, col_area, face_column)


def group_weighted_median(labels: IntArray, values: FloatArray, weights: FloatArray, k: int, value_order: IntArray | None = None) -> FloatArray:
    """``(k,)`` weighted median of ``values`` in each group ``0 .. k-1`` of ``labels`` (every
    group must hold at least one value): the plane of a wall or of a strip of it, robust to the
    few faces of a fixture or a frame in front of it.

    ``value_order`` is ``np.argsort(values, kind="stable")`` where the caller has it (several
    groupings of the same values): the order is that of ``np.lexsort((values, labels))``, a
    stable sort by value then a stable counting sort by group."""
    if value_order is None:  # numpy's stable order, by a compiled radix sort (2-4x faster)
        value_order = stable_argsort_f64(np.ascontiguousarray(values, dtype=np.float64))
    order = value_order[stable_group_order(np.asarray(labels, dtype=np.int64)[value_order], int(k))]
    lab, val, w = labels[order], values[order], weights[order]
    cw = np.cumsum(w)
    start = np.searchsorted(lab, np.arange(k))
    end = np.searchsorted(lab, np.arange(k), side="right")
    before = np.where(start > 0, cw[np.maximum(start - 1, 0)], 0.0)
    total = cw[end - 1] - before
    target = before + 0.5 * total
    idx = np.searchsorted(cw, target)
    return val[np.clip(idx, start, end - 1)]


def _region(raster: StoryRaster, grid: FloatArray, normal: FloatArray, cols: Columns, width_m: float, across: FloatArray, outside: float) -> FloatArray:
    """``(m, s)`` raster values at samples of each column: 3 along it, ``across`` (m, positive
    into the room) from its plane."""
    tangent = np.array([-normal[1], normal[0]])
    centre = (cols.bin + 0.5) * width_m
    along = centre[:, None] + np.array([-1 / 3, 0.0, 1 / 3]) * width_m  # (m, 3)
    a = cols.offset[:, None, None] + across[None, None, :]  # (m, 1, s)
    x = along[:, :, None] * tangent[0] + a * normal[0]
    z = along[:, :, None] * tangent[1] + a * normal[1]
    return raster.sample(grid, x, z, outside).reshape(len(cols), -1)


def local_top(raster: StoryRaster, normal: FloatArray, cols: Columns, width_m: float, context_m: float, thickness_m: float) -> FloatArray:
    """Top of what was scanned in front of each column and behind it beyond the wall's thickness
    (m; ``-inf`` where nothing was), within ``context_m``: what the column's top must reach. The
    other face of the wall itself, which another room may show higher, is left out."""
    step = RASTER_M / 2
    front = np.arange(step, context_m + 1e-9, step)
    behind = -np.arange(thickness_m + step, context_m + 1e-9, step)
    return _region(raster, raster.top, normal, cols, width_m, np.r_[front, behind], -np.inf).max(axis=1)


def behind_top(raster: StoryRaster, normal: FloatArray, cols: Columns, width_m: float, context_m: float, thickness_m: float) -> FloatArray:
    """Top of what was scanned behind each column, beyond the wall's thickness and within
    ``context_m`` (m; ``-inf`` where nothing was): the wall behind a front, the ceiling running
    on over a screen, or nothing at the edge of the scan."""
    step = RASTER_M / 2
    behind = -np.arange(thickness_m + step, context_m + 1e-9, step)
    if not len(behind):
        return np.full(len(cols), -np.inf)
    return _region(raster, raster.top, normal, cols, width_m, behind, -np.inf).max(axis=1)


def top_attached(raster: StoryRaster, normal: FloatArray, cols: Columns, width_m: float) -> FloatArray:
    """Share of the strip behind each column's top edge (:data:`TOP_SEARCH_M`) covered by a level
    surface at the height of that edge (within :data:`TOP_EDGE_TOLERANCE_M`)."""
    behind = -np.arange(TOP_SEARCH_M[0], TOP_SEARCH_M[1] + 1e-9, RASTER_M / 2)
    shelf = _region(raster, raster.shelf, normal, cols, width_m, behind, np.nan)
    with np.errstate(invalid="ignore"):
        hit = np.abs(shelf - cols.top[:, None]) <= TOP_EDGE_TOLERANCE_M
    return hit.mean(axis=1)


def floor_behind(raster: StoryRaster, start: FloatArray, end: FloatArray, normal: FloatArray, thickness_m: float, depth_m: float) -> FloatArray:
    """Share of the length of each wall face with the floor scanned behind it (on the side its
    normal points away from), beyond ``thickness_m`` and within ``depth_m``.

    A wall bounds a space: behind it is its other face, then another room or nothing the
    scanner saw from inside. Floor scanned right behind a short piece means the scanner walked
    around it: a free-standing panel, pillar or screen.

    Parameters
    ----------
    start, end
        ``(W, 2)`` plan ends of the faces.
    normal
        ``(W, 2)`` their normals (into the room they were scanned from).
    thickness_m, depth_m
        The band behind each face that is searched (m).
    """
    return _share_behind(raster, raster.floor, 0.5, start, end, normal, thickness_m, depth_m)


def ceiling_behind(
    raster: StoryRaster, start: FloatArray, end: FloatArray, normal: FloatArray, thickness_m: float, depth_m: float, ceiling_m: float
) -> FloatArray:
    """Share of the length of each wall face with something scanned up to ``ceiling_m`` (the
    story's ceiling, less :data:`CEILING_TOLERANCE_M`) behind it (pass ``-normal`` for the side
    in front), beyond ``thickness_m`` and within ``depth_m``: the space goes on over the face's
    top. A wall bounds the space up to the ceiling; behind it lies its other face, then another
    room or nothing seen. Behind a pillar or a column the ceiling runs on all round its top (its
    footprint is a small hole in the scanned ceiling). Same parameters as :func:`floor_behind`."""
    return _share_behind(raster, raster.top, ceiling_m, start, end, normal, thickness_m, depth_m)


def seen_in_front(raster: StoryRaster, start: FloatArray, end: FloatArray, normal: FloatArray, near_m: float, depth_m: float) -> FloatArray:
    """Share of the length of each wall face with anything scanned in front of it (on the side
    its normal points to), beyond ``near_m`` and within ``depth_m``: where nothing is, the face
    looks out of everything scanned (the outer face of a model's exterior wall). Same
    parameters as :func:`floor_behind`."""
    return _share_behind(raster, raster.top, float(np.finfo(np.float64).min), start, end, -normal, near_m, depth_m)


def work_surface_in_front(raster: StoryRaster, start: FloatArray, end: FloatArray, normal: FloatArray, floor: float, work_surface_m: float) -> FloatArray:
    """Share of the length of each wall face with a level surface at work-surface height (more
    than :data:`FLOOR_CLEARANCE_M` and at most ``work_surface_m`` above ``floor``) in front of
    it, in the strip where a counter's or a desk's top meets a front (:data:`TOP_SEARCH_M`, on
    the side ``normal`` points to): a desk or a counter against the face."""
    with np.errstate(invalid="ignore"):
        work = np.where(_at_work_height(raster.shelf, floor, work_surface_m), 1.0, 0.0)
    return _share_behind(raster, work, 0.5, start, end, -normal, TOP_SEARCH_M[0] - RASTER_M / 2, TOP_SEARCH_M[1])


def work_surface_height(raster: StoryRaster, start: FloatArray, end: FloatArray, normal: FloatArray, floor: float, work_surface_m: float) -> FloatArray:
    """Median height (m) of the level surfaces at work-surface height in front of each wall
    face, in the strip of :func:`work_surface_in_front` (``nan`` where there is none): the top of
    the desk or the counter against it."""
    if not len(start):
        return np.zeros(0)
    h = _behind(raster, raster.shelf, np.nan, start, end, -normal, TOP_SEARCH_M[0] - RASTER_M / 2, TOP_SEARCH_M[1]).reshape(len(start), -1)
    with np.errstate(invalid="ignore"):
        h = np.where(_at_work_height(h, floor, work_surface_m), h, np.nan)
    out = np.full(len(start), np.nan)
    some = np.isfinite(h).any(axis=1)
    out[some] = np.nanmedian(h[some], axis=1)
    return out


def _at_work_height(shelf: FloatArray, floor: float, work_surface_m: float) -> np.ndarray:
    """Where a level surface lies at work-surface height: more than :data:`FLOOR_CLEARANCE_M`
    and at most ``work_surface_m`` above ``floor`` (False where there is none, ``nan``)."""
    return (shelf > floor + FLOOR_CLEARANCE_M) & (shelf <= floor + work_surface_m)


def top_around(raster: StoryRaster, start: FloatArray, end: FloatArray, normal: FloatArray, thickness_m: float, depth_m: float) -> FloatArray:
    """Highest point scanned in front of each wall face (within ``depth_m``) and behind it
    (beyond ``thickness_m`` and within ``depth_m``), along its length (m; ``-inf`` where nothing
    was): where it is no higher than the face's own top, that top is lost in unscanned space."""
    if not len(start):
        return np.zeros(0)
    step = RASTER_M / 2
    along = (np.arange(8) + 0.5) / 8
    across = np.r_[-np.arange(step, depth_m + 1e-9, step), np.arange(thickness_m + step, depth_m + 1e-9, step)]
    p = start[:, None, None, :] + along[None, :, None, None] * (end - start)[:, None, None, :]
    p = p - across[None, None, :, None] * normal[:, None, None, :]
    return raster.sample(raster.top, p[..., 0], p[..., 1], -np.inf).reshape(len(start), -1).max(axis=1)


def _share_behind(
    raster: StoryRaster, grid: FloatArray, at_least: float, start: FloatArray, end: FloatArray, normal: FloatArray, thickness_m: float, depth_m: float
) -> FloatArray:
    """Share of the length of each face with a cell of ``grid`` of at least ``at_least`` behind
    it, beyond ``thickness_m`` and within ``depth_m`` (8 samples along each face)."""
    if not len(start):
        return np.zeros(0)
    hit = _behind(raster, grid, -np.inf, start, end, normal, thickness_m, depth_m) >= at_least
    return hit.any(axis=2).mean(axis=1) if hit.shape[2] else np.zeros(len(start))


def _behind(
    raster: StoryRaster, grid: FloatArray, outside: float, start: FloatArray, end: FloatArray, normal: FloatArray, thickness_m: float, depth_m: float
) -> FloatArray:
    """``(W, 8, depth)`` values of ``grid`` behind each face (``outside`` beyond the raster): 8
    samples along it, each at every :data:`RASTER_M` / 2 beyond ``thickness_m`` and within
    ``depth_m`` on the side ``normal`` points away from."""
    step = RASTER_M / 2
    along = (np.arange(8) + 0.5) / 8  # samples along each face
    behind = np.arange(thickness_m + step, depth_m + 1e-9, step)
    p = start[:, None, None, :] + along[None, :, None, None] * (end - start)[:, None, None, :]
    p = p - behind[None, None, :, None] * normal[:, None, None, :]
    return raster.sample(grid, p[..., 0], p[..., 1], outside)


def hidden_behind(cols: Columns, context_m: float, thickness_m: float, work_surface_m: float) -> np.ndarray:
    """Columns with a surface facing the same way behind them, deeper than ``thickness_m`` and
    within ``context_m``, seen over :data:`MIN_BEHIND_SPAN_M` and rising above the work surfaces
    (``work_surface_m``, or the column's own top where that is lower; within
    :data:`TOP_EDGE_TOLERANCE_M`): the wall behind a cupboard, a counter or a shelf, so that the
    column itself does not bound the space. The height test keeps a partition whose far side has
    furniture against it: the back of a desk or a sideboard in the next room faces the same way
    and stands right behind the partition, but ends at table height, while a wall behind a front
    rises above any work surface (where it is scanned above the front at all)."""
    tall = cols.top - cols.bottom >= MIN_BEHIND_SPAN_M
    out = np.zeros(len(cols), dtype=bool)
    if not tall.any():
        return out
    # per bin along the wall, the offsets of the tall columns, sorted: a window search
    order = np.lexsort((cols.offset[tall], cols.bin[tall]))
    tb, to = cols.bin[tall][order], cols.offset[tall][order]
    ttop = cols.top[tall][order]
    lo = _search(tb, to, cols.bin, cols.offset - context_m, "left")
    hi = _search(tb, to, cols.bin, cols.offset - thickness_m, "right")
    # the highest top in each window [lo, hi): windows hold the few parallel surfaces of one bin,
    # so a loop over the offset within the window (not over columns) covers them all
    need = np.minimum(cols.top, work_surface_m) - TOP_EDGE_TOLERANCE_M
    width = int((hi - lo).max()) if len(hi) else 0
    for k in range(width):
        idx = lo + k
        inside = idx < hi
        out[inside] |= ttop[idx[inside]] >= need[inside]
    return out


def _search(bins: IntArray, values: FloatArray, qbin: IntArray, qvalue: FloatArray, side: Literal["left", "right"]) -> IntArray:
    """``searchsorted`` of ``(qbin, qvalue)`` in the rows ``(bins, values)`` sorted by bin, then value."""
    start = np.searchsorted(bins, qbin, side="left")
    end = np.searchsorted(bins, qbin, side="right")
    out = np.empty(len(qbin), dtype=np.int64)
    # values are sorted within each bin; offset them by the bin so one searchsorted serves all
    span = float(np.abs(values).max() + np.abs(qvalue).max() + 1.0) * 4.0
    key = bins * span + values
    out[:] = np.searchsorted(key, qbin * span + qvalue, side=side)
    return np.clip(out, start, end)


def neighbour_max(cols: Columns, values: FloatArray) -> FloatArray:
    """Largest of ``values`` over each column and the columns beside it in its segment (one bin
    either side): the top of a wall is judged over about a box length, so that a patch of it
    scanned a little lower does not break it."""
    key = cols.segment * (int(cols.bin.max() - cols.bin.min()) + 3) + (cols.bin - cols.bin.min() + 1)
    order = np.argsort(key)
    sk, sv = key[order], values[order]
    out = sv.copy()
    for step in (-1, 1):
        j = np.searchsorted(sk, sk + step)
        j = np.clip(j, 0, len(sk) - 1)
        hit = sk[j] == sk + step
        out[hit] = np.maximum(out[hit], sv[j[hit]])
    res = np.empty_like(out)
    res[order] = out
    return res


def runs(cols: Columns, wall: np.ndarray, neutral: np.ndarray, grazed: np.ndarray | None = None) -> IntArray:
    """Run of wall columns of each column's segment (-1 for columns in none).

    A run is a sequence of consecutive wall and *neutral* columns (too little seen to tell, such
    as the lintel over a door: they neither start nor break a wall), trimmed to its first and
    last wall column; any other column ends it. Columns with no faces (holes in the scan) do not
    end a run. *Grazed* columns (the end of a wall at the edge of the scan, seen lower and lower
    as the sensor's rays grazed it) extend a run that holds a wall column but start none: the
    run is trimmed to its first and last wall or grazed column.
    """
    order = np.lexsort((cols.bin, cols.segment))
    seg, w = cols.segment[order], wall[order]
    g = np.zeros(len(w), dtype=bool) if grazed is None else grazed[order] & ~w
    ok = w | neutral[order] | g
    new_seg = np.r_[True, seg[1:] != seg[:-1]]
    start = ok & (new_seg | ~np.r_[False, ok[:-1]])
    run = np.where(ok, np.cumsum(start) - 1, -1)
    n = int(run.max()) + 1
    pos = np.arange(len(run))
    first = np.full(max(n, 1), len(run))
    last = np.full(max(n, 1), -1)
    has_wall = np.zeros(max(n, 1), dtype=bool)
    has_wall[run[w]] = True
    ends = (w | g) & (run >= 0) & has_wall[np.maximum(run, 0)]
    np.minimum.at(first, run[ends], pos[ends])
    np.maximum.at(last, run[ends], pos[ends])
    inside = (run >= 0) & (pos >= first[np.maximum(run, 0)]) & (pos <= last[np.maximum(run, 0)])
    run = np.where(inside, run, -1)
    # renumber the runs that kept a wall column, densely
    kept = np.unique(run[run >= 0])
    run = np.where(run >= 0, np.searchsorted(kept, run), -1)
    out = np.empty(len(cols), dtype=np.int64)
    out[order] = run
    return out

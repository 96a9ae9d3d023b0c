"""Slicing a mesh with horizontal planes, all planes at once (paper, "Slicing the mesh").

For planes ``y_i = y_floor + (y_ceiling - y_floor) * i / n``, every (triangle, plane) pair is
found from each triangle's height range (the planes it spans are a contiguous run of indices),
the pairs are expanded with ``np.repeat`` and every intersection segment is computed in one
vectorized pass. No loop runs over planes or triangles.

A vertex exactly on a plane counts as above it, so a triangle touching a plane with one vertex
gives no segment and a triangle with an edge on the plane gives that edge once (from the
triangle below it); a horizontal triangle lying in a plane gives none.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from .errors import ParameterError
from .geometry import FloatArray, IntArray, in_threads, max3, min3, search_threads


@dataclass(frozen=True, eq=False)
class Slices:
    """Intersection segments of a mesh with a stack of horizontal planes.

    Attributes
    ----------
    heights
        ``(n,)`` plane heights.
    segments
        ``(S, 2, 2)`` segment end points projected on the floor, as [x, z].
    level
        ``(S,)`` index into ``heights`` of each segment's plane.
    face
        ``(S,)`` index of the face each segment comes from.
    """

    heights: FloatArray
    segments: FloatArray
    level: IntArray
    face: IntArray

    def __len__(self) -> int:
        return int(len(self.segments))

    def at(self, i: int) -> FloatArray:
        """Segments of plane ``i``."""
        return self.segments[self.level == i]


def plane_heights(floor: float, ceiling: float, n: int) -> FloatArray:
    """The paper's evenly spaced heights ``floor + (ceiling - floor) * i / n``, ``0 <= i <= n``."""
    if not isinstance(n, (int, np.integer)) or n < 1:
        raise ParameterError(f"the number of slices must be a positive integer, got {n!r}", "pass --slices N with N >= 1")
    return floor + (ceiling - floor) * np.arange(n + 1) / n


#: The corner alone on its side of a plane, indexed by which corners lie at or above it (bit i
#: for corner i): the one above when one is, the one below when two are; -1 when the plane
#: does not cut the triangle (all corners on one side).
_ODD_CORNER = np.array([-1, 0, 1, 2, 2, 1, 0, -1], dtype=np.int64)


#: Faces from which :func:`slice_mesh` cuts a mesh in threads (:data:`meshplan.geometry.SEARCH_THREADS`),
#: this many at least for each: its passes are numpy's, much of them without the interpreter's
#: lock; for fewer a thread's start and the joined arrays cost more than the pass saves.
SLICE_THREAD_MIN_FACES = 200_000


def slice_mesh(triangles: ArrayLike, heights: ArrayLike, select: ArrayLike | None = None) -> Slices:
    """Intersect triangles with the horizontal planes ``y = heights[i]``.

    Parameters
    ----------
    triangles
        ``(F, 3, 3)`` triangle corners (y up).
    heights
        ``(n,)`` increasing plane heights.
    select
        Indices of the triangles to slice (all by default): the slices of
        ``triangles[select]``, ``face`` indexing ``select``, without that copy of their corners
        (a story's, 216 MB at 3M faces): their heights are gathered, and the corners of the faces
        a plane cuts (at the drafting height, a few per cent of them).
    """
    tri = np.asarray(triangles, dtype=np.float64).reshape(-1, 3, 3)
    h = np.asarray(heights, dtype=np.float64).reshape(-1)
    if len(h) > 1 and np.any(np.diff(h) <= 0):
        raise ParameterError("slice heights must be increasing", "check the floor and ceiling heights")
    empty = Slices(h, np.zeros((0, 2, 2)), np.zeros(0, np.int64), np.zeros(0, np.int64))
    rows = None if select is None else np.asarray(select, dtype=np.int64).reshape(-1)
    if not len(tri) or not len(h) or (rows is not None and not len(rows)):
        return empty
    n = len(tri) if rows is None else len(rows)
    parts = search_threads(n // SLICE_THREAD_MIN_FACES)
    if parts == 1:
        return _slice_rows(tri, h, rows, empty)
    # consecutive runs of the faces cut in threads, their segments joined in the faces' order:
    # the slices one pass makes
    cuts = np.linspace(0, n, parts + 1).astype(np.int64)
    runs = [np.arange(a, b) if rows is None else rows[a:b] for a, b in zip(cuts[:-1], cuts[1:])]
    done = in_threads(lambda i: _slice_rows(tri, h, runs[i], empty), parts)
    return Slices(
        h,
        np.concatenate([d.segments for d in done]),
        np.concatenate([d.level for d in done]),
        np.concatenate([d.face + a for d, a in zip(done, cuts[:-1])]),
    )


def _slice_rows(tri: FloatArray, h: FloatArray, rows: IntArray | None, empty: Slices) -> Slices:
    """:func:`slice_mesh` of the faces ``rows`` (all when ``None``) of ``tri``, its arguments
    checked (``face`` indexing ``rows``)."""
    y = tri[:, :, 1] if rows is None else tri[rows, :, 1]
    lo, hi = min3(y), max3(y)
    # planes strictly above the lowest vertex and at or below the highest one can cut
    first = np.searchsorted(h, lo, side="right")
    last = np.searchsorted(h, hi, side="right")
    count = last - first
    faces = np.repeat(np.arange(len(y)), count)
    if not len(faces):
        return empty
    level = np.repeat(first - np.cumsum(count) + count, count) + np.arange(len(faces))
    d = y[faces] - h[level][:, None]  # signed heights of the corners
    above = d >= 0
    # the corner alone on its side of the plane (both cut edges start from it), from a table:
    # one pass where counting the corners above and arg-maximising took four
    odd = _ODD_CORNER[above[:, 0] + 2 * above[:, 1].astype(np.int64) + 4 * above[:, 2]]
    cut = np.flatnonzero(odd >= 0)
    faces, level, odd = faces[cut], level[cut], odd[cut]
    u1, u2 = (odd + 1) % 3, (odd + 2) % 3
    # corners read by flat index from (x, z) of every corner: no (S, 3, 3) copy of the triangles
    xz = tri[:, :, ::2].reshape(-1, 2)
    heights_flat = d.reshape(-1)
    pair, corner = cut * 3, (faces if rows is None else rows[faces]) * 3
    p0 = xz[corner + odd]
    d0 = heights_flat[pair + odd]

    def cut_point(u: np.ndarray) -> np.ndarray:
        du = heights_flat[pair + u]
        return p0 + (xz[corner + u] - p0) * (d0 / (d0 - du))[:, None]

    seg = np.stack([cut_point(u1), cut_point(u2)], axis=1)
    # a top corner touching the plane makes a single point, not a segment
    real = np.any(seg[:, 0] != seg[:, 1], axis=1)
    return Slices(h, seg[real], level[real].astype(np.int64), faces[real].astype(np.int64))


def chain_segments(segments: ArrayLike, tolerance: float = 1e-6) -> list[FloatArray]:
    """Join segments that share end points into polylines.

    The segments of one slice of a mesh meet end to end (neighbouring triangles cut their
    common edge at the same point, to rounding); a CAD file holding one polyline per chain
    instead of one line per triangle is ten times smaller and faster to write and to open.

    Parameters
    ----------
    segments
        ``(S, 2, 2)`` segments.
    tolerance
        End points closer than this (on a grid of this size) are the same point.

    Returns
    -------
    list of ``(k, 2)`` arrays
        Polylines, each with at least two points, covering every segment once; a closed chain
        repeats its first point at the end.
    """
    seg = np.asarray(segments, dtype=np.float64).reshape(-1, 2, 2)
    if not len(seg):
        return []
    _, node = np.unique(np.round(seg.reshape(-1, 2) / tolerance).astype(np.int64), axis=0, return_inverse=True)
    node = node.reshape(-1, 2)
    # incident segments of every node, as CSR arrays
    ends = node.reshape(-1)
    order = np.argsort(ends, kind="stable")
    start = np.searchsorted(ends[order], np.arange(node.max() + 2))
    incident = order // 2  # segment of each sorted end
    degree = np.diff(start)
    used = np.zeros(len(seg), dtype=bool)

    def walk(s: int, at: int) -> list[int]:
        """Nodes visited from node ``at`` along segment ``s`` while the chain goes on through
        nodes of degree 2."""
        path = []
        while True:
            used[s] = True
            at = node[s, 1] if node[s, 0] == at else node[s, 0]
            path.append(int(at))
            if degree[at] != 2:
                return path
            a, b = incident[start[at]], incident[start[at] + 1]
            s = b if a == s else a
            if used[s]:
                return path

    chains = []
    # chains start at nodes of degree other than 2 (ends, junctions), then what is left is loops
    starts = np.flatnonzero(degree[node[:, 0]] != 2).tolist() + np.flatnonzero(degree[node[:, 1]] != 2).tolist()
    for s in starts + list(range(len(seg))):
        if used[s]:
            continue
        first = node[s, 0] if (degree[node[s, 0]] != 2 or degree[node[s, 1]] == 2) else node[s, 1]
        chains.append([int(first), *walk(s, first)])
    # points: the first occurrence of each node among the segment ends
    first_end = np.full(node.max() + 1, -1, dtype=np.int64)
    first_end[ends[::-1]] = np.arange(len(ends))[::-1]
    flat = seg.reshape(-1, 2)
    return [flat[first_end[np.asarray(c)]] for c in chains]

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
from .geometry import FloatArray, IntArray


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


def slice_mesh(triangles: ArrayLike, heights: ArrayLike) -> Slices:
    """Intersect triangles with the horizontal planes ``y = heights[i]``.

    Parameters
    ----------
    triangles
        ``(F, 3, 3)`` triangle corners (y up).
    heights
        ``(n,)`` increasing plane heights.
    """
    tri = np.asarray(triangles, dtype=np.float64).reshape(-1, 3, 3)
    h = np.asarray(heights, dtype=np.float64).reshape(-1)
    if len(h) > 1 and np.any(np.diff(h) <= 0):
        raise ParameterError("slice heights must be increasing", "check the floor and ceiling heights")
    empty = Slices(h, np.zeros((0, 2, 2)), np.zeros(0, np.int64), np.zeros(0, np.int64))
    if not len(tri) or not len(h):
        return empty
    y = tri[:, :, 1]
    lo, hi = y.min(axis=1), y.max(axis=1)
    # planes strictly above the lowest vertex and at or below the highest one can cut
    first = np.searchsorted(h, lo, side="right")
    last = np.searchsorted(h, hi, side="right")
    count = last - first
    faces = np.repeat(np.arange(len(tri)), count)
    if not len(faces):
        return empty
    offsets = np.arange(len(faces)) - np.repeat(np.cumsum(count) - count, count)
    level = np.repeat(first, count) + offsets
    t = tri[faces]
    d = t[:, :, 1] - h[level][:, None]  # signed heights of the corners
    above = d >= 0
    # an edge (a, b) crosses when exactly one end is above; each cut triangle has two
    a_idx = np.array([0, 1, 2])
    b_idx = np.array([1, 2, 0])
    crosses = above[:, a_idx] != above[:, b_idx]
    ok = crosses.sum(axis=1) == 2
    t, d, crosses, faces, level = t[ok], d[ok], crosses[ok], faces[ok], level[ok]
    da, db = d[:, a_idx], d[:, b_idx]
    s = np.where(crosses, da / np.where(crosses, da - db, 1.0), 0.0)
    pa, pb = t[:, a_idx], t[:, b_idx]
    points = pa + (pb - pa) * s[:, :, None]  # (m, 3 edges, 3)
    # the two crossing edges, in edge order
    order = np.argsort(~crosses, axis=1, kind="stable")[:, :2]
    seg = np.take_along_axis(points, order[:, :, None], axis=1)[:, :, [0, 2]]
    # a top corner touching the plane makes a single point, not a segment
    real = np.any(seg[:, 0] != seg[:, 1], axis=1)
    return Slices(h, seg[real], level[real].astype(np.int64), faces[real].astype(np.int64))

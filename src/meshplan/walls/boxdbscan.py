"""The paper's modified DBSCAN: neighbours in an axis-aligned box instead of a sphere.

A point's neighbourhood is the box of the given half-extents centred on it. Dividing every
coordinate by its half-extent turns the box into the unit ball of the Chebyshev (max) metric, so
the clustering is exactly DBSCAN with ``metric="chebyshev", eps=1`` on the scaled coordinates
(a core point has at least ``min_points`` points in its box, itself included; clusters are the
connected components of core points; a border point joins the cluster of its nearest core
neighbour; the rest is noise).

It runs on a grid of unit cells: all points of a cell are neighbours of each other, so a cell
with ``min_points`` points is all core, and only neighbouring cells are searched. Box
neighbourhoods along a wall hold hundreds of points, where a KD-tree pair search would list
every pair; the grid stops at the first link between two cells.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ParameterError
from ..geometry import FloatArray, IntArray

_OFFSETS = np.array([(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)], dtype=np.int64)
_SHIFT = 2**20  # cell coordinates are offset into [0, 2^21) per axis for the key


def _grid(scaled: FloatArray) -> tuple[IntArray, FloatArray, IntArray, IntArray]:
    """Sort points by unit cell; return the order, sorted points, cell starts and neighbour table."""
    cells = np.floor(scaled).astype(np.int64)
    cells -= cells.min(axis=0)
    if cells.size and cells.max() >= 2 * _SHIFT - 2:
        raise ParameterError("the DBSCAN box is too small for the extent of the scan", "use a larger box")
    cells += 1  # room for the -1 offset
    key = (cells[:, 0] * (2 * _SHIFT) + cells[:, 1]) * (2 * _SHIFT) + cells[:, 2]
    order = np.argsort(key, kind="stable")
    key_sorted = key[order]
    uniq, start = np.unique(key_sorted, return_index=True)
    start = np.r_[start, len(key_sorted)].astype(np.int64)
    first = order[start[:-1]]
    base = cells[first]
    nb = base[:, None, :] + _OFFSETS[None, :, :]
    nkey = (nb[..., 0] * (2 * _SHIFT) + nb[..., 1]) * (2 * _SHIFT) + nb[..., 2]
    pos = np.searchsorted(uniq, nkey)
    pos = np.minimum(pos, len(uniq) - 1)
    neigh = np.where(uniq[pos] == nkey, pos, -1).astype(np.int64)
    return order, np.ascontiguousarray(scaled[order]), start, neigh


def box_dbscan(points: ArrayLike, half_extents: ArrayLike, min_points: int) -> tuple[IntArray, np.ndarray]:
    """Cluster points with a box neighbourhood.

    Parameters
    ----------
    points
        ``(N, 3)`` coordinates.
    half_extents
        ``(3,)`` half-sizes of the box along each coordinate axis (the box is centred on the
        point, so two points are neighbours when every coordinate differs by at most the
        half-extent).
    min_points
        Minimum number of points in a box (the centre included) for a core point.

    Returns
    -------
    labels
        ``(N,)`` cluster of every point, numbered from 0 in order of each cluster's first point;
        -1 for noise.
    core
        ``(N,)`` True for core points.
    """
    from .._kernels import dbscan_cell_roots, dbscan_core, dbscan_labels

    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    h = np.asarray(half_extents, dtype=np.float64).reshape(3)
    if not np.all(np.isfinite(h)) or np.any(h <= 0):
        raise ParameterError(f"box half-extents must be positive, got {h.tolist()}", "check the DBSCAN box size")
    if not isinstance(min_points, (int, np.integer)) or min_points < 1:
        raise ParameterError(f"min_points must be a positive integer, got {min_points!r}", "pass a positive integer")
    n = len(p)
    if n == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=bool)
    if not np.all(np.isfinite(p)):
        raise ParameterError("points must be finite", "drop NaN and infinite points first")
    order, sp, start, neigh = _grid(p / h)
    core_s = dbscan_core(sp, start, neigh, int(min_points))
    roots = dbscan_cell_roots(sp, core_s, start, neigh)
    lab_s = dbscan_labels(sp, core_s, start, neigh, roots)
    labels = np.empty(n, dtype=np.int64)
    labels[order] = lab_s
    core = np.empty(n, dtype=bool)
    core[order] = core_s
    # number clusters by their first point, so the result does not depend on the grid
    valid = labels >= 0
    if valid.any():
        uniq, first = np.unique(labels[valid], return_index=True)
        rank = np.empty(len(uniq), dtype=np.int64)
        rank[np.argsort(np.flatnonzero(valid)[first], kind="stable")] = np.arange(len(uniq))
        labels[valid] = rank[np.searchsorted(uniq, labels[valid])]
    return labels, core


@dataclass
class BoxDBSCAN:
    """scikit-learn style estimator around :func:`box_dbscan`.

    Parameters
    ----------
    half_extents
        Half-sizes of the box along x, y and z (or whatever the three coordinates are).
    min_points
        Minimum number of points in a box, the point itself included, for a core point.

    Examples
    --------
    >>> import numpy as np
    >>> pts = np.array([[0, 0, 0], [0.2, 0, 0], [0.4, 0, 0], [5, 0, 0]])
    >>> BoxDBSCAN(half_extents=(0.25, 0.05, 1.0), min_points=2).fit(pts).labels_.tolist()
    [0, 0, 0, -1]
    """

    half_extents: tuple[float, float, float] = (0.2286, 0.0508, 1.25)
    min_points: int = 10
    # fitted attributes (scikit-learn's convention): None until fit() sets them
    labels_: IntArray = field(init=False, repr=False, default=None)  # type: ignore[arg-type]
    core_sample_mask_: np.ndarray = field(init=False, repr=False, default=None)  # type: ignore[arg-type]

    def fit(self, points: ArrayLike) -> BoxDBSCAN:
        self.labels_, self.core_sample_mask_ = box_dbscan(points, self.half_extents, self.min_points)
        return self

    def fit_predict(self, points: ArrayLike) -> IntArray:
        return self.fit(points).labels_

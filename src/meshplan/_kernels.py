"""Compiled inner loops (numba) for the few steps numpy cannot vectorize well.

Each kernel is a plain function of arrays, compiled once and cached on disk. They are private:
the public functions that call them validate their inputs.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def kmeans_round(x, w, centers, idx):  # pragma: no cover - compiled
    """One Lloyd round of spherical k-means over the directions ``x[idx]``.

    Returns the label and the similarity to the chosen centre of each direction, and the
    weighted direction sums and weights of every cluster.
    """
    k = centers.shape[0]
    n = idx.shape[0]
    labels = np.empty(n, np.int64)
    best_sim = np.empty(n, np.float64)
    sums = np.zeros((k, 3), np.float64)
    weights = np.zeros(k, np.float64)
    for ii in range(n):
        i = idx[ii]
        x0, x1, x2 = x[i, 0], x[i, 1], x[i, 2]
        best = -2.0
        bj = 0
        for j in range(k):
            d = x0 * centers[j, 0] + x1 * centers[j, 1] + x2 * centers[j, 2]
            if d > best:
                best = d
                bj = j
        labels[ii] = bj
        best_sim[ii] = best
        wi = w[i]
        sums[bj, 0] += wi * x0
        sums[bj, 1] += wi * x1
        sums[bj, 2] += wi * x2
        weights[bj] += wi
    return labels, best_sim, sums, weights


# ---------------------------------------------------------------------------------------------
# Grid DBSCAN with a box (Chebyshev) neighbourhood of radius 1 in scaled coordinates.
#
# Points are sorted by their unit cell; ``start[c]:start[c+1]`` are the points of cell c and
# ``neigh[c]`` the indices of its 27 neighbouring cells (itself included, -1 where empty). Two
# points of one cell are always neighbours (every coordinate differs by less than 1).


@njit(cache=True, nogil=True)
def _box_close(p, i, j):  # pragma: no cover - compiled
    return abs(p[i, 0] - p[j, 0]) <= 1.0 and abs(p[i, 1] - p[j, 1]) <= 1.0 and abs(p[i, 2] - p[j, 2]) <= 1.0


@njit(cache=True, nogil=True)
def dbscan_core(p, start, neigh, min_pts):  # pragma: no cover - compiled
    """Core flag of every point: at least ``min_pts`` points (itself included) in its box."""
    n_cells = start.shape[0] - 1
    core = np.zeros(p.shape[0], np.bool_)
    for c in range(n_cells):
        a, b = start[c], start[c + 1]
        if b - a >= min_pts:
            for i in range(a, b):
                core[i] = True
            continue
        for i in range(a, b):
            count = 0
            for k in range(neigh.shape[1]):
                nc = neigh[c, k]
                if nc < 0:
                    continue
                for j in range(start[nc], start[nc + 1]):
                    if _box_close(p, i, j):
                        count += 1
                        if count >= min_pts:
                            break
                if count >= min_pts:
                    break
            core[i] = count >= min_pts
    return core


@njit(cache=True, nogil=True)
def _find(parent, x):  # pragma: no cover - compiled
    root = x
    while parent[root] != root:
        root = parent[root]
    while parent[x] != root:
        nxt = parent[x]
        parent[x] = root
        x = nxt
    return root


@njit(cache=True, nogil=True)
def dbscan_cell_roots(p, core, start, neigh):  # pragma: no cover - compiled
    """Union-find over cells: cells are joined when a core point of one is within the box of a
    core point of the other. Returns the root cell of every cell (-1 for cells without core)."""
    n_cells = start.shape[0] - 1
    parent = np.arange(n_cells)
    has_core = np.zeros(n_cells, np.bool_)
    for c in range(n_cells):
        for i in range(start[c], start[c + 1]):
            if core[i]:
                has_core[c] = True
                break
    for c in range(n_cells):
        if not has_core[c]:
            continue
        for k in range(neigh.shape[1]):
            nc = neigh[c, k]
            if nc <= c or not has_core[nc]:
                continue
            if _find(parent, c) == _find(parent, nc):
                continue
            linked = False
            for i in range(start[c], start[c + 1]):
                if not core[i]:
                    continue
                for j in range(start[nc], start[nc + 1]):
                    if core[j] and _box_close(p, i, j):
                        linked = True
                        break
                if linked:
                    break
            if linked:
                ra, rb = _find(parent, c), _find(parent, nc)
                if ra < rb:
                    parent[rb] = ra
                else:
                    parent[ra] = rb
    roots = np.full(n_cells, -1, np.int64)
    for c in range(n_cells):
        if has_core[c]:
            roots[c] = _find(parent, c)
    return roots


@njit(cache=True, nogil=True)
def dbscan_labels(p, core, start, neigh, roots):  # pragma: no cover - compiled
    """Cluster (root cell) of every point: core points take their cell's root; a border point
    takes the root of its nearest core neighbour (Chebyshev distance); noise is -1."""
    n_cells = start.shape[0] - 1
    labels = np.full(p.shape[0], -1, np.int64)
    for c in range(n_cells):
        for i in range(start[c], start[c + 1]):
            if core[i]:
                labels[i] = roots[c]
                continue
            best = 2.0
            for k in range(neigh.shape[1]):
                nc = neigh[c, k]
                if nc < 0 or roots[nc] < 0:
                    continue
                for j in range(start[nc], start[nc + 1]):
                    if not core[j]:
                        continue
                    d = max(abs(p[i, 0] - p[j, 0]), abs(p[i, 1] - p[j, 1]), abs(p[i, 2] - p[j, 2]))
                    if d <= 1.0 and d < best:
                        best = d
                        labels[i] = roots[nc]
    return labels

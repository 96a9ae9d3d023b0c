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


def load_machinery() -> None:
    """Load numba's machinery for compiled code now: a process's first kernel call (any kernel)
    imports and registers numba's implementations, scipy.linalg among them (0.15-0.2 s); each
    kernel after it only loads its own code from the cache (a few ms). A run does so before it
    forks its drawing worker, so that the worker, whose pen-and-ink raster is a kernel
    (:func:`count_levels`), inherits it."""
    scatter_max(np.zeros(1), np.zeros(1, dtype=np.int64), np.zeros(1))


@njit(cache=True, nogil=True)
def scatter_max(out, idx, values):  # pragma: no cover - compiled
    """``np.maximum.at(out, idx, values)`` (NaN values propagate, as there), in one pass."""
    for j in range(idx.shape[0]):
        i = idx[j]
        v = values[j]
        if v > out[i] or v != v:
            out[i] = v


@njit(cache=True, nogil=True)
def scatter_min(out, idx, values):  # pragma: no cover - compiled
    """``np.minimum.at(out, idx, values)`` (NaN values propagate, as there), in one pass."""
    for j in range(idx.shape[0]):
        i = idx[j]
        v = values[j]
        if v < out[i] or v != v:
            out[i] = v


@njit(cache=True, nogil=True)
def count_levels(a, d, n, level, order, rows, cols):  # pragma: no cover - compiled
    """``(rows * cols,)`` how many distinct levels' segments cross each pixel.

    Segment ``i`` runs from ``a[i]`` by ``d[i]`` (pixels, x then y) in ``n[i]`` samples, at
    ``t = k / max(n[i] - 1, 1)``, each in the pixel its coordinates truncate to, and ``order``
    takes the segments level by level: a pixel counts a level when it is first met at it.
    """
    counts = np.zeros(rows * cols, dtype=np.int32)
    last = np.full(rows * cols, -1, dtype=np.int32)
    for j in range(order.shape[0]):
        i = order[j]
        lv = level[i]
        m = max(n[i] - 1, 1)
        for k in range(n[i]):
            t = k / m
            c = int(a[i, 0] + d[i, 0] * t)
            r = int(a[i, 1] + d[i, 1] * t)
            if c >= 0 and c < cols and r >= 0 and r < rows:
                px = r * cols + c
                if last[px] != lv:
                    last[px] = lv
                    counts[px] += 1
    return counts


@njit(cache=True, nogil=True)
def max_corner_distance(tri, other, shift):  # pragma: no cover - compiled
    """``(F,)`` largest distance from corner ``k`` of each face ``tri`` (F, 3, 3) to point
    ``(k + shift) % 3`` of ``other`` (F, 3, 3; a broadcast view will do), a NaN kept as NaN.

    ``max_corner_distance(tri, tri, 2)`` is each face's longest edge (the numbers of
    ``np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1)``), and with ``other``
    the centroids broadcast to (F, 3, 3) it is each face's reach from its centroid."""
    n = tri.shape[0]
    out = np.empty(n, np.float64)
    for f in range(n):
        best = 0.0
        for a in range(3):
            b = (a + shift) % 3
            e0 = tri[f, a, 0] - other[f, b, 0]
            e1 = tri[f, a, 1] - other[f, b, 1]
            e2 = tri[f, a, 2] - other[f, b, 2]
            d = np.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
            if a == 0 or d > best or d != d:
                best = d
        out[f] = best
    return out


@njit(cache=True, nogil=True)
def centroids_areas(tri):  # pragma: no cover - compiled
    """``(F, 3)`` centroids (``(t0 + t1 + t2) / 3``) and ``(F,)`` areas (``|(t1 - t0) x (t2 -
    t0)| / 2``) of the faces ``tri`` (F, 3, 3), with numpy's operations in numpy's order."""
    n = tri.shape[0]
    c = np.empty((n, 3), np.float64)
    area = np.empty(n, np.float64)
    for f in range(n):
        for k in range(3):
            c[f, k] = (tri[f, 0, k] + tri[f, 1, k] + tri[f, 2, k]) / 3.0
        a0 = tri[f, 1, 0] - tri[f, 0, 0]
        a1 = tri[f, 1, 1] - tri[f, 0, 1]
        a2 = tri[f, 1, 2] - tri[f, 0, 2]
        b0 = tri[f, 2, 0] - tri[f, 0, 0]
        b1 = tri[f, 2, 1] - tri[f, 0, 1]
        b2 = tri[f, 2, 2] - tri[f, 0, 2]
        x = a1 * b2 - a2 * b1
        y = a2 * b0 - a0 * b2
        z = a0 * b1 - a1 * b0
        area[f] = 0.5 * np.sqrt(x * x + y * y + z * z)
    return c, area


@njit(cache=True, nogil=True)
def stable_group_order(labels, k):  # pragma: no cover - compiled
    """Indices that sort ``labels`` (ints in ``0 .. k-1``) stably: a counting sort, the order of
    ``np.argsort(labels, kind="stable")``."""
    counts = np.zeros(k + 1, np.int64)
    for j in range(labels.shape[0]):
        counts[labels[j] + 1] += 1
    for i in range(k):
        counts[i + 1] += counts[i]
    out = np.empty(labels.shape[0], np.int64)
    for j in range(labels.shape[0]):
        g = labels[j]
        out[counts[g]] = j
        counts[g] += 1
    return out


@njit(cache=True, nogil=True)
def _edge3(t):  # pragma: no cover - compiled
    """Longest edge of one face ``t`` (3, 3), as ``max_corner_distance(tri, tri, 2)``."""
    best = 0.0
    for a in range(3):
        b = (a + 2) % 3
        e0 = t[a, 0] - t[b, 0]
        e1 = t[a, 1] - t[b, 1]
        e2 = t[a, 2] - t[b, 2]
        d = np.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
        if a == 0 or d > best or d != d:
            best = d
    return best


#: The four pieces of a face split at its edge midpoints, as indices into its corners
#: ``a, b, c`` (0-2) and midpoints ``ab, bc, ca`` (3-5): ``(a, ab, ca), (ab, b, bc), (ca, bc, c),
#: (ab, bc, ca)``, the order of ``meshplan.plan.doors._subdivide``.
_QUARTERS = np.array([[0, 3, 5], [3, 1, 4], [5, 4, 2], [3, 4, 5]], np.int64)


@njit(cache=True, nogil=True)
def _put(dst, i, src):  # pragma: no cover - compiled
    """``dst[i] = src[:3, :3]``, element by element. Numba compiles an array assignment through
    its broadcasting machinery: four of them made ``sample_faces`` the slowest kernel to
    compile by far (6.9 s of a fresh install's first 13.5 s run on the 300k-face apartment)."""
    for k in range(3):
        for d in range(3):
            dst[i, k, d] = src[k, d]


@njit(cache=True, nogil=True)
def _grown(a, rows, size):  # pragma: no cover - compiled
    """A new (``size``, 3, 3) array holding the first ``rows`` faces of ``a``."""
    out = np.empty((size, 3, 3), np.float64)
    for r in range(rows):
        _put(out, r, a[r])
    return out


@njit(cache=True, nogil=True)
def _split_pieces(t, longest, stack, pieces):  # pragma: no cover - compiled
    """The pieces of face ``t`` split into four at its edge midpoints until no edge exceeds
    ``longest`` (corners in the order of ``meshplan.plan.doors._subdivide``), written to
    ``pieces`` (grown as needed); returns them, their number and the (grown) stack."""
    top = 0
    _put(stack, 0, t)
    corners = np.empty((6, 3), np.float64)
    n = 0
    while top >= 0:
        for k in range(3):  # corners[:3] = stack[top]: the face popped
            for d in range(3):
                corners[k, d] = stack[top, k, d]
        top -= 1
        if not (_edge3(corners) > longest):
            if n == pieces.shape[0]:
                pieces = _grown(pieces, n, 2 * n)
            _put(pieces, n, corners)
            n += 1
            continue
        if top + 4 >= stack.shape[0]:
            stack = _grown(stack, top + 1, 2 * stack.shape[0] + 8)
        for d in range(3):
            corners[3, d] = 0.5 * (corners[0, d] + corners[1, d])
            corners[4, d] = 0.5 * (corners[1, d] + corners[2, d])
            corners[5, d] = 0.5 * (corners[2, d] + corners[0, d])
        for q in range(4):
            top += 1
            for k in range(3):
                for d in range(3):
                    stack[top, k, d] = corners[_QUARTERS[q, k], d]
    return pieces, n, stack


@njit(cache=True, nogil=True)
def _levels(e, spacing):  # pragma: no cover - compiled
    return int(min(max(np.ceil(e / spacing), 1.0), 64.0))


@njit(cache=True, nogil=True)
def _grid_points(p, k, out, j):  # pragma: no cover - compiled
    """The barycentric grid of ``k`` steps on face ``p`` written to ``out`` from row ``j``."""
    for i in range(k + 1):
        for jj in range(k + 1 - i):
            a = i / k
            b = jj / k
            w0 = 1 - a - b
            for d in range(3):
                out[j, d] = w0 * p[0, d] + a * p[1, d] + b * p[2, d]
            j += 1
    return j


@njit(cache=True, nogil=True)
def sample_faces(tri, longest, spacing):  # pragma: no cover - compiled
    """The sample points of ``meshplan.plan.rooms.sample_triangles(_subdivide(tri, longest),
    spacing)``, the same points in another order (to rounding: numpy's matmul adds the
    barycentric products in its own order).

    Each face is split into four until no edge exceeds ``longest``; each piece gets the
    barycentric grid of ``k = clip(ceil(edge / spacing), 1, 64)`` steps per edge, every point
    ``(1 - a - b) t0 + a t1 + b t2``.
    """
    n = tri.shape[0]
    stack = np.empty((64, 3, 3), np.float64)
    pieces = np.empty((16, 3, 3), np.float64)
    edge = np.empty(n, np.float64)
    total = 0
    for f in range(n):  # first pass: how many points
        e = _edge3(tri[f])
        edge[f] = e
        if not (e > longest):
            k = _levels(e, spacing)
            total += (k + 1) * (k + 2) // 2
            continue
        pieces, m, stack = _split_pieces(tri[f], longest, stack, pieces)
        for q in range(m):
            k = _levels(_edge3(pieces[q]), spacing)
            total += (k + 1) * (k + 2) // 2
    out = np.empty((total, 3), np.float64)
    j = 0
    for f in range(n):
        if not (edge[f] > longest):
            j = _grid_points(tri[f], _levels(edge[f], spacing), out, j)
            continue
        pieces, m, stack = _split_pieces(tri[f], longest, stack, pieces)
        for q in range(m):
            j = _grid_points(pieces[q], _levels(_edge3(pieces[q]), spacing), out, j)
    return out


@njit(cache=True, nogil=True)
def _root(parent, x):  # pragma: no cover - compiled
    while parent[x] != x:
        parent[x] = parent[parent[x]]
        x = parent[x]
    return x


@njit(cache=True, nogil=True)
def face_components(faces, n_vertices):  # pragma: no cover - compiled
    """``(F,)`` connected piece of every face (faces sharing a vertex are connected), labelled
    by the lowest vertex of the piece: union-find with the lower root kept."""
    parent = np.arange(n_vertices)
    for f in range(faces.shape[0]):
        for e in range(2):
            a = _root(parent, faces[f, e])
            b = _root(parent, faces[f, e + 1])
            if a < b:
                parent[b] = a
            elif b < a:
                parent[a] = b
    out = np.empty(faces.shape[0], np.int64)
    for f in range(faces.shape[0]):
        out[f] = _root(parent, faces[f, 0])
    return out


@njit(cache=True, nogil=True)
def plan_rasters(tri, centroid, level, on_floor, ceiling, capped, cell):  # pragma: no cover - compiled
    """The rasters of ``meshplan.walls.evidence.story_raster`` in three passes over the faces:
    each face marks the cells (``cell`` m, from the lowest x and z of every corner and centroid)
    of its three corners and its centroid. Returns ``x0, z0``, the highest point of each cell
    (capped at ``ceiling`` when ``capped``; ``-inf`` where none), the highest ``level`` centroid
    (``-inf`` where none) and the cells of ``on_floor`` faces (1.0)."""
    n = tri.shape[0]
    x0 = np.inf
    z0 = np.inf
    for f in range(n):
        for a in range(4):
            x = tri[f, a, 0] if a < 3 else centroid[f, 0]
            z = tri[f, a, 2] if a < 3 else centroid[f, 2]
            if x < x0:
                x0 = x
            if z < z0:
                z0 = z
    ni = 0
    nk = 0
    for f in range(n):
        for a in range(4):
            x = tri[f, a, 0] if a < 3 else centroid[f, 0]
            z = tri[f, a, 2] if a < 3 else centroid[f, 2]
            i = int(np.floor((x - x0) / cell))
            k = int(np.floor((z - z0) / cell))
            if i > ni:
                ni = i
            if k > nk:
                nk = k
    ni += 1
    nk += 1
    top = np.full(ni * nk, -np.inf)
    shelf = np.full(ni * nk, -np.inf)
    floor_cells = np.zeros(ni * nk)
    for f in range(n):
        for a in range(4):
            x = tri[f, a, 0] if a < 3 else centroid[f, 0]
            y = tri[f, a, 1] if a < 3 else centroid[f, 1]
            z = tri[f, a, 2] if a < 3 else centroid[f, 2]
            c = int(np.floor((x - x0) / cell)) * nk + int(np.floor((z - z0) / cell))
            if capped and not (y <= ceiling):
                y = ceiling if y == y else y
            if y > top[c] or y != y:
                top[c] = y
            if level[f]:
                v = centroid[f, 1]
                if v > shelf[c] or v != v:
                    shelf[c] = v
            if on_floor[f]:
                floor_cells[c] = 1.0
    return x0, z0, top.reshape(ni, nk), shelf.reshape(ni, nk), floor_cells.reshape(ni, nk)


# ---------------------------------------------------------------------------------------------
# Reading a scan: coincident vertices merged, unusable and repeated faces dropped, in few passes
# (meshplan.io.mesh.clean_mesh).


@njit(cache=True, nogil=True)
def _sort_by(keys, order, s, e, col):  # pragma: no cover - compiled
    """Sort ``order[s:e]`` by ``keys[:, col]`` (an insertion sort for a short run)."""
    m = e - s
    if m <= 16:
        for i in range(s + 1, e):
            x = order[i]
            v = keys[x, col]
            j = i - 1
            while j >= s and keys[order[j], col] > v:
                order[j + 1] = order[j]
                j -= 1
            order[j + 1] = x
        return
    vals = np.empty(m, np.int64)
    for i in range(m):
        vals[i] = keys[order[s + i], col]
    o = np.argsort(vals)
    run = order[s:e].copy()
    for i in range(m):
        order[s + i] = run[o[i]]


@njit(cache=True, nogil=True)
def lexsort_rows(keys, order):  # pragma: no cover - compiled
    """``order`` (indices sorting ``keys[:, 0]``, an (N, C) int64 array) made to sort the rows
    lexicographically, in place: column by column, each run of rows equal in the columns so far
    sorted by the next. The order of equal rows is left as it comes (callers merge them).
    (No recursion: numba's cache does not keep recursive kernels reliably.)"""
    n = order.shape[0]
    for col in range(1, keys.shape[1]):
        i = 0
        while i < n:
            j = i + 1
            while j < n:
                same = True
                for c in range(col):
                    if keys[order[j], c] != keys[order[i], c]:
                        same = False
                        break
                if not same:
                    break
                j += 1
            if j - i > 1:
                _sort_by(keys, order, i, j, col)
            i = j
    return order


@njit(cache=True, nogil=True)
def unique_sorted_rows(keys, order):  # pragma: no cover - compiled
    """The first of each run of equal rows of ``keys`` in ``order`` (lexicographically sorted
    indices) and the rank of the run of every row: ``keys[first]`` are the unique rows in order,
    ``inverse`` maps each row to its own."""
    n = order.shape[0]
    inverse = np.empty(n, np.int64)
    first = np.empty(n, np.int64)
    u = -1
    for i in range(n):
        r = order[i]
        new = i == 0
        if not new:
            p = order[i - 1]
            for c in range(keys.shape[1]):
                if keys[r, c] != keys[p, c]:
                    new = True
                    break
        if new:
            u += 1
            first[u] = r
        inverse[r] = u
    return first[: u + 1].copy(), inverse


#: Most kept faces on one lowest vertex that :func:`clean_faces` compares a face with before it
#: gives up its chains for a hash table: a scanned surface puts 2-3 faces on a vertex, a fan
#: (a disc, a cone) a few hundred; a hub of 100k faces would make the chains quadratic.
CLEAN_MAX_CHAIN = 1024


@njit(cache=True, nogil=True)
def clean_faces(vertices, inverse, faces, min_area, hashed, out, tri, cross):  # pragma: no cover - compiled
    """The faces of ``faces`` renumbered by ``inverse`` (onto the merged ``vertices``), their
    corners and cross products ``(t1 - t0) x (t2 - t0)`` (numpy's operations in numpy's order),
    and which to keep: not degenerate (a repeated vertex, or an area not above ``min_area``) and
    not a repeat of an earlier kept face (the same three vertices in any order). Also returns
    which vertices the kept faces use, the counts of degenerate and repeated faces, and whether
    it finished (see below).

    Repeats are found without sorting the faces. Unless ``hashed``, each kept face is chained to
    its lowest vertex (``head``, ``chain``), and a face is compared with the kept faces on its
    lowest vertex only (two or three on a scanned surface; a vertex's faces lie close in a scan's
    face order, so the chains stay in the cache, where a hash table of the faces misses it at
    every face: 0.1 s against 0.35 s at 3M faces). A chain longer than :data:`CLEAN_MAX_CHAIN`
    stops the pass (``finished`` False): the caller runs it again ``hashed``, with a hash table
    of the sorted vertex triples, linear in the faces whatever their fans.

    The renumbered faces, corners and cross products are written into ``out`` (F, 3),
    ``tri`` (F, 3, 3) and ``cross`` (F, 3), allocated by the caller with numpy: numpy asks the
    kernel for huge pages on large arrays where it may, numba never does, and 400 MB of small
    pages freed among huge ones made the later stages' large allocations stall (slicing a
    3M-face scan: 1.2 -> 2.1 s of CPU). The ``meshplan`` command keeps numpy's arrays in small
    pages too (:func:`meshplan._memory.small_pages`); a program that imports meshplan may not."""
    n = faces.shape[0]
    keep = np.zeros(n, np.bool_)
    used = np.zeros(vertices.shape[0], np.bool_)
    head = np.full(0 if hashed else vertices.shape[0], -1, np.int64)
    chain = np.empty(0 if hashed else n, np.int64)
    size = 1
    while hashed and size < 2 * n:
        size *= 2
    table = np.full(size if hashed else 0, -1, np.int64)
    mask = np.uint64(size - 1)
    degenerate = 0
    repeated = 0
    nv = inverse.shape[0]
    for f in range(n):
        i0, i1, i2 = faces[f, 0], faces[f, 1], faces[f, 2]
        if i0 < 0 or i0 >= nv or i1 < 0 or i1 >= nv or i2 < 0 or i2 >= nv:
            raise IndexError("face index out of range")  # (numpy would have said so; numba reads anything)
        a = inverse[i0]
        b = inverse[i1]
        c = inverse[i2]
        out[f, 0] = a
        out[f, 1] = b
        out[f, 2] = c
        for k in range(3):
            tri[f, 0, k] = vertices[a, k]
            tri[f, 1, k] = vertices[b, k]
            tri[f, 2, k] = vertices[c, k]
        a0 = tri[f, 1, 0] - tri[f, 0, 0]
        a1 = tri[f, 1, 1] - tri[f, 0, 1]
        a2 = tri[f, 1, 2] - tri[f, 0, 2]
        b0 = tri[f, 2, 0] - tri[f, 0, 0]
        b1 = tri[f, 2, 1] - tri[f, 0, 1]
        b2 = tri[f, 2, 2] - tri[f, 0, 2]
        x = a1 * b2 - a2 * b1
        y = a2 * b0 - a0 * b2
        z = a0 * b1 - a1 * b0
        cross[f, 0] = x
        cross[f, 1] = y
        cross[f, 2] = z
        area = 0.5 * np.sqrt(x * x + y * y + z * z)
        if a == b or b == c or a == c or not (area > min_area):
            degenerate += 1
            continue
        lo, mid, hi = a, b, c  # the sorted triple
        if lo > mid:
            lo, mid = mid, lo
        if mid > hi:
            mid, hi = hi, mid
        if lo > mid:
            lo, mid = mid, lo
        seen = False
        if hashed:
            h = np.uint64(lo) * np.uint64(0x9E3779B97F4A7C15)  # multiplicative hashing (odd constants)
            h ^= np.uint64(mid) * np.uint64(0xC2B2AE3D27D4EB4F)
            h ^= np.uint64(hi) * np.uint64(0x165667B19E3779F9)
            slot = np.int64((h ^ (h >> np.uint64(29))) & mask)
            while table[slot] >= 0:
                g = table[slot]
                p, q, r = out[g, 0], out[g, 1], out[g, 2]
                if (p == lo or q == lo or r == lo) and (p == mid or q == mid or r == mid) and (p == hi or q == hi or r == hi):
                    seen = True
                    break
                slot = np.int64((np.uint64(slot) + np.uint64(1)) & mask)
            if not seen:
                table[slot] = f
        else:
            g = head[lo]
            steps = 0
            while g >= 0:
                p, q, r = out[g, 0], out[g, 1], out[g, 2]
                if (p == mid or q == mid or r == mid) and (p == hi or q == hi or r == hi):
                    seen = True  # it holds lo too: the chain is lo's
                    break
                g = chain[g]
                steps += 1
                if steps > CLEAN_MAX_CHAIN:
                    return out, tri, cross, keep, used, degenerate, repeated, False
            if not seen:
                chain[f] = head[lo]
                head[lo] = f
        if seen:
            repeated += 1
            continue
        keep[f] = True
        used[a] = True
        used[b] = True
        used[c] = True
    return out, tri, cross, keep, used, degenerate, repeated, True


# ---------------------------------------------------------------------------------------------
# Making the normals face into the rooms (meshplan.orient.facing).


@njit(cache=True, nogil=True)
def component_labels(faces, n_vertices):  # pragma: no cover - compiled
    """``(F,)`` connected piece of every face (faces sharing a vertex are connected), numbered in
    the order of their lowest vertex, a vertex of no face counting as a piece of its own (as
    ``scipy.sparse.csgraph.connected_components`` numbers the vertex graph's).

    The union-find of :func:`face_components` keeps the lower root, so every vertex's parent is
    at most the vertex itself: one pass in vertex order then labels every vertex by its root's
    number (its parent's label is already final), where finding each face's root and numbering
    the roots with numpy took three more passes."""
    parent = np.arange(n_vertices)
    for f in range(faces.shape[0]):
        for e in range(2):
            a = _root(parent, faces[f, e])
            b = _root(parent, faces[f, e + 1])
            if a < b:
                parent[b] = a
            elif b < a:
                parent[a] = b
    label = np.empty(n_vertices, np.int64)
    count = 0
    for v in range(n_vertices):
        p = parent[v]
        if p == v:
            label[v] = count
            count += 1
        else:
            label[v] = label[p]
    out = np.empty(faces.shape[0], np.int64)
    for f in range(faces.shape[0]):
        out[f] = label[faces[f, 0]]
    return out


@njit(cache=True, nogil=True)
def slab_votes(normal_y, heights, areas, floors, ceilings, tolerance, cos_horizontal, vote, horiz):  # pragma: no cover - compiled
    """``(F,)`` winding votes of the floor and ceiling faces and ``(F,)`` which faces are
    horizontal (``|n_y| > cos_horizontal``): a horizontal face within ``tolerance`` of a floor
    of ``floors`` votes its area times the sign of its ``n_y``, of a ceiling (``ceilings``, NaN
    where a story has none) minus that; story by story, floor then ceiling, as the numpy
    masks added them. Written into ``vote`` and ``horiz``, allocated by the caller with numpy
    (huge pages: see :func:`clean_faces`)."""
    n = normal_y.shape[0]
    for f in range(n):
        ny = normal_y[f]
        vote[f] = 0.0
        horiz[f] = False
        if not (abs(ny) > cos_horizontal):
            continue
        horiz[f] = True
        s = np.sign(ny)
        v = 0.0
        for k in range(floors.shape[0]):
            if abs(heights[f] - floors[k]) < tolerance:
                v += areas[f] * s
            if abs(heights[f] - ceilings[k]) < tolerance:  # NaN: no ceiling, never near
                v -= areas[f] * s
        vote[f] = v
    return vote, horiz


@njit(cache=True, nogil=True)
def _probe_floor(grid, lo0, lo1, x, z, cell):  # pragma: no cover - compiled
    i = np.int64(np.floor(x / cell)) - lo0
    k = np.int64(np.floor(z / cell)) - lo1
    if i < 0 or i >= grid.shape[0] or k < 0 or k >= grid.shape[1]:
        return 0.0
    return 1.0 if grid[i, k] else 0.0


@njit(cache=True, nogil=True)
def floor_probe_votes(normals, centroids, areas, mine, grid, lo, probes, cell):  # pragma: no cover - compiled
    """``meshplan.orient.facing._wall_votes``' probes: for each face of ``mine`` (indices), its
    area times the floor found in front of its foot less the floor behind it, at each distance
    of ``probes`` (m) along its horizontal normal, on the floor ``grid`` of ``cell`` (m) whose
    cell ``(0, 0)`` is ``lo`` (in cells of x and z); numpy's operations in numpy's order."""
    out = np.empty(mine.shape[0], np.float64)
    for j in range(mine.shape[0]):
        f = mine[j]
        u0 = normals[f, 0]
        u1 = normals[f, 2]
        norm = max(np.sqrt(u0 * u0 + u1 * u1), 1e-12)
        u0 /= norm
        u1 /= norm
        x = centroids[f, 0]
        z = centroids[f, 2]
        v = 0.0
        for d in probes:
            v += _probe_floor(grid, lo[0], lo[1], x + d * u0, z + d * u1, cell) - _probe_floor(grid, lo[0], lo[1], x - d * u0, z - d * u1, cell)
        out[j] = areas[f] * v
    return out


# ---------------------------------------------------------------------------------------------
# Sorting


#: Bits of :func:`stable_argsort_f64`'s radix digits: 2048 buckets stay in the cache while a
#: pass scatters a million indices (16 bits: a third slower there, however fewer the passes).
_RADIX_BITS = 11


@njit(cache=True, nogil=True)
def stable_argsort_f64(x):  # pragma: no cover - compiled
    """``np.argsort(x, kind="stable")`` of a float64 array, by a least-significant-digit radix
    sort (six passes of :data:`_RADIX_BITS` bits, a pass skipped where every key shares its
    digit): linear, 2-5 times faster than numpy's timsort on the 0.1-1M unordered values of a
    mesh's weighted medians. Numpy's order exactly: -0.0 sorts as 0.0, and NaN (of either sign)
    after +inf, equal values (and all NaN) in the order they come."""
    n = x.shape[0]
    key = np.empty(n, np.uint64)
    sign = np.uint64(1) << np.uint64(63)
    for i in range(n):
        v = x[i]
        if v != v:
            b = np.uint64(0xFFFFFFFFFFFFFFFF)  # every NaN last
        else:
            b = np.float64(v + 0.0).view(np.uint64)  # + 0.0: -0.0 as 0.0
            b = ~b if b & sign else b | sign  # monotone: negatives reversed below positives
        key[i] = b
    order = np.arange(n)
    tmp = np.empty(n, np.int64)
    key2 = np.empty(n, np.uint64)
    buckets = 1 << _RADIX_BITS
    mask = np.uint64(buckets - 1)
    count = np.empty(buckets + 1, np.int64)
    for shift in range(0, 64, _RADIX_BITS):
        s = np.uint64(shift)
        count[:] = 0
        for i in range(n):
            count[np.int64((key[i] >> s) & mask) + 1] += 1
        if count[1:].max() == n:  # every key shares this digit: the pass changes nothing
            continue
        for d in range(buckets):
            count[d + 1] += count[d]
        for j in range(n):  # the keys travel with their indices: read in order, not gathered
            k = key[j]
            d = np.int64((k >> s) & mask)
            tmp[count[d]] = order[j]
            key2[count[d]] = k
            count[d] += 1
        order, tmp = tmp, order
        key, key2 = key2, key
    return order


# ---------------------------------------------------------------------------------------------
# Rooms (meshplan.plan.rooms)


@njit(cache=True, nogil=True)
def footprint_vertices(tri, faces, vertices, select, big_edge, x0, z0, cell, grid):  # pragma: no cover - compiled
    """``meshplan.plan.rooms.footprint_raster``'s small faces in one pass: each face of
    ``select`` (indices) whose longest edge is at most ``big_edge`` marks the cells of ``grid``
    (rows z from ``z0``, columns x from ``x0``, ``cell`` m) under its corners (``faces`` into
    ``vertices``; cells off the grid ignored). Returns the selected faces with a longer edge,
    in order, to be sampled over their surface."""
    big = np.empty(select.shape[0], np.int64)
    nbig = 0
    rows, cols = grid.shape
    for j in range(select.shape[0]):
        f = select[j]
        if _edge3(tri[f]) > big_edge:
            big[nbig] = f
            nbig += 1
            continue
        for a in range(3):
            v = faces[f, a]
            c = np.int64(np.floor((vertices[v, 0] - x0) / cell))
            r = np.int64(np.floor((vertices[v, 2] - z0) / cell))
            if r >= 0 and r < rows and c >= 0 and c < cols:
                grid[r, c] = True
    return big[:nbig].copy()


# ---------------------------------------------------------------------------------------------
# Gravity's candidate tests (meshplan.orient.gravity)


@njit(cache=True, nogil=True)
def third_points(tri):  # pragma: no cover - compiled
    """``(F, 3)``: ``t0 + (t1 - t0) / 3 + (t2 - t0) / 3`` of every face ``tri`` (F, 3, 3),
    written as numpy evaluates ``tri[:, 0] + third * (tri[:, 1] - tri[:, 0]) + third * (tri[:, 2]
    - tri[:, 0])`` (``third = 1 / 3``), to the bit, in one pass without temporaries."""
    n = tri.shape[0]
    out = np.empty((n, 3), np.float64)
    third = 1.0 / 3.0
    for f in range(n):
        for k in range(3):
            out[f, k] = (tri[f, 0, k] + third * (tri[f, 1, k] - tri[f, 0, k])) + third * (tri[f, 2, k] - tri[f, 0, k])
    return out


@njit(cache=True, nogil=True)
def span_bins(vertex_h, faces, select, bin_m):  # pragma: no cover - compiled
    """For each face of ``select`` (indices into ``faces``), the lowest and highest of its
    corners' heights ``vertex_h`` in bins of ``bin_m``: numpy's ``np.round(np.minimum(...) /
    bin_m)`` (round half to even; ``np.minimum``'s choice between equal or NaN values), to the
    bit, without gathering the corners."""
    n = select.shape[0]
    lo = np.empty(n, np.float64)
    hi = np.empty(n, np.float64)
    for j in range(n):
        f = select[j]
        a = vertex_h[faces[f, 0]]
        b = vertex_h[faces[f, 1]]
        c = vertex_h[faces[f, 2]]
        mn = a if (a < b or a != a) else b
        mn = mn if (mn < c or mn != mn) else c
        mx = a if (a > b or a != a) else b
        mx = mx if (mx > c or mx != mx) else c
        lo[j] = np.rint(mn / bin_m)
        hi[j] = np.rint(mx / bin_m)
    return lo, hi


# ---------------------------------------------------------------------------------------------
# The up direction's spherical k-means in a narrowing cone (meshplan.orient.gravity._refine_kmeans)


@njit(cache=True, nogil=True)
def fold_near_axis(normals, areas, g, cos_max):  # pragma: no cover - compiled
    """The rows of ``normals`` within the double cone ``|n . g| >= cos_max`` about ``g``, each
    turned onto ``g``'s hemisphere (times the sign of ``n . g``), and their ``areas``: two
    passes (count, then fill), so that the arrays are allocated at their final size."""
    g0, g1, g2 = g[0], g[1], g[2]
    count = 0
    for i in range(normals.shape[0]):
        if abs(normals[i, 0] * g0 + normals[i, 1] * g1 + normals[i, 2] * g2) >= cos_max:
            count += 1
    n = np.empty((count, 3), np.float64)
    a = np.empty(count, np.float64)
    j = 0
    for i in range(normals.shape[0]):
        d = normals[i, 0] * g0 + normals[i, 1] * g1 + normals[i, 2] * g2
        if abs(d) >= cos_max:
            s = np.sign(d)  # as numpy's (0 when the cone reaches the equator)
            n[j, 0] = normals[i, 0] * s
            n[j, 1] = normals[i, 1] * s
            n[j, 2] = normals[i, 2] * s
            a[j] = areas[i]
            j += 1
    return n, a


@njit(cache=True, nogil=True)
def cone_sum(n, a, m, g, cos_c, sel):  # pragma: no cover - compiled
    """One round of the cone's k-means over the first ``m`` rows of ``n``: which lie within
    ``n . g >= cos_c`` (written into ``sel``), whether that differs from what ``sel`` held, how
    many, and the area-weighted sum of their directions (rows in order)."""
    g0, g1, g2 = g[0], g[1], g[2]
    # scalar sums and no branch on the test: a row outside adds its area times 0.0, which
    # changes no sum, while the test's outcome is as good as random in the narrow cones (a
    # branch, or a select the compiler turns into one, made the round 3-4 times slower)
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    count = 0
    changed = 0
    for i in range(m):
        inside = n[i, 0] * g0 + n[i, 1] * g1 + n[i, 2] * g2 >= cos_c
        changed |= inside ^ sel[i]
        sel[i] = inside
        w = a[i] * np.float64(inside)
        count += np.int64(inside)
        s0 += w * n[i, 0]
        s1 += w * n[i, 1]
        s2 += w * n[i, 2]
    return np.array([s0, s1, s2]), count, changed != 0


@njit(cache=True, nogil=True)
def keep_in_cone(n, a, m, g, cos_c):  # pragma: no cover - compiled
    """Move the rows among the first ``m`` of ``n`` (and ``a``) with ``n . g >= cos_c`` to the
    front, in order; returns how many."""
    g0, g1, g2 = g[0], g[1], g[2]
    j = 0
    for i in range(m):
        if n[i, 0] * g0 + n[i, 1] * g1 + n[i, 2] * g2 >= cos_c:
            n[j, 0], n[j, 1], n[j, 2] = n[i, 0], n[i, 1], n[i, 2]
            a[j] = a[i]
            j += 1
    return j

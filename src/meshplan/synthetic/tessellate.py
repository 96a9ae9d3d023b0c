"""Planar pieces to triangles, the way a HoloLens spatial mesh looks.

Every scanned surface is a :class:`Piece`: a planar rectangle or trapezoid spanned by two unit
axes. A piece is covered by a grid of cells of about ``cell_m``; interior vertices are jittered in
the plane by up to 30 % of the cell and every cell is split along a random diagonal. Vertices on
the piece's edges stay on them (they only slide along the edge).

Openings are cut in two ways. *Hard* cuts (doors, windows, stair openings, the outline of an
L-shaped floor) put grid lines on their edges, so the cut is exact and straight. *Soft* cuts
(holes, missing wall strips) drop the triangles whose centroid falls inside, which leaves the
ragged edge of a real scan.

Why one long module: the HoloLens-like tessellation (graded grids, jitter, the diagonal choice,
decimation) is one algorithm whose steps share the grid arrays.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..geometry import FloatArray, IntArray

#: Surface kind of every face of a synthetic scan (``SyntheticScan.face_kinds`` indexes this).
SURFACE_KINDS = ("floor", "ceiling", "wall", "bevel", "opening", "slab_edge", "stair", "furniture", "door_leaf")

#: Largest in-plane jitter of an interior vertex, as a fraction of the local grid spacing.
JITTER_FRACTION = 0.3

#: Growth of the cell size from one row or column to the next on a graded (decimated) grid: the
#: cells double within two steps, about what quadric decimation leaves beside a crease.
GRADING_GROWTH = 1.6

_UNIT = np.array([0.0, 1.0])


@dataclass(eq=False)
class Piece:
    """One planar surface to tessellate.

    The piece covers ``origin + u * eu + v * ev`` for ``v`` in ``v_range`` and ``u`` between the
    left and right edges, which run linearly from ``u_range`` (at the low ``v``) to
    ``u_range_top`` (at the high ``v``; the same as ``u_range`` for a rectangle).

    Attributes
    ----------
    normal
        The side the surface is seen from (into the room); the triangles are wound to face it.
    kind
        One of :data:`SURFACE_KINDS`.
    group
        Index of the object (room shell, furniture item) the piece belongs to.
    wall
        Index of the truth wall for wall faces, -1 otherwise.
    cuts
        Rectangles ``(u0, u1, v0, v1)`` removed exactly (grid lines on their edges); rectangles only.
    keep
        ``(k, 2)`` rectilinear polygon in ``(u, v)``: cells outside it are removed exactly.
    soft_cuts
        Rectangles removed by triangle centroid (ragged edges).
    ellipses
        ``(cu, cv, a, b, angle_rad)`` elliptical holes removed by triangle centroid.
    triangle
        ``(3, 3)`` corners of a single triangle emitted instead of a grid.
    cell_m
        Grid cell size (on a graded grid, beside the piece's edges and hard cuts).
    max_cell_m
        When set, the grid is graded like a decimated mesh: cells of ``cell_m`` along the edges
        and hard cuts, growing by :data:`GRADING_GROWTH` per row up to ``max_cell_m`` in between.
    jitter
        Largest in-plane jitter of interior vertices, as a fraction of the local grid spacing.
    flip
        Reverse the winding of every face (outward or mixed scans).
    """

    origin: FloatArray
    eu: FloatArray
    ev: FloatArray
    normal: FloatArray
    u_range: tuple[float, float]
    v_range: tuple[float, float]
    kind: str
    group: int
    wall: int = -1
    u_range_top: tuple[float, float] | None = None
    cuts: list = field(default_factory=list)
    keep: FloatArray | None = None
    soft_cuts: list = field(default_factory=list)
    ellipses: list = field(default_factory=list)
    triangle: FloatArray | None = None
    cell_m: float = 0.05
    max_cell_m: float | None = None
    jitter: float = JITTER_FRACTION
    flip: bool = False

    @property
    def kind_index(self) -> int:
        return SURFACE_KINDS.index(self.kind)

    def widths(self) -> tuple[float, float]:
        """Widths of the piece at its low and high ``v``."""
        top = self.u_range_top or self.u_range
        return self.u_range[1] - self.u_range[0], top[1] - top[0]

    def area_m2(self) -> float:
        """Area of the piece before any cut."""
        if self.triangle is not None:
            t = self.triangle
            return 0.5 * float(np.linalg.norm(np.cross(t[1] - t[0], t[2] - t[0])))
        wb, wt = self.widths()
        return 0.5 * (wb + wt) * (self.v_range[1] - self.v_range[0])

    def kept_fraction(self) -> float:
        """Rough fraction of the piece left after its cuts (for face-count prediction)."""
        area = self.area_m2()
        if area <= 0 or self.triangle is not None:
            return 1.0
        removed = sum((c[1] - c[0]) * (c[3] - c[2]) for c in self._clipped(self.cuts + self.soft_cuts))
        removed += sum(np.pi * e[2] * e[3] for e in self.ellipses)
        kept = area - removed
        if self.keep is not None:
            kept -= area - abs(_shoelace(self.keep))
        return float(np.clip(kept / area, 0.0, 1.0))

    def _clipped(self, rects: list) -> list:
        (u0, u1), (v0, v1) = self.u_range, self.v_range
        out = []
        for a0, a1, b0, b1 in rects:
            a0, a1, b0, b1 = max(a0, u0), min(a1, u1), max(b0, v0), min(b1, v1)
            if a1 > a0 and b1 > b0:
                out.append((a0, a1, b0, b1))
        return out

    def breaks(self) -> tuple[FloatArray, FloatArray]:
        """Grid lines forced by hard cuts, as fractions of the width and height (0 and 1 included)."""
        (u0, u1), (v0, v1) = self.u_range, self.v_range
        if not self.cuts and self.keep is None:
            return _UNIT, _UNIT
        us, vs = [u0, u1], [v0, v1]
        if self.u_range_top is None:
            for a0, a1, b0, b1 in self._clipped(self.cuts):
                us += [a0, a1]
                vs += [b0, b1]
            if self.keep is not None:
                us += list(self.keep[:, 0])
                vs += list(self.keep[:, 1])
        return _fractions(us, u0, u1), _fractions(vs, v0, v1)


def _fractions(values: list, lo: float, hi: float) -> FloatArray:
    f = (np.clip(np.asarray(values, dtype=np.float64), lo, hi) - lo) / (hi - lo)
    f = np.unique(np.round(f, 12))
    # merge grid lines closer than 1 mm: they would only make slivers
    keep = np.r_[True, np.diff(f) * (hi - lo) > 1e-3]
    f = f[keep]
    f[-1] = 1.0
    return f


def _shoelace(poly: FloatArray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


@dataclass(frozen=True)
class Box:
    """A rectangular solid whose listed faces are scanned.

    Attributes
    ----------
    center
        ``(3,)`` centre, truth frame.
    half
        ``(3,)`` half extents along the box axes.
    rotation
        ``(3, 3)`` rotation whose columns are the box axes in the truth frame.
    faces
        The scanned faces as signed axes, e.g. ``"+x -x +y +z"``; bottoms are left out because no
        one sees them.
    """

    center: FloatArray
    half: FloatArray
    rotation: FloatArray
    faces: str = "+x -x +y +z -z"


def box_pieces(box: Box, kind: str, group: int) -> list[Piece]:
    """One rectangular piece per scanned face of ``box``, normals pointing out of the box."""
    out = []
    r = np.asarray(box.rotation, dtype=np.float64)
    h = np.asarray(box.half, dtype=np.float64)
    c = np.asarray(box.center, dtype=np.float64)
    for token in box.faces.split():
        sign = 1.0 if token[0] == "+" else -1.0
        k = "xyz".index(token[1])
        i, j = (k + 1) % 3, (k + 2) % 3  # cyclic, so that e_i x e_j = e_k
        origin = c + sign * h[k] * r[:, k] - h[i] * r[:, i] - h[j] * r[:, j]
        out.append(
            Piece(
                origin=origin,
                eu=r[:, i].copy(),
                ev=r[:, j].copy(),
                normal=sign * r[:, k],
                u_range=(0.0, 2 * h[i]),
                v_range=(0.0, 2 * h[j]),
                kind=kind,
                group=group,
            )
        )
    return out


# --------------------------------------------------------------------------------------------
# Grids


def _nodes(length: float, breaks: FloatArray, cell_m: float) -> tuple[FloatArray, np.ndarray]:
    """Grid node fractions along one axis: every interval between breaks split into equal cells
    of at most ``cell_m``. Returns the nodes and which of them are breaks (not to be jittered
    across)."""
    seg = np.diff(breaks)
    n = np.maximum(1, np.ceil(seg * length / cell_m - 1e-9)).astype(np.int64)
    starts = np.repeat(breaks[:-1], n)
    step = np.repeat(seg / n, n)
    first = np.repeat(np.cumsum(n) - n, n)
    nodes = np.r_[starts + (np.arange(n.sum()) - first) * step, 1.0]
    fixed = np.zeros(len(nodes), dtype=bool)
    fixed[np.r_[0, np.cumsum(n)]] = True
    return nodes, fixed


def _graded_nodes(length: float, breaks: FloatArray, cell_m: float, max_cell_m: float) -> tuple[FloatArray, np.ndarray]:
    """Like :func:`_nodes`, but every interval between breaks starts and ends with cells of about
    ``cell_m`` that grow by :data:`GRADING_GROWTH` towards its middle, up to ``max_cell_m``."""
    nodes, fixed = [0.0], [True]
    for f0, f1 in zip(breaks[:-1], breaks[1:]):
        seg = (f1 - f0) * length
        steps: list[float] = []
        total = 0.0
        while 2.0 * total < seg - 1e-12:
            steps.append(min(cell_m * GRADING_GROWTH ** len(steps), max_cell_m))
            total += steps[-1]
        if seg <= cell_m + 1e-12 or not steps:
            seq = np.array([1.0])
        else:
            seq = np.array(steps + steps[::-1])
            if len(seq) > 2 and seq[len(steps) - 1] + seq[len(steps)] <= max_cell_m:
                seq = np.r_[seq[: len(steps) - 1], seq[len(steps) - 1] + seq[len(steps)], seq[len(steps) + 1 :]]
            seq = seq / seq.sum()
        pos = f0 + (f1 - f0) * np.cumsum(seq)
        pos[-1] = f1
        nodes += list(pos)
        fixed += [False] * (len(pos) - 1) + [True]
    return np.array(nodes), np.array(fixed, dtype=bool)


def face_count_model(pieces: list[Piece], cells_m: FloatArray):
    """A fast predictor of the number of faces: ``model(scale)`` is the expected face count when
    every piece's cell is ``cells_m * scale`` (cuts counted by their area)."""
    ids_u_parts: list[IntArray] = []
    len_u_parts: list[FloatArray] = []
    ids_v_parts: list[IntArray] = []
    len_v_parts: list[FloatArray] = []
    singles = 0
    kept = np.zeros(len(pieces))
    for k, p in enumerate(pieces):
        if p.triangle is not None:
            singles += 1
            continue
        bu, bv = p.breaks()
        wb, wt = p.widths()
        len_u_parts.append(np.diff(bu) * max(wb, wt))
        len_v_parts.append(np.diff(bv) * (p.v_range[1] - p.v_range[0]))
        ids_u_parts.append(np.full(len(bu) - 1, k))
        ids_v_parts.append(np.full(len(bv) - 1, k))
        kept[k] = p.kept_fraction()
    if not len_u_parts:
        return lambda scale: float(singles)
    len_u, len_v = np.concatenate(len_u_parts), np.concatenate(len_v_parts)
    ids_u, ids_v = np.concatenate(ids_u_parts), np.concatenate(ids_v_parts)
    cells_m = np.asarray(cells_m, dtype=np.float64)

    def model(scale: float) -> float:
        nu = np.bincount(ids_u, np.maximum(1, np.ceil(len_u / (cells_m[ids_u] * scale) - 1e-9)), len(pieces))
        nv = np.bincount(ids_v, np.maximum(1, np.ceil(len_v / (cells_m[ids_v] * scale) - 1e-9)), len(pieces))
        return float(singles + 2.0 * np.sum(nu * nv * kept))

    return model


def _inside_polygon(x: FloatArray, y: FloatArray, poly: FloatArray) -> np.ndarray:
    """Even-odd point-in-polygon test, vectorized over the points."""
    inside = np.zeros(x.shape, dtype=bool)
    px, py = poly[:, 0], poly[:, 1]
    qx, qy = np.roll(px, -1), np.roll(py, -1)
    for ax, ay, bx, by in zip(px, py, qx, qy):
        if ay == by:
            continue
        crosses = (ay > y) != (by > y)
        xi = ax + (y - ay) * (bx - ax) / (by - ay)
        inside ^= crosses & (x < xi)
    return inside


def _in_rects(u: FloatArray, v: FloatArray, rects: list) -> np.ndarray:
    out = np.zeros(u.shape, dtype=bool)
    for a0, a1, b0, b1 in rects:
        out |= (u > a0) & (u < a1) & (v > b0) & (v < b1)
    return out


def _in_ellipses(u: FloatArray, v: FloatArray, ellipses: list) -> np.ndarray:
    out = np.zeros(u.shape, dtype=bool)
    for cu, cv, a, b, ang in ellipses:
        du, dv = u - cu, v - cv
        c, s = np.cos(ang), np.sin(ang)
        x, y = c * du + s * dv, -s * du + c * dv
        out |= (x / a) ** 2 + (y / b) ** 2 < 1.0
    return out


def _node_arrays(p: Piece) -> tuple[FloatArray, np.ndarray, FloatArray, np.ndarray]:
    """Grid nodes (fractions) and break flags of a piece along u and v."""
    wb, wt = p.widths()
    width, height = max(wb, wt), p.v_range[1] - p.v_range[0]
    if p.max_cell_m is not None:  # graded, like a decimated mesh
        bu, bv = p.breaks()
        su, fu = _graded_nodes(width, bu, p.cell_m, p.max_cell_m)
        tv, fv = _graded_nodes(height, bv, p.cell_m, p.max_cell_m)
        return su, fu, tv, fv
    if not p.cuts and p.keep is None:  # the common case, without the general machinery
        out = []
        for length in (width, height):
            n = max(1, int(np.ceil(length / p.cell_m - 1e-9)))
            fixed = np.zeros(n + 1, dtype=bool)
            fixed[[0, n]] = True
            out += [np.arange(n + 1) / n, fixed]
        return out[0], out[1], out[2], out[3]
    bu, bv = p.breaks()
    su, fu = _nodes(width, bu, p.cell_m)
    tv, fv = _nodes(height, bv, p.cell_m)
    return su, fu, tv, fv


def _spacing(nodes: FloatArray, fixed: np.ndarray) -> FloatArray:
    """Jitter scale of every node: the smaller neighbouring interval, 0 on break lines."""
    d = np.diff(nodes)
    return np.minimum(np.concatenate([d[:1], d]), np.concatenate([d, d[-1:]])) * ~fixed


def tessellate(pieces: list[Piece], rng: np.random.Generator) -> tuple[FloatArray, IntArray, IntArray, IntArray]:
    """Triangulate every piece, all grids at once.

    Returns
    -------
    vertices, faces
        The joined mesh (pieces share no vertices, like the surface chunks of a HoloLens export).
    face_piece, vertex_piece
        Index of the piece of every face and every vertex.
    """
    grid = [k for k, p in enumerate(pieces) if p.triangle is None]
    tris = [k for k, p in enumerate(pieces) if p.triangle is not None]
    P = len(grid)
    su_l, fu_l, tv_l, fv_l = [], [], [], []
    for k in grid:
        su, fu, tv, fv = _node_arrays(pieces[k])
        su_l.append(su)
        fu_l.append(fu)
        tv_l.append(tv)
        fv_l.append(fv)
    nu = np.array([len(a) - 1 for a in su_l], dtype=np.int64)
    nv = np.array([len(a) - 1 for a in tv_l], dtype=np.int64)
    off_u = np.r_[0, np.cumsum(nu + 1)[:-1]].astype(np.int64)
    off_v = np.r_[0, np.cumsum(nv + 1)[:-1]].astype(np.int64)
    U = np.concatenate(su_l) if P else np.zeros(0)
    V = np.concatenate(tv_l) if P else np.zeros(0)
    SPU = np.concatenate([_spacing(a, f) for a, f in zip(su_l, fu_l)]) if P else np.zeros(0)
    SPV = np.concatenate([_spacing(a, f) for a, f in zip(tv_l, fv_l)]) if P else np.zeros(0)

    # per-piece geometry
    g = [pieces[k] for k in grid]
    ul0 = np.array([p.u_range[0] for p in g])
    ul1 = np.array([(p.u_range_top or p.u_range)[0] for p in g])
    wb = np.array([p.widths()[0] for p in g])
    wt = np.array([p.widths()[1] for p in g])
    v0 = np.array([p.v_range[0] for p in g])
    hh = np.array([p.v_range[1] - p.v_range[0] for p in g])

    # vertices: piece, column i, row j
    nvert = (nu + 1) * (nv + 1)
    vstart = np.r_[0, np.cumsum(nvert)[:-1]].astype(np.int64)
    vp = np.repeat(np.arange(P), nvert)
    local = np.arange(int(nvert.sum())) - vstart[vp]
    vi, vj = local % (nu + 1)[vp], local // (nu + 1)[vp]
    del local
    iu, iv = off_u[vp] + vi, off_v[vp] + vj
    s0, t0 = U[iu], V[iv]
    n_all = len(vp)
    rad = JITTER_FRACTION * np.sqrt(rng.random(n_all))
    jitter = np.array([p.jitter for p in pieces if p.triangle is None], dtype=np.float64)
    if np.any(jitter != JITTER_FRACTION):
        rad = rad * (jitter / JITTER_FRACTION)[vp]
    ang = 2.0 * np.pi * rng.random(n_all)
    ju = rad * np.cos(ang) * SPU[iu]
    jv = rad * np.sin(ang) * SPV[iv]
    del rad, ang, iu, iv, vi, vj

    # cells: piece, column, row; kept unless a hard cut removes them
    ncell = nu * nv
    cp = np.repeat(np.arange(P), ncell)
    cstart = np.r_[0, np.cumsum(ncell)[:-1]].astype(np.int64)
    local = np.arange(int(ncell.sum())) - cstart[cp]
    ci, cj = local % nu[cp], local // nu[cp]
    del local
    keep = np.ones(len(cp), dtype=bool)
    for q, p in enumerate(g):
        if not p.cuts and p.keep is None:
            continue
        sl = slice(cstart[q], cstart[q] + ncell[q])
        su, tv = su_l[q], tv_l[q]
        sc = 0.5 * (su[ci[sl]] + su[ci[sl] + 1])
        tc = 0.5 * (tv[cj[sl]] + tv[cj[sl] + 1])
        uc = ul0[q] + tc * (ul1[q] - ul0[q]) + sc * (wb[q] + tc * (wt[q] - wb[q]))
        vc = v0[q] + tc * hh[q]
        kept = np.ones(len(uc), dtype=bool)
        if p.cuts:
            kept &= ~_in_rects(uc, vc, p._clipped(p.cuts))
        if p.keep is not None:
            kept &= _inside_polygon(uc, vc, p.keep)
        keep[sl] = kept
    diag = rng.random(len(cp)) < 0.5
    a = vstart[cp] + cj * (nu + 1)[cp] + ci
    del ci, cj
    a, cp, diag = a[keep], cp[keep], diag[keep]
    step = (nu + 1)[cp]
    corners = np.stack([a, a + 1, a + 1 + step, a + step], axis=1)  # v00 v10 v11 v01
    del a, step, keep

    def metric() -> tuple[FloatArray, FloatArray]:
        s, t = s0 + ju, t0 + jv
        return ul0[vp] + t * (ul1 - ul0)[vp] + s * (wb[vp] + t * (wt - wb)[vp]), v0[vp] + t * hh[vp]

    for _ in range(4):
        u, v = metric()
        cu, cv = u[corners], v[corners]

        def area2(i0: int, i1: int, i2: int, cu: FloatArray = cu, cv: FloatArray = cv) -> FloatArray:
            return (cu[:, i1] - cu[:, i0]) * (cv[:, i2] - cv[:, i0]) - (cu[:, i2] - cu[:, i0]) * (cv[:, i1] - cv[:, i0])

        eps = 0.02 * np.abs((cu[:, 2] - cu[:, 0]) * (cv[:, 2] - cv[:, 0])) + 1e-12
        ok_a = np.minimum(area2(0, 1, 2), area2(0, 2, 3)) > eps  # split along v00-v11
        ok_b = np.minimum(area2(0, 1, 3), area2(1, 2, 3)) > eps  # split along v10-v01
        del cu, cv
        diag = np.where(diag, ok_b | ~ok_a, ok_b & ~ok_a)  # keep the random split when valid
        bad = ~ok_a & ~ok_b
        if not bad.any():
            break
        # rare: too much jitter around a cell; undo it there and try again
        idx = np.unique(corners[bad])
        ju[idx] = 0.0
        jv[idx] = 0.0
    faces = np.empty((2 * len(corners), 3), dtype=np.int64)
    faces[0::2] = np.where(diag[:, None], corners[:, [0, 1, 3]], corners[:, [0, 1, 2]])
    faces[1::2] = np.where(diag[:, None], corners[:, [1, 2, 3]], corners[:, [0, 2, 3]])
    fp = np.repeat(cp, 2)
    del corners, diag, cp

    # soft cuts, judged at the jittered triangle centroids
    soft = [q for q, p in enumerate(g) if p.soft_cuts or p.ellipses]
    if soft:
        drop = np.zeros(len(faces), dtype=bool)
        bounds = np.searchsorted(fp, np.arange(P + 1))
        for q in soft:
            sl = slice(bounds[q], bounds[q + 1])
            f = faces[sl]
            gu, gv = u[f].mean(axis=1), v[f].mean(axis=1)
            drop[sl] = _in_rects(gu, gv, g[q].soft_cuts) | _in_ellipses(gu, gv, g[q].ellipses)
        faces, fp = faces[~drop], fp[~drop]

    # winding: counter-clockwise in (u, v) faces eu x ev; turn to the wanted side, then flip
    eu = np.array([p.eu for p in g]).reshape(-1, 3)
    ev = np.array([p.ev for p in g]).reshape(-1, 3)
    nrm = np.array([p.normal for p in g]).reshape(-1, 3)
    reverse = (np.einsum("ij,ij->i", np.cross(eu, ev), nrm) < 0) ^ np.array([p.flip for p in g], dtype=bool)
    rf = reverse[fp]
    faces[rf] = faces[rf][:, ::-1]

    used = np.zeros(n_all, dtype=bool)
    used[faces] = True
    remap = np.cumsum(used) - 1
    faces = remap[faces]
    u, v, vp = u[used], v[used], vp[used]
    origin = np.array([p.origin for p in g]).reshape(-1, 3)
    verts = origin[vp] + u[:, None] * eu[vp] + v[:, None] * ev[vp]
    del u, v
    grid_ids = np.array(grid, dtype=np.int64)
    face_piece, vert_piece = grid_ids[fp], grid_ids[vp]

    if tris:  # single triangles (bevel corners)
        t = np.array([pieces[k].triangle for k in tris], dtype=np.float64)
        nt = np.array([pieces[k].normal for k in tris])
        f = np.arange(3 * len(tris)).reshape(-1, 3) + len(verts)
        rev = (np.einsum("ij,ij->i", np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), nt) < 0) ^ np.array([pieces[k].flip for k in tris])
        f[rev] = f[rev][:, ::-1]
        verts = np.concatenate([verts, t.reshape(-1, 3)])
        faces = np.concatenate([faces, f])
        face_piece = np.r_[face_piece, tris]
        vert_piece = np.r_[vert_piece, np.repeat(tris, 3)]
    return verts, faces, face_piece, vert_piece

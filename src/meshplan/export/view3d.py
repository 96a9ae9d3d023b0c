"""The report's 3D view: which faces it shows (:func:`view_meshes`) and the data its script
draws them from (:func:`page_data`, the page's ``meshplan-data`` JSON).

Large scans are simplified by vertex clustering on a voxel grid (:func:`simplify_faces`,
:func:`cluster_vertices`: every vertex moved to the mean of its cell, the faces that collapse
dropped), the finest grid whose faces fit the budget (:data:`MAX_FACES`): the page stays small
and responsive, and the surface shown has no holes the scan had not (a random subsample of
whole faces, before, left gaps everywhere; a point cloud's splats, which share no vertex, are
still shown so: :func:`subsample_faces`). The same result gives the same page.
Annotations are given in the plan frame (to draw) and in the scan file's coordinates (to export
unchanged, as the page's annotation editor does).

The meshes are packed to keep the page small (:func:`_layer_data`): coordinates as uint16 across
each layer's box (:func:`quantize_positions`, under 0.1 mm off on a 10 m story) and as
differences from vertex to vertex (:func:`pack_positions`), faces as small back-references to
the vertices in first-use order (:func:`first_use_order`, :func:`encode_faces`), each block
deflated (zlib) and base64. The page's script inflates them with the browser's own
``DecompressionStream`` (nothing to load) and decodes them as :func:`unpack_positions`,
:func:`decode_positions` and :func:`decode_faces` do.
"""

from __future__ import annotations

import base64
import math
import zlib
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .._version import __version__
from ..geometry import ANNOTATION_KINDS, ANNOTATION_PROBE_M, Mesh, max3, min3, transform_directions, transform_points
from .glb import KIND_RGBA, MESH_RGBA, WALL_RGBA, submesh

if TYPE_CHECKING:  # pragma: no cover
    from ..result import Result

__all__ = [
    "CELL_SEARCH_SAMPLE", "CELL_SEARCH_STEPS", "CELL_SEARCH_TOLERANCE", "FLAP_FACES", "KIND_PREFIX", "MAX_FACES",
    "POSITION_LEVELS", "PROBE_M", "SUBSAMPLE_SEED", "ViewMesh", "ViewMeshes", "ZLIB_LEVEL", "cluster_vertices",
    "decode_faces", "decode_positions", "encode_faces", "first_use_order", "pack_positions", "page_data",
    "quantize_positions", "simplify_faces", "subsample_faces", "unpack_positions", "view_meshes",
]

#: Most faces the 3D view shows; past this the stories are simplified (:func:`simplify_faces`).
#: Measured in Chromium: plotly builds a 120k-face scene in about 1 s and keeps rotating it
#: smoothly. In headless Chromium's software renderer on this project's 2 busy cores, the
#: benchmark's 300k-face apartment simplified to 120k, 160k and 200k faces took 2.0-2.6, 2.8
#: and 1.8-3.5 s to build, and a turn of the camera 1.1-1.7, 1.9 and 1.8-2.8 s to draw (the
#: former subsample of 120k whole faces: 2.2-3.5 s and 1.3-1.7 s): 120k draws as fast as the
#: subsample did. The page takes 3.1, 3.3 and 3.5 MB (plotly's 3D bundle is 1.75 MB of it, the
#: meshes 0.6 MB at 120k faces: simplified, they share their vertices; the subsample's took
#: 0.94 MB), the 3M-face apartment's 3.2, 3.5 and 3.7 MB.
MAX_FACES = 120_000

#: Steps of the uint16 grid a layer's vertex coordinates are rounded to, per axis, across the
#: layer's bounding box (65535 steps, 65536 levels: the most a uint16 holds). See
#: :func:`quantize_positions` for the error.
POSITION_LEVELS = 65535

#: zlib (deflate) level of the page's mesh blocks. Measured on the benchmark's 300k-face
#: apartment (120k faces shown, 129k vertices): levels 1, 4 and 6 take 22, 28 and 91 ms of
#: CPU and leave 1.00, 0.94 and 0.92 MB (base64); 9 takes 0.7 s for 0.92 MB. Level 4 is
#: nearly level 6's size at a third of its time (the report is made during the run).
ZLIB_LEVEL = 4

#: The cell search of :func:`simplify_faces` stops once the faces left are within this
#: fraction under the budget ...
CELL_SEARCH_TOLERANCE = 0.03

#: ... or after this many cells tried (two to four are, on the benchmark's apartments).
CELL_SEARCH_STEPS = 12

#: Faces the cell search of :func:`simplify_faces` counts among, at most: past this, every
#: k-th face of the stories (the 3M-face apartment's 2.6 million faces take 50 ms a cell, every
#: 9th a tenth of it); the faces left are then counted once in full.
CELL_SEARCH_SAMPLE = 300_000

#: Seed of the subsample of a point cloud's splats (fixed: the same result gives the same page).
SUBSAMPLE_SEED = 0

#: Most faces of a flap that :func:`_without_flaps` takes off the surface (faces kept from
#: pairs of opposite faces, joined by their edges): folds within a cell leave one to three.
FLAP_FACES = 4

#: Length of the probe drawn from each annotation along its direction, metres.
PROBE_M = ANNOTATION_PROBE_M

#: Label prefix suggested for a new annotation of each kind.
KIND_PREFIX = {"sensor": "S", "thermostat": "T", "window": "W", "door": "D", "other": "O"}

_WALL_VIEW_RGB = WALL_RGBA[:3]


@dataclass(frozen=True, eq=False)
class ViewMesh:
    """One mesh layer of the 3D view.

    Attributes
    ----------
    name
        Legend entry.
    role
        ``"scan"`` (a story without its ceiling) or ``"walls"`` (its flat walls).
    story
        Story index.
    mesh
        The faces shown (plan frame): the layer's faces of the scan, or, for a large scan's
        story, those faces simplified (:func:`cluster_vertices`).
    faces_total
        Faces of the layer before any simplification.
    """

    name: str
    role: str
    story: int
    mesh: Mesh
    faces_total: int

    @property
    def faces_shown(self) -> int:
        return self.mesh.n_faces


@dataclass(frozen=True, eq=False)
class ViewMeshes:
    """The layers of the 3D view and how much of the scan they show: ``cell_m`` is the edge of
    the grid the stories were simplified on, metres (``None``: shown exactly)."""

    layers: tuple[ViewMesh, ...]
    max_faces: int
    cell_m: float | None = None

    @property
    def faces_shown(self) -> int:
        return sum(layer.faces_shown for layer in self.layers)

    @property
    def faces_total(self) -> int:
        return sum(layer.faces_total for layer in self.layers)

    @property
    def fraction(self) -> float:
        """Faces shown over the scan's faces (1 when shown exactly)."""
        scan = [layer for layer in self.layers if layer.role == "scan"]
        total = sum(layer.faces_total for layer in scan)
        return sum(layer.faces_shown for layer in scan) / total if total else 1.0

    @property
    def decimated(self) -> bool:
        """Whether the stories are shown simplified (:func:`simplify_faces`) or, a point cloud's
        splats, subsampled (:func:`subsample_faces`)."""
        return self.cell_m is not None or self.faces_shown < self.faces_total


class _Grid:
    """A voxel grid over a mesh's box, from its lowest corner: the cell of points as one
    integer, for any cell size."""

    def __init__(self, vertices: np.ndarray) -> None:
        # axis by axis (x, y and z each contiguous): numpy loops over an (n, 3) array's rows
        # of 3 several times slower
        vt = np.ascontiguousarray(np.asarray(vertices, dtype=np.float64).reshape(-1, 3).T)
        self.origin = vt.min(axis=1) if vt.shape[1] else np.zeros(3)
        self.size = vt.max(axis=1) - self.origin if vt.shape[1] else np.zeros(3)
        #: ``(3, n)`` coordinates of the vertices from the box's corner
        self.rel = vt - self.origin[:, None]

    def keys(self, rel: np.ndarray, cell: float) -> tuple[np.ndarray, int]:
        """``(n,)`` int64, the cell of each point (``(3, n)`` coordinates from the box's
        corner, as :attr:`rel`; cells of edge ``cell``, numbered x, then y, then z), and the
        number of cells in the box."""
        scale = 1.0 / cell
        dims = (self.size * scale).astype(np.int64) + 1  # the same product as ijk's: ijk < dims
        n = int(np.prod(dims))
        # int32 when the numbers fit: half the memory to gather at every face's corners
        ijk = (rel * scale).astype(np.int32 if n < 2**31 else np.int64)  # >= 0: truncation is floor
        d1, d2 = dims[1:].astype(ijk.dtype)
        return (ijk[0] * d1 + ijk[1]) * d2 + ijk[2], n


def _three_cells(c: np.ndarray) -> np.ndarray:
    """Which rows of ``c`` (``(m, 3)`` cells of the corners of faces) name three cells."""
    return (c[:, 0] != c[:, 1]) & (c[:, 1] != c[:, 2]) & (c[:, 0] != c[:, 2])


def _cluster(
    vertices: np.ndarray, corners: Sequence[np.ndarray], areas: Sequence[np.ndarray], keys: np.ndarray, n_keys: int, kept: Sequence[np.ndarray]
) -> list[Mesh]:
    """:func:`cluster_vertices` of groups of faces, ``corners`` (``(m, 3)`` indices into
    ``vertices``, with their ``areas``), the vertices' cells being ``keys`` (of ``n_keys``)
    and ``kept`` the faces with their corners in three cells (:func:`_three_cells`). The
    cells' representatives are those of all the groups' vertices, so that groups that meet
    (two stories) still meet."""
    nv = len(vertices)
    w = np.zeros(nv)
    for c, a in zip(corners, areas):
        for k in range(3):  # three times the area around each vertex
            w += np.bincount(c[:, k], weights=a, minlength=nv)
    shown = [c[t] for c, t in zip(corners, kept)]
    used = w > 0
    for c in shown:
        used[c.ravel()] = True  # a face of no area in three cells (a sliver) still has its corners
    vi = np.flatnonzero(used)
    kv = keys[vi]
    if n_keys <= max(8 * len(vi), 1 << 22):  # the cells present, numbered in order: a table
        present = np.zeros(n_keys, dtype=bool)
        present[kv] = True
        cid = (np.cumsum(present) - 1)[kv]
        n = int(cid.max()) + 1 if len(cid) else 0
    else:  # the same numbers, sorting
        cells, cid = np.unique(kv, return_inverse=True)
        n = len(cells)
    w = w[vi] + 1e-9 * (float(w.sum()) / max(len(vi), 1)) + 1e-300  # a cell of zero-area faces: their plain mean
    total = np.bincount(cid, weights=w, minlength=n)
    v = vertices[vi]
    reps = np.stack([np.bincount(cid, weights=w * v[:, a], minlength=n) / total for a in range(3)], axis=1)
    to_cell = np.zeros(nv, dtype=np.int64)
    to_cell[vi] = cid
    # the groups' faces as one surface (a fold across two stories is one fold), then apart
    group = np.repeat(np.arange(len(shown)), [len(c) for c in shown])
    c = to_cell[np.concatenate(shown)] if shown else np.zeros((0, 3), dtype=np.int64)
    first, pair = _one_a_triple(c, n)
    c, group = c[first], group[first]
    keep = _without_flaps(c, pair, n)
    c, group = c[keep], group[keep]
    meshes = []
    for g in range(len(shown)):
        f = c[group == g]
        on = np.zeros(n, dtype=bool)
        on[f.ravel()] = True  # a cell of collapsed faces only is no vertex
        meshes.append(Mesh(reps[on], (np.cumsum(on) - 1)[f]))
    return meshes


def _one_a_triple(c: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Of faces on the same three cells (``c``, ``(m, 3)`` of ``n`` cells), the first: their
    indices, in order; and for each, whether as many faces of its triple ran one way as the
    other (the two sides of a part thinner than a cell, or a fold)."""
    lo, hi = min3(c), max3(c)
    mid = c.sum(axis=1) - lo - hi
    if n < 2**21:  # the three cells, in order, as one int64
        order = np.argsort((lo * n + mid) * n + hi, kind="stable")
    else:  # pragma: no cover - over two million cells shown
        order = np.lexsort((hi, mid, lo))
    s = np.stack([lo, mid, hi], axis=1)[order]
    start = np.flatnonzero(np.concatenate([[True], np.any(s[1:] != s[:-1], axis=1)])) if len(s) else np.zeros(0, dtype=np.int64)
    # +1 when the face runs lo, mid, hi (an even permutation), -1 the other way
    even = ((c[:, 0] == lo) & (c[:, 1] == mid)) | ((c[:, 1] == lo) & (c[:, 2] == mid)) | ((c[:, 2] == lo) & (c[:, 0] == mid))
    net = np.add.reduceat(np.where(even, 1, -1)[order], start) if len(start) else np.zeros(0, dtype=np.int64)
    first = order[start]  # the sort is stable: the first face of each triple in the scan's order
    in_order = np.argsort(first)
    return first[in_order], (net == 0)[in_order]


def _edge_keys(f: np.ndarray, n: int) -> np.ndarray:
    """``(m, 3)`` int64: the edges of faces ``f`` (of ``n < 2**31`` cells), each as one number."""
    a, b = f, np.roll(f, -1, axis=1)
    return np.minimum(a, b) * n + np.maximum(a, b)


def _without_flaps(c: np.ndarray, pair: np.ndarray, n: int) -> np.ndarray:
    """Which of the faces ``c`` (``(m, 3)`` cells of ``n``) to keep: all but the flaps that
    folds of the surface within a cell leave, small groups of faces kept from pairs of
    opposite faces (``pair``) without which each of their edges has an even number of faces.

    Counted with its way round, a closed surface clustered is closed again (each edge has as
    many faces running along it one way as the other), and a pair of opposite faces on one
    triple counts for nothing. One face of such a pair is shown all the same, so that a part
    thinner than a cell (its two sides on the same cells) still shows, as one sheet. Where a
    fold leaves such faces alone, or two or three of them side by side (at most
    :data:`FLAP_FACES`, joined by their edges), they stand out of the surface by an edge with
    no other face (a smooth sphere clustered to 117k faces had about 700 flaps, leaving 970
    edges with one face and 1,110 with three): without them every edge they had has an even
    number of faces again, and the surface is closed. A thin part's sheet is larger, and stays.
    """
    keep = np.ones(len(c), dtype=bool)
    sel = np.flatnonzero(pair)
    if not len(sel):
        return keep
    near = np.zeros(n, dtype=bool)
    near[c[sel].ravel()] = True
    around = c[np.count_nonzero(near[c], axis=1) >= 2]  # the faces that may share an edge with them
    edges, counts = np.unique(_edge_keys(around, n), return_counts=True)
    e = _edge_keys(c[sel], n).ravel()  # the pair faces' edges, three a face
    face = np.repeat(np.arange(len(sel)), 3)
    # the pair faces joined where they share an edge, each group named by its first face: the
    # least name passed along the joins as many times as a flap has faces reaches every face
    # of a flap; a group still joined to a face of another name is larger
    order = np.argsort(e, kind="stable")
    same = np.flatnonzero(e[order][1:] == e[order][:-1])
    u, v = face[order][same], face[order][same + 1]
    label = np.arange(len(sel))
    for _ in range(FLAP_FACES):
        least = np.minimum(label[u], label[v])
        np.minimum.at(label, u, least)
        np.minimum.at(label, v, least)
    size = np.bincount(label, minlength=len(sel))
    split = label[u] != label[v]
    size[label[u][split]] = FLAP_FACES + 1
    size[label[v][split]] = FLAP_FACES + 1
    # each group's edges: the faces of the group on each (runs of equal group and edge)
    g = label[face]
    order = np.lexsort((e, g))
    ge, gg = e[order], g[order]
    start = np.flatnonzero(np.concatenate([[True], (ge[1:] != ge[:-1]) | (gg[1:] != gg[:-1])]))
    own = np.diff(np.append(start, len(ge)))
    left = counts[np.searchsorted(edges, ge[start])] - own  # faces on the edge, the group's left out
    odd = np.zeros(len(size), dtype=bool)
    odd[gg[start][left % 2 == 1]] = True
    flap = (size <= FLAP_FACES) & ~odd
    keep[sel[flap[label]]] = False
    return keep


def cluster_vertices(mesh: Mesh, cell: float, faces: np.ndarray | None = None) -> Mesh:
    """The faces ``faces`` of ``mesh`` (indices, in the scan's order; all by default) with
    every vertex moved to the representative of its cell, on a grid of cubes of edge ``cell``
    from the vertices' lowest corner: vertex clustering (Rossignac and Borrel's, with the mean
    of a cell's vertices, no quadrics).

    Returns
    -------
    Mesh
        One vertex a cell that the faces' corners fall in, at the mean of the cell's vertices
        weighted by the area around each (a third of the area of its faces: a finely
        tessellated patch does not pull it more than a coarse one of the same size). A cell's
        vertices lie in the cell and on the surface, so their mean lies in the cell, and on a
        flat wall or floor on its plane (a corner is cut by up to a cell). The faces whose
        corners fall in three cells, re-indexed, each way round as it was, in the scan's order
        (which keeps the page's packing small); the others (two corners in one cell) collapse
        to an edge or a point and go. Of faces on the same three cells (the two sides of a
        part thinner than a cell, or a fold) the first is kept, but for the flaps that folds
        leave (:func:`_without_flaps`).

    Notes
    -----
    A closed surface stays closed. Counted with their way round, the faces left make a closed
    surface again (the image of a cycle is a cycle: every edge of the scan had a face on
    either side, and a face that collapses takes its shared edges along): each edge has as
    many faces running along it one way as the other. A pair of opposite faces on the same
    cells counts for nothing there, but one of them is shown, so that a part thinner than a
    cell still shows, as one sheet (its rim may stay open); the pairs that folds of the
    surface within a cell leave alone are taken off, and then every edge of a clustered closed
    surface has two faces, or now and then four (cells that meet at one edge of the surface
    only). Cost: linear in the faces but for a sort of the faces left.
    """
    faces = np.arange(mesh.n_faces) if faces is None else np.asarray(faces, dtype=np.int64)
    grid = _Grid(mesh.vertices)
    keys, n_keys = grid.keys(grid.rel, cell)
    corners = mesh.faces[faces]
    return _cluster(mesh.vertices, [corners], [mesh.face_areas[faces]], keys, n_keys, [_three_cells(keys[corners])])[0]


def simplify_faces(mesh: Mesh, groups: Sequence[np.ndarray], budget: int) -> tuple[list[Mesh], float | None]:
    """The face groups ``groups`` of ``mesh`` (the stories) as meshes of at most ``budget``
    faces in all, clustered on one voxel grid (:func:`cluster_vertices`).

    Returns
    -------
    meshes
        One a group: its faces exactly (:func:`~meshplan.export.glb.submesh`) when the
        groups hold ``budget`` faces or fewer in all, else clustered.
    cell
        The grid's cell, metres; ``None`` when nothing was clustered.

    Notes
    -----
    The groups are clustered on the same cells with the same representatives (those of all
    their vertices), so where two stories meet their layers still meet, vertex on vertex.

    The cell is the finest found whose faces fit. The faces left fall about as the square of
    the cell grows (a vertex a cell the surface crosses, two faces a vertex), so from a first
    guess (the square root of twice the area over the budget) the cell is scaled by the square
    root of the faces left over the budget, kept between the cells already known too fine
    and coarse enough (geometric bisection where a step would leave them), until the faces
    left are within :data:`CELL_SEARCH_TOLERANCE` under the budget, or after
    :data:`CELL_SEARCH_STEPS` cells. A cell is judged by comparing the cells of each face's
    corners (a few milliseconds on the benchmark's 300k faces; two or three cells are tried
    there; past :data:`CELL_SEARCH_SAMPLE` faces, among every k-th face, and the cell found
    checked in full); the faces shown are fewer still (duplicates and flaps go). The grid
    starts at the scan's lowest corner, so the same scan gives the same cells, and the same
    page. On the benchmark's apartments (120k faces shown) the cell is 7.6 cm for the
    300k-face one, 8.6 cm for the 3M-face one (smaller faces, more of the furniture's surface
    kept), and the view's layers take 0.08 and 0.35 s to make (0.02 and 0.1 s for the former
    subsample).
    """
    groups = [np.asarray(g, dtype=np.int64) for g in groups]
    total = sum(len(g) for g in groups)
    if total <= budget:
        return [submesh(mesh, g) for g in groups], None
    grid = _Grid(mesh.vertices)
    corners = [mesh.faces[g] for g in groups]
    areas = [mesh.face_areas[g] for g in groups]
    target = max(budget * (1.0 - 0.5 * CELL_SEARCH_TOLERANCE), 1.0)
    finest = max(float(grid.size.max()) * 2.0**-20, 1e-9)  # the cells' numbers fit in an int64
    # past CELL_SEARCH_SAMPLE faces, the search counts the faces left among every k-th face
    # (of their corners' cells alone): a face is left or not by the cells of its own corners,
    # so k times their count estimates the scan's
    stride = -(-total // CELL_SEARCH_SAMPLE)
    if stride > 1:
        sample = np.concatenate([c[::stride] for c in corners])
        rel = np.take(grid.rel, sample.ravel(), axis=1)
        weight = total / len(sample)

        def estimate(cell: float) -> float:
            keys, _ = grid.keys(rel, cell)
            return weight * int(np.count_nonzero(_three_cells(keys.reshape(-1, 3))))
    else:

        def estimate(cell: float) -> float:
            keys, _ = grid.keys(grid.rel, cell)
            return float(sum(int(np.count_nonzero(_three_cells(keys[c]))) for c in corners))

    fine, coarse = 0.0, math.inf  # too many faces with cells of `fine`, few enough with `coarse`
    cell = max(math.sqrt(2.0 * float(sum(a.sum() for a in areas)) / target), finest)
    for _ in range(CELL_SEARCH_STEPS):
        kept = estimate(cell)
        if kept > target:
            fine = cell
        else:
            coarse = cell
            if kept >= (1.0 - CELL_SEARCH_TOLERANCE) * budget:
                break
        if coarse < math.inf and coarse <= fine * 1.001:
            break
        guess = max(cell * math.sqrt(max(kept, 1.0) / target), finest)
        if not fine < guess < coarse:
            guess = math.sqrt(fine * coarse) if 0.0 < fine and coarse < math.inf else (2.0 * cell if kept > target else 0.5 * cell)
        cell = guess
    cell = coarse if coarse < math.inf else 2.0 * cell
    # the faces left, counted, and a coarser cell while they are too many (an estimate may be
    # a little low)
    while True:
        keys, n_keys = grid.keys(grid.rel, cell)
        three = [_three_cells(keys[c]) for c in corners]
        kept = sum(int(np.count_nonzero(t)) for t in three)
        if kept <= budget:
            break
        cell *= max(math.sqrt(kept / target), 1.002)
    return _cluster(mesh.vertices, corners, areas, keys, n_keys, three), cell


def subsample_faces(areas: np.ndarray, m: int, seed: int = SUBSAMPLE_SEED) -> np.ndarray:
    """``m`` of the faces with these ``areas``, as sorted indices: a random choice with a fixed
    seed, each face weighted by its area (Efraimidis and Spirakis' exponential keys,
    vectorized). How a point cloud's splats are shown past the budget (:func:`view_meshes`):
    they share no vertex, so that clustering their vertices would collapse most of them."""
    n = len(areas)
    if m >= n:
        return np.arange(n)
    if m <= 0:
        return np.zeros(0, dtype=np.int64)
    rng = np.random.default_rng(seed)
    with np.errstate(divide="ignore"):
        keys = -np.log(rng.random(n)) / np.asarray(areas, dtype=np.float64)
    return np.sort(np.argpartition(keys, m - 1)[:m])


def view_meshes(result: Result, max_faces: int = MAX_FACES) -> ViewMeshes:
    """The 3D view's layers: each story without its ceiling and its flat walls.

    When the stories hold more than ``max_faces`` faces in all (flat walls included), they are
    simplified on one voxel grid (:func:`simplify_faces`: vertex clustering, the finest cell
    that fits), so that the page stays small and responsive and the surface keeps no holes it
    did not have; the flat walls (two faces a wall) are always whole. Smaller scans are shown
    exactly. A point cloud's splats (one triangle a point, no vertex shared) are shown as a
    fixed subsample instead, the same fraction of every story's (:func:`subsample_faces`).
    """
    mesh = result.mesh
    walls = [result.walls.mesh(sp.story.index) for sp in result.stories]
    budget = max(max_faces - sum(w.n_faces for w in walls), 0)
    groups = [sp.model_faces for sp in result.stories]
    cell: float | None = None
    if result.input.points_read:
        n_scan = sum(len(f) for f in groups)
        frac = 1.0 if n_scan <= budget else budget / n_scan
        scans = [
            submesh(mesh, f[subsample_faces(mesh.face_areas[f], int(math.floor(frac * len(f))), SUBSAMPLE_SEED + sp.story.index)])
            for sp, f in zip(result.stories, groups)
        ]
    else:
        scans, cell = simplify_faces(mesh, groups, budget)
    layers = []
    for sp, scan, wall_mesh in zip(result.stories, scans, walls):
        i = sp.story.index
        layers.append(ViewMesh(f"story {i}: scan", "scan", i, scan, len(sp.model_faces)))
        layers.append(ViewMesh(f"story {i}: flat walls", "walls", i, wall_mesh, wall_mesh.n_faces))
    return ViewMeshes(tuple(layers), max_faces, cell)


# --------------------------------------------------------------------------------------------
# The page's data


def _hex(rgba) -> str:
    return "#{:02x}{:02x}{:02x}".format(*rgba[:3])


def _finite_or_none(a: np.ndarray, nd: int = 9) -> list[float] | None:
    a = np.asarray(a, dtype=np.float64)
    if not np.all(np.isfinite(a)):
        return None
    return (np.round(a, nd) + 0.0).tolist()


def quantize_positions(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertex coordinates rounded to a uint16 grid across their bounding box.

    Parameters
    ----------
    vertices
        ``(n, 3)`` finite coordinates, metres (the plan frame).

    Returns
    -------
    q : numpy.ndarray
        ``(n, 3)`` uint16: ``vertices ~= origin + q * step``.
    origin : numpy.ndarray
        ``(3,)`` float64, the box's low corner (zeros when there is no vertex).
    step : numpy.ndarray
        ``(3,)`` float64, the box's extent over :data:`POSITION_LEVELS` per axis (0 on an axis
        where the box is flat: every coordinate is then the origin's, exactly).

    Notes
    -----
    The error of a coordinate decoded as the page does (:func:`decode_positions`) is at most
    half a step, ``extent / 131070``, plus the float32 rounding of the decoded value
    (``|x| * 2**-24``, 6 micrometres at 100 m from the plan's origin). A layer is one story
    (or its flat walls), so the extent is that story's: 0.076 mm on the benchmark apartment's
    9.9 m, 0.5 mm for a 65 m story, 1 mm would take a 131 m one. Shared vertices are rounded
    once, so faces that meet still meet (no cracks), and a click cast against the decoded
    faces lands within that error of the scanned surface.
    """
    # axis by axis (x, y and z each contiguous): numpy loops over an (n, 3) array's rows of 3
    # several times slower
    vt = np.ascontiguousarray(np.asarray(vertices, dtype=np.float64).reshape(-1, 3).T)
    if not vt.shape[1]:
        return np.zeros((0, 3), dtype=np.uint16), np.zeros(3), np.zeros(3)
    origin = vt.min(axis=1)
    step = (vt.max(axis=1) - origin) / POSITION_LEVELS
    scale = np.divide(1.0, step, out=np.zeros(3), where=step > 0)
    # (v - origin) * scale lies in [0, 65535] (a hair over at most): + 0.5, truncated, rounds
    # it to the nearest level
    qt = ((vt - origin[:, None]) * scale[:, None] + 0.5).astype(np.uint16)
    return qt.T, origin, step


def decode_positions(q: np.ndarray, origin: np.ndarray, step: np.ndarray) -> np.ndarray:
    """The coordinates the page decodes from :func:`quantize_positions`: ``origin + q * step``
    in double precision, stored as float32 (the page's ``Float32Array``), bit for bit."""
    return (np.asarray(origin, dtype=np.float64) + np.asarray(q, dtype=np.float64) * np.asarray(step, dtype=np.float64)).astype(np.float32)


def pack_positions(q: np.ndarray) -> np.ndarray:
    """Quantized coordinates (:func:`quantize_positions`) as the page's bytes: per axis (x, y,
    then z), the differences from the previous vertex modulo 65536 (the first from 0), their
    low bytes and then their high bytes.

    In first-use order (:func:`first_use_order`) a vertex is mostly near the one before it
    (the corners of one face, then of the next face of the same surface), so the differences
    are small: their high bytes mostly 0 or 255, which deflate packs, and their low bytes
    repeat more. Measured (deflated, base64) on the benchmark's apartments when they were
    shown as a subsample of whole faces: 0.94 -> 0.70 MB for the 129k vertices shown of the
    300k-face one, 2.23 -> 1.63 MB for the 312k of the 3M-face one (1 face in 20 kept: few
    shared vertices). Simplified (:func:`simplify_faces`), the faces shown share their
    vertices: 59k and 54k of them.

    Returns
    -------
    numpy.ndarray
        ``6 n`` uint8; :func:`unpack_positions` undoes it.
    """
    d = np.mod(np.diff(np.asarray(q).reshape(-1, 3).T.astype(np.int64), axis=1, prepend=0), 65536)
    return np.stack([d & 0xFF, d >> 8], axis=1).astype(np.uint8).ravel()  # x low, x high, y low, ...


def unpack_positions(b: np.ndarray, n: int) -> np.ndarray:
    """The ``(n, 3)`` uint16 coordinates :func:`pack_positions` packed, as the page unpacks
    them (a running sum of the differences, modulo 65536)."""
    planes = np.asarray(b, dtype=np.int64).reshape(3, 2, n)
    d = planes[:, 0] | (planes[:, 1] << 8)
    return (np.cumsum(d, axis=1) % 65536).astype(np.uint16).T


def first_use_order(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """The vertices the faces use, in the order the faces first name them.

    Parameters
    ----------
    faces
        ``(m, 3)`` vertex indices.
    n_vertices
        Number of vertices they index.

    Returns
    -------
    order : numpy.ndarray
        The used vertices (old indices) in order of first use, reading the faces row by row;
        vertices of no face are left out.
    faces : numpy.ndarray
        ``(m, 3)`` int64, the faces renumbered: vertex ``order[n]`` becomes ``n``.
    """
    flat = np.asarray(faces, dtype=np.int64).ravel()
    first = np.full(n_vertices, len(flat), dtype=np.int64)
    np.minimum.at(first, flat, np.arange(len(flat)))
    is_first = np.zeros(len(flat), dtype=bool)
    is_first[first[first < len(flat)]] = True
    order = flat[is_first]  # linear time: the corners where a vertex first appears, in order
    renumber = np.zeros(n_vertices, dtype=np.int64)
    renumber[order] = np.arange(len(order))
    return order, renumber[flat].reshape(-1, 3)


def encode_faces(faces: np.ndarray) -> np.ndarray:
    """Faces numbered in first-use order (:func:`first_use_order`) as back-reference codes.

    Read row by row, a corner either names the next vertex not seen yet (code 0) or one seen
    before, ``code`` vertices back from it: ``code = next - index``. A scan lists its faces
    surface by surface, so the codes are 0 or small (at most 313 on the benchmark apartment,
    against indices up to 129k), which deflate packs into a third of what it makes of the
    indices themselves: 0.23 MB, base64, for its 120k faces shown, against 0.64 MB for the
    renumbered indices and 0.96 MB for the indices in their former order (uint32).

    Returns
    -------
    numpy.ndarray
        ``3 m`` codes, int64, in ``[0, n_vertices]``: :func:`decode_faces` undoes them.
    """
    flat = np.asarray(faces, dtype=np.int64).ravel()
    if not len(flat):
        return flat
    seen = np.maximum.accumulate(flat) + 1  # vertices seen once each corner is read
    nxt = np.concatenate([[0], seen[:-1]])
    return nxt - flat


def decode_faces(codes: np.ndarray) -> np.ndarray:
    """The ``(m, 3)`` faces :func:`encode_faces` coded, as the page decodes them.

    The page reads the codes in turn (``index = next - code``, ``next`` one on after a 0);
    here the same, vectorized: the next new vertex at a corner is the number of 0 codes before
    it.
    """
    c = np.asarray(codes, dtype=np.int64).ravel()
    nxt = np.concatenate([[0], np.cumsum(c == 0)[:-1]]) if len(c) else c
    return (nxt - c).reshape(-1, 3)


def _block(a: np.ndarray, dtype: str) -> str:
    """Little-endian ``dtype`` bytes of ``a``, deflated (zlib), base64: what the page inflates
    with the browser's ``DecompressionStream("deflate")``."""
    return base64.b64encode(zlib.compress(np.ascontiguousarray(a, dtype=dtype).tobytes(), ZLIB_LEVEL)).decode("ascii")


def _layer_data(layer: ViewMesh) -> dict[str, Any]:
    """A layer for the page.

    The vertices are those of the faces, in first-use order (:func:`first_use_order`); their
    coordinates rounded to uint16 across the layer's box (:func:`quantize_positions`), with
    the box's ``position_origin`` and ``position_step`` per axis, and packed as differences
    from vertex to vertex, x, y and z apart (:func:`pack_positions`; plotly wants the axes
    apart too); the faces as back-reference codes read row by row (:func:`encode_faces`),
    uint16 when every code fits (always with fewer than 65536 vertices) and uint32 otherwise
    (``face_dtype``). Both blocks are deflated (zlib), then base64.

    On the benchmark's 300k-face apartment, subsampled (120k faces and 129k vertices shown),
    the meshes took 0.93 MB of the page where float32 coordinates and uint32 indices in base64
    took 3.98 MB: uint16 coordinates take half (2.06 -> 1.03 MB), packed and deflated 0.70 MB,
    and deflate packs the face codes into 0.23 MB (1.92 MB as uint32 indices). Simplified
    (115k faces sharing 59k vertices) they take 0.60 MB. The page's 3D view waits for the
    browser to inflate and decode them: about 0.1 s in Chromium, where plotly then takes 1 to
    2 s to build the scene. Making them takes about 30 ms here.
    """
    m = layer.mesh
    order, faces = first_use_order(m.faces, m.n_vertices)
    q, origin, step = quantize_positions(m.vertices[order])
    codes = encode_faces(faces)
    face_dtype = "uint16" if not len(codes) or int(codes.max()) <= np.iinfo(np.uint16).max else "uint32"
    return {
        "name": layer.name,
        "role": layer.role,
        "story": layer.story,
        "color": _hex(MESH_RGBA if layer.role == "scan" else _WALL_VIEW_RGB),
        "visible": layer.role == "scan",
        "n_vertices": len(order),
        "n_faces": m.n_faces,
        "positions": _block(pack_positions(q), "u1"),
        "position_origin": origin.tolist(),
        "position_step": step.tolist(),
        "faces": _block(codes, "<u2" if face_dtype == "uint16" else "<u4"),
        "face_dtype": face_dtype,
    }


def _annotation_data(result: Result) -> list[dict[str, Any]]:
    """The scan's annotations in the plan frame (to draw) and in the file's coordinates (to
    export unchanged)."""
    ann = result.annotations
    if not len(ann):
        return []
    inv = np.linalg.inv(result.transform)
    scale = float(result.input.scale_to_m)
    pos_in = transform_points(inv, ann.positions) / scale
    dir_in = transform_directions(inv, ann.directions)
    story = result.annotation_story
    return [
        {
            "label": label,
            "kind": kind,
            "story": int(story[i]) if i < len(story) else None,
            "position": _finite_or_none(ann.positions[i]),
            "direction": _finite_or_none(ann.directions[i]),
            "input_position": _finite_or_none(pos_in[i]),
            "input_direction": _finite_or_none(dir_in[i]),
        }
        for i, (label, kind) in enumerate(zip(ann.labels, ann.kinds))
    ]


def page_data(result: Result, view: ViewMeshes) -> dict[str, Any]:
    """What the page's script reads (the ``meshplan-data`` JSON): the layers, the annotations,
    the transform back to the file's coordinates and the stories."""
    return {
        "meshplan_version": __version__,
        "meshes": [_layer_data(layer) for layer in view.layers],
        "faces_shown": view.faces_shown,
        "faces_total": view.faces_total,
        "annotations": _annotation_data(result),
        "kinds": list(ANNOTATION_KINDS),
        "kind_colors": {k: _hex(KIND_RGBA.get(k, KIND_RGBA["other"])) for k in ANNOTATION_KINDS},
        "kind_prefix": KIND_PREFIX,
        "to_input": np.linalg.inv(result.transform).tolist(),
        "scale_to_m": float(result.input.scale_to_m),
        "units": result.input.units,
        "stories": [
            {
                "index": s.index,
                "floor": s.floor,
                "ceiling": s.ceiling,
                "bottom": s.bottom if math.isfinite(s.bottom) else None,
                "top": s.top if math.isfinite(s.top) else None,
            }
            for s in result.orientation.stories
        ],
        "probe_m": PROBE_M,
    }

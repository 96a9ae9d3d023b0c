"""The report's meshes (meshplan.export.view3d): large scans simplified by vertex clustering
(closed surfaces stay closed), and packed: uint16 coordinates on each layer's box, faces as
back-references in first-use order, deflated. Decoded here as the page's script does (report.js,
decodeLayer), independently of view3d's own decoders, which are checked against it."""

from __future__ import annotations

import base64
import zlib

import numpy as np
import pytest

from meshplan.export.glb import submesh
from meshplan.export.view3d import (
    POSITION_LEVELS,
    ViewMesh,
    _layer_data,
    cluster_vertices,
    decode_faces,
    decode_positions,
    encode_faces,
    first_use_order,
    pack_positions,
    quantize_positions,
    simplify_faces,
    unpack_positions,
)
from meshplan.geometry import Mesh

#: float32's relative rounding (half an ulp): what storing a decoded coordinate may add.
F32_REL = 2.0**-24


def decode_layer(layer: dict) -> tuple[np.ndarray, np.ndarray]:
    """``(vertices float32 (n, 3), faces int64 (m, 3))`` of a layer of the page's data, decoded
    step by step as report.js decodes it (inflate; per axis, the low and high bytes of the
    differences summed modulo 65536 to ``q``, then ``origin + q * step`` in double, stored as
    float32; the face codes read in turn)."""
    nv, nf = layer["n_vertices"], layer["n_faces"]
    b = np.frombuffer(zlib.decompress(base64.b64decode(layer["positions"])), np.uint8).astype(np.int64)
    assert b.size == 6 * nv
    o, st = layer["position_origin"], layer["position_step"]
    pos = np.empty(3 * nv, dtype=np.float32)
    for a in range(3):
        lo, hi = b[2 * a * nv : (2 * a + 1) * nv], b[(2 * a + 1) * nv : (2 * a + 2) * nv]
        q = np.cumsum(lo | (hi << 8)) & 0xFFFF  # the page's running sum, masked at each step
        pos[a * nv : (a + 1) * nv] = o[a] + q.astype(np.float64) * st[a]
    codes = np.frombuffer(zlib.decompress(base64.b64decode(layer["faces"])), {"uint16": "<u2", "uint32": "<u4"}[layer["face_dtype"]])
    assert codes.size == 3 * nf
    idx, nxt = [], 0
    for c in codes.tolist():
        idx.append(nxt - c)
        nxt += c == 0
    assert nxt == nv
    return pos.reshape(3, nv).T, np.array(idx, dtype=np.int64).reshape(nf, 3)


def position_bound(vertices: np.ndarray, step: np.ndarray) -> np.ndarray:
    """The stated worst case (quantize_positions): half a step, plus float32's rounding."""
    return 0.5 * step + np.abs(vertices) * F32_REL + 1e-12


def _grid_scan(n: int = 350, keep: int = 120_000, seed: int = 0) -> Mesh:
    """A scan-like surface: a 10 m square grid of ``n`` by ``n`` vertices, 5 mm of noise across
    it, its faces listed row by row as a scanner lists them, ``keep`` of them at random (as the
    report's former subsample kept them: few vertices shared)."""
    rng = np.random.default_rng(seed)
    x, z = np.meshgrid(np.linspace(0.0, 10.0, n), np.linspace(0.0, 10.0, n))
    v = np.stack([x.ravel() + 3.0, rng.normal(0.0, 0.005, n * n) + 1.2, z.ravel() - 4.0], axis=1)
    a = (np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None, :]).ravel()
    faces = np.stack([np.stack([a, a + 1, a + n], 1), np.stack([a + 1, a + n + 1, a + n], 1)], axis=1).reshape(-1, 3)
    return submesh(Mesh(v, faces), np.sort(rng.choice(len(faces), keep, replace=False)))


# --------------------------------------------------------------------------------------------


def test_quantized_positions_round_trip_within_half_a_step():
    rng = np.random.default_rng(1)
    box = np.array([60.0, 3.1, 41.0])  # a large story
    v = rng.random((20_000, 3)) * box + [-250.0, 0.4, 1200.0]  # far from the origin: float32 counts
    q, origin, step = quantize_positions(v)
    assert q.dtype == np.uint16 and q.min() == 0 and q.max() == POSITION_LEVELS
    np.testing.assert_allclose(origin, v.min(axis=0))
    np.testing.assert_allclose(step, (v.max(axis=0) - v.min(axis=0)) / 65535)
    err = np.abs(decode_positions(q, origin, step).astype(np.float64) - v)
    assert np.all(err <= position_bound(v, step))
    assert err.max(axis=0)[[0, 2]].min() > 0.4 * step[[0, 2]].min()  # the bound is met, not loose
    assert np.all(err <= 0.5e-3)  # as the docstring states: under half a millimetre on a 60 m story


def test_packed_positions_round_trip_exactly():
    rng = np.random.default_rng(3)
    q = rng.integers(0, 65536, size=(5000, 3)).astype(np.uint16)
    q[:4] = [[0, 65535, 7], [65535, 0, 7], [0, 65535, 8], [1, 1, 1]]  # differences that wrap round
    b = pack_positions(q)
    assert b.dtype == np.uint8 and b.shape == (6 * len(q),)
    np.testing.assert_array_equal(b[: 2 * len(q)].reshape(2, -1)[:, 1], [65535 & 0xFF, 65535 >> 8])  # x: 65535 - 0, low then high
    np.testing.assert_array_equal(unpack_positions(b, len(q)), q)
    # near vertices (first-use order) give small differences: high bytes 0 or 255 only
    walk = np.cumsum(rng.integers(-100, 101, size=(5000, 3)), axis=0) + 30_000
    high = pack_positions(walk.astype(np.uint16)).reshape(3, 2, -1)[:, 1, 1:]
    assert set(np.unique(high).tolist()) <= {0, 255}
    assert unpack_positions(pack_positions(np.zeros((0, 3), dtype=np.uint16)), 0).shape == (0, 3)


def test_quantized_positions_flat_axis_and_empty_layer():
    v = np.array([[0.0, 2.5, 1.0], [4.0, 2.5, 3.0], [1.0, 2.5, 2.0]])
    q, origin, step = quantize_positions(v)
    assert step[1] == 0.0 and np.all(q[:, 1] == 0)
    np.testing.assert_array_equal(decode_positions(q, origin, step)[:, 1], np.float32(2.5))
    q, origin, step = quantize_positions(np.zeros((0, 3)))
    assert q.shape == (0, 3) and q.dtype == np.uint16 and np.all(origin == 0) and np.all(step == 0)


def test_faces_round_trip_exactly_in_first_use_order():
    rng = np.random.default_rng(2)
    nv = 5000
    faces = rng.integers(0, nv, size=(8000, 3))
    faces[::7, 1] = faces[::7, 0]  # a repeated corner is still coded
    order, renumbered = first_use_order(faces, nv + 10)  # vertices of no face are left out
    assert len(order) == len(np.unique(faces)) and len(set(order.tolist())) == len(order)
    np.testing.assert_array_equal(order[renumbered], faces)  # the same vertices, renumbered
    flat = renumbered.ravel()
    assert np.all(flat <= np.concatenate([[0], np.maximum.accumulate(flat)[:-1] + 1]))  # first use
    codes = encode_faces(renumbered)
    assert codes.min() >= 0 and codes.max() <= len(order)
    np.testing.assert_array_equal(decode_faces(codes), renumbered)
    layer = _layer_data(ViewMesh("l", "scan", 0, Mesh(rng.random((nv + 10, 3)), faces), len(faces)))
    _, decoded = decode_layer(layer)
    np.testing.assert_array_equal(decoded, renumbered)
    np.testing.assert_array_equal(decode_faces(encode_faces(np.zeros((0, 3), dtype=np.int64))), np.zeros((0, 3)))


def _strip(nv: int) -> np.ndarray:
    t = np.arange(nv - 2)
    return np.stack([t, t + 1, t + 2], axis=1)


@pytest.mark.parametrize(
    "nv,far,dtype",
    [
        (65_535, True, "uint16"),  # under 65536 vertices: every code fits
        (70_000, False, "uint16"),  # more, but every face names vertices close to each other
        (70_000, True, "uint32"),  # more, and a face reaches back past 65535 vertices
    ],
)
def test_face_dtype_is_uint16_when_every_code_fits(nv, far, dtype):
    faces = _strip(nv)
    if far:
        faces = np.concatenate([faces, [[0, nv - 2, nv - 1]]])
    v = np.stack([np.arange(nv) * 1e-3, np.zeros(nv), np.arange(nv) % 7 * 1e-2], axis=1)
    layer = _layer_data(ViewMesh("l", "scan", 0, Mesh(v, faces), len(faces)))
    assert layer["face_dtype"] == dtype
    assert layer["n_vertices"] == nv and layer["n_faces"] == len(faces)
    pos, decoded = decode_layer(layer)
    np.testing.assert_array_equal(decoded, faces)  # first use is the original order here
    assert np.all(np.abs(pos - v) <= position_bound(v, np.array(layer["position_step"])))


def test_layer_round_trip_and_size_of_a_scan_like_subsample():
    mesh = _grid_scan()
    layer = _layer_data(ViewMesh("s", "scan", 0, mesh, 2 * 349 * 349))
    pos, faces = decode_layer(layer)
    step = np.array(layer["position_step"])
    assert np.all(step < 10.0 / 65535 * 1.001)
    # the faces drawn are the mesh's: each corner decodes to its own vertex
    tri = pos[faces].astype(np.float64)
    assert np.all(np.abs(tri - mesh.triangles) <= position_bound(mesh.triangles, step))
    assert layer["n_vertices"] == mesh.n_vertices and layer["face_dtype"] == "uint16"
    # float32 coordinates and uint32 indices in base64 took 32 bytes a face; 5.5 now
    size = len(layer["positions"]) + len(layer["faces"])
    assert size / mesh.n_faces < 8.0, size / mesh.n_faces


# --------------------------------------------------------------------------------------------
# Large scans simplified: vertex clustering


def _cube(n: int, lo=(-1.0, -1.0, -1.0), hi=(1.0, 1.0, 1.0)) -> Mesh:
    """The closed surface of a box, ``n`` by ``n`` squares of two faces on each side
    (``12 n**2`` faces), the vertices shared along the edges and corners, every face
    counter-clockwise seen from outside."""
    t = np.arange(n + 1)
    u, v = (a.ravel() for a in np.meshgrid(t, t, indexing="ij"))
    cell = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).ravel()  # a square's low corner
    q00, q10, q01, q11 = cell, cell + n + 1, cell + 1, cell + n + 2
    quads = np.concatenate([np.stack([q00, q10, q11], 1), np.stack([q00, q11, q01], 1)])
    points, faces = [], []
    for axis in range(3):
        for side in (0, n):
            p = np.zeros((len(u), 3), dtype=np.int64)
            p[:, axis], p[:, (axis + 1) % 3], p[:, (axis + 2) % 3] = side, u, v
            faces.append((quads if side else quads[:, ::-1]) + sum(len(q) for q in points))
            points.append(p)
    grid, index = np.unique(np.concatenate(points), axis=0, return_inverse=True)
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    return Mesh(lo + grid * (hi - lo) / n, index.ravel()[np.concatenate(faces)])


def _edge_uses(mesh: Mesh) -> np.ndarray:
    """How many edges have 0, 1, 2, ... faces (each edge met by at least one face)."""
    f = mesh.faces
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    _, counts = np.unique(e[:, 0] * mesh.n_vertices + e[:, 1], return_counts=True)
    return np.bincount(counts)


def _welded(meshes: list[Mesh]) -> Mesh:
    """The meshes as one, their vertices at the same place merged (the layers as drawn)."""
    v = np.concatenate([m.vertices for m in meshes])
    base = np.cumsum([0] + [m.n_vertices for m in meshes])[:-1]
    f = np.concatenate([m.faces + b for m, b in zip(meshes, base)])
    points, index = np.unique(v, axis=0, return_inverse=True)
    return Mesh(points, index.ravel()[f])


@pytest.fixture(scope="module")
def box():
    return _cube(130)  # 202,800 faces


@pytest.fixture(scope="module")
def sphere(box):
    """A sphere of radius 2 m: the box's grid pushed out onto it (202,800 faces)."""
    v = box.vertices
    return Mesh(2.0 * v / np.linalg.norm(v, axis=1, keepdims=True), box.faces)


def _simplified(mesh: Mesh, budget: int) -> tuple[Mesh, float]:
    (shown,), cell = simplify_faces(mesh, [np.arange(mesh.n_faces)], budget)
    assert cell is not None
    return shown, cell


@pytest.mark.parametrize("budget", [120_000, 50_000, 5_000])
def test_closed_sphere_simplified_stays_closed_on_its_surface(sphere, budget):
    assert _edge_uses(sphere).tolist() == [0, 0, 304_200]  # closed: every edge has two faces
    shown, cell = _simplified(sphere, budget)
    assert 0.9 * budget <= shown.n_faces <= budget
    # closed still: every edge has two faces (none open, none shared by more)
    uses = _edge_uses(shown)
    assert uses[1] == 0 and uses[2] > 0 and uses[3:].sum() == 0, uses
    # on the surface: every vertex within a cell of it (far closer: the mean of a patch of it)
    r = np.linalg.norm(shown.vertices, axis=1)
    assert np.all(np.abs(r - 2.0) <= cell), np.abs(r - 2.0).max() / cell
    assert np.abs(r - 2.0).max() < 0.05 * cell
    # the same area, the faces still facing out (a fold within a cell may turn one round)
    assert abs(shown.face_areas.sum() / sphere.face_areas.sum() - 1.0) < 0.01
    out = np.einsum("ij,ij->i", shown.face_normals, shown.face_centroids) > 0
    assert out.mean() > 0.99
    # the finest cell that fits: a tenth finer leaves too many faces
    assert cluster_vertices(sphere, cell / 1.1).n_faces > budget


def test_closed_box_simplified_stays_closed_corners_cut_by_under_a_cell(box):
    shown, cell = _simplified(box, 50_000)
    assert 45_000 <= shown.n_faces <= 50_000
    uses = _edge_uses(shown)
    assert uses[1] == 0 and uses[3:].sum() == 0, uses
    # on a side, a vertex stays on its plane; along the box's edges and corners the mean of a
    # cell's points cuts in, by under a cell
    inside = 1.0 - np.abs(shown.vertices).max(axis=1)
    assert inside.min() >= -1e-12 and inside.max() < cell
    on_a_side = np.sum(np.abs(np.abs(shown.vertices) - 1.0) < 1e-12, axis=1) >= 1
    assert on_a_side.mean() > 0.9
    assert 0.97 < shown.face_areas.sum() / box.face_areas.sum() <= 1.0


def test_thin_part_stays_as_one_sheet():
    """A slab thinner than a cell: its two sides fall on the same cells and show as one sheet
    (the flaps that folds leave are taken off; a thin part's sheet is not one)."""
    slab = _cube(100, lo=(0.0, 0.0, 0.0), hi=(2.0, 0.01, 2.0))  # 2 m by 2 m, 1 cm thick, 120k faces
    shown, cell = _simplified(slab, 20_000)
    assert cell > 0.02  # the two sides within a cell of each other
    top = slab.face_areas[slab.face_normals[:, 1] > 0.5].sum()  # 4 m2 a side
    assert 0.9 * top < shown.face_areas.sum() < 1.2 * top
    # it covers the slab: seen from above, every 10 cm square has faces over it
    c = shown.face_centroids
    cover = np.zeros((20, 20), dtype=bool)
    cover[np.clip((c[:, 0] / 0.1).astype(int), 0, 19), np.clip((c[:, 2] / 0.1).astype(int), 0, 19)] = True
    assert cover.all()


def test_stories_simplified_on_one_grid_still_meet(sphere):
    """Two groups of faces (the stories) clustered together: the same cells and the same
    representatives, so that where they meet their layers share their vertices, and the two
    together are as closed as the whole."""
    top = np.flatnonzero(sphere.face_centroids[:, 1] > 0.3)
    bottom = np.flatnonzero(sphere.face_centroids[:, 1] <= 0.3)
    (a, b), cell = simplify_faces(sphere, [top, bottom], 50_000)
    assert cell is not None and a.n_faces + b.n_faces <= 50_000
    assert _edge_uses(a)[1] > 0 and _edge_uses(b)[1] > 0  # each open where it was cut
    uses = _edge_uses(_welded([a, b]))
    assert uses[1] == 0 and uses[3:].sum() == 0, uses
    assert a.face_centroids[:, 1].min() > 0.3 - 2 * cell and b.face_centroids[:, 1].max() < 0.3 + 2 * cell


def test_simplification_is_deterministic(sphere):
    (a,), cell_a = simplify_faces(sphere, [np.arange(sphere.n_faces)], 30_000)
    (b,), cell_b = simplify_faces(sphere, [np.arange(sphere.n_faces)], 30_000)
    assert cell_a == cell_b
    np.testing.assert_array_equal(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.faces, b.faces)
    assert _layer_data(ViewMesh("s", "scan", 0, a, sphere.n_faces)) == _layer_data(ViewMesh("s", "scan", 0, b, sphere.n_faces))


def test_meshes_under_the_budget_are_shown_exactly(sphere):
    groups = [np.arange(0, 1000), np.arange(5000, 5600)]
    meshes, cell = simplify_faces(sphere, groups, 1600)  # exactly the budget
    assert cell is None
    for m, g in zip(meshes, groups):
        exact = submesh(sphere, g)
        np.testing.assert_array_equal(m.vertices, exact.vertices)
        np.testing.assert_array_equal(m.faces, exact.faces)
    (m,), cell = simplify_faces(sphere, [np.arange(1601)], 1600)  # one over: clustered
    assert cell is not None and m.n_faces <= 1600


def test_simplified_layer_is_small_on_the_page(sphere):
    """Clustered faces share their vertices (about one a two faces) and run surface by surface
    in the scan's order: the layer packs small (6.7 bytes a face on this curved surface, all
    its coordinates different; 5.2 on the benchmark's 300k-face apartment, mostly walls)."""
    shown, _ = _simplified(sphere, 50_000)
    assert shown.n_vertices < 0.55 * shown.n_faces
    layer = _layer_data(ViewMesh("s", "scan", 0, shown, sphere.n_faces))
    pos, faces = decode_layer(layer)
    np.testing.assert_array_equal(pos[faces].shape, shown.triangles.shape)
    assert np.all(np.abs(pos[faces] - shown.triangles) <= position_bound(shown.triangles, np.array(layer["position_step"])))
    assert (len(layer["positions"]) + len(layer["faces"])) / shown.n_faces < 8.0


def test_point_cloud_splats_are_subsampled_not_clustered():
    """A point cloud's splats (one triangle a point, no vertex shared: io.points.splat_mesh)
    are no surface to cluster (most would collapse in cells as large as they are, the rest
    turn into triangles between cells): they are shown as a fixed subsample of whole splats,
    as large scans were before."""
    from types import SimpleNamespace

    from meshplan.export.view3d import view_meshes

    rng = np.random.default_rng(4)
    n = 30_000
    centres = np.stack([rng.random(n) * 10.0, np.zeros(n), rng.random(n) * 10.0], axis=1)  # a 10 m floor
    corners = centres[:, None, :] + 0.02 * np.array([[1.0, 0.0, 0.0], [-0.5, 0.0, 0.87], [-0.5, 0.0, -0.87]])
    splats = Mesh(corners.reshape(-1, 3), np.arange(3 * n).reshape(-1, 3)[:, ::-1])
    no_walls = Mesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64))

    def result(points_read: int) -> SimpleNamespace:
        story = SimpleNamespace(model_faces=np.arange(n), story=SimpleNamespace(index=0))
        return SimpleNamespace(mesh=splats, stories=[story], walls=SimpleNamespace(mesh=lambda i: no_walls), input=SimpleNamespace(points_read=points_read))

    view = view_meshes(result(n), max_faces=10_000)  # type: ignore[arg-type]
    (layer,) = [v for v in view.layers if v.role == "scan"]
    assert view.cell_m is None and view.decimated and layer.faces_shown == 10_000
    assert np.isclose(layer.mesh.face_areas, splats.face_areas[0]).all()  # whole splats
    again = view_meshes(result(n), max_faces=10_000)  # type: ignore[arg-type]
    np.testing.assert_array_equal(again.layers[0].mesh.vertices, layer.mesh.vertices)
    # a mesh of the same faces is clustered
    mesh_view = view_meshes(result(0), max_faces=10_000)  # type: ignore[arg-type]
    assert mesh_view.cell_m is not None and mesh_view.faces_shown <= 10_000

"""The report's packed meshes (meshplan.export.view3d): uint16 coordinates on each layer's box,
faces as back-references in first-use order, deflated. Decoded here as the page's script does
(report.js, decodeLayer), independently of view3d's own decoders, which are checked against it."""

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
    decode_faces,
    decode_positions,
    encode_faces,
    first_use_order,
    pack_positions,
    quantize_positions,
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
    report's subsample keeps them)."""
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
    layer = _layer_data(ViewMesh("l", "scan", 0, Mesh(rng.random((nv + 10, 3)), faces), len(faces)), 0.0)
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
    layer = _layer_data(ViewMesh("l", "scan", 0, Mesh(v, faces), len(faces)), 0.0)
    assert layer["face_dtype"] == dtype
    assert layer["n_vertices"] == nv and layer["n_faces"] == len(faces)
    pos, decoded = decode_layer(layer)
    np.testing.assert_array_equal(decoded, faces)  # first use is the original order here
    assert np.all(np.abs(pos - v) <= position_bound(v, np.array(layer["position_step"])))


def test_layer_round_trip_and_size_of_a_scan_like_subsample():
    mesh = _grid_scan()
    layer = _layer_data(ViewMesh("s", "scan", 0, mesh, 2 * 349 * 349), 0.3)
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

"""Property and fuzz tests (hypothesis): the plan does not depend on how the scan is placed or
ordered, and no input makes meshplan fail with anything but a clear error."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from meshplan.errors import MeshplanError
from meshplan.geometry import Annotations, Mesh, homogeneous
from meshplan.io import LoadStats, load_mesh
from meshplan.options import RunOptions
from meshplan.pipeline import compute
from meshplan.synthetic import SynthParams, generate

SLOW = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
FAST = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
OPTIONS = RunOptions.from_kwargs(slices=10)


def _compute(mesh: Mesh, annotations: Annotations | None = None):
    stats = LoadStats("x", "ply", "m", 1.0, 1, mesh.n_vertices, mesh.n_faces, 0, 0, 0, mesh.n_vertices, mesh.n_faces)
    return compute(mesh, stats, annotations or Annotations(), OPTIONS)


@pytest.fixture(scope="module")
def base():
    scan = generate(SynthParams(preset="room", seed=21, triangle_size_m=(0.1, 0.18), tilt_deg=0.0))
    return scan, _compute(scan.mesh, scan.annotations)


def _rotation(q) -> np.ndarray:
    q = np.asarray(q, float)
    q = q / np.linalg.norm(q)
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def _wall_points(result) -> np.ndarray:
    w = result.walls
    mid = 0.5 * (w.bottom + w.top)
    return np.stack([np.c_[w.start[:, 0], mid, w.start[:, 1]], np.c_[w.end[:, 0], mid, w.end[:, 1]]], axis=1)


quaternions = st.tuples(*[st.floats(-1, 1, allow_nan=False) for _ in range(4)]).filter(lambda q: np.linalg.norm(q) > 0.2)
shifts = st.tuples(*[st.floats(-50, 50, allow_nan=False) for _ in range(3)])


@SLOW
@given(q=quaternions, t=shifts)
def test_rigid_motion_gives_the_same_plan(base, q, t):
    scan, r0 = base
    move = homogeneous(_rotation(q), t)
    r1 = _compute(scan.mesh.transformed(move), scan.annotations.transformed(move))
    # plan frame of r0 -> plan frame of r1: a quarter turn about y at most, and a shift
    rel = r1.transform @ move @ np.linalg.inv(r0.transform)
    x = rel[:3, :3] @ [1, 0, 0]
    yaw = np.degrees(np.arctan2(x[2], x[0])) % 90
    assert min(yaw, 90 - yaw) < 0.1
    assert np.degrees(np.arccos(np.clip(rel[1, 1], -1, 1))) < 0.1
    assert [round(s.floor, 2) for s in r0.orientation.stories] == pytest.approx([round(s.floor, 2) for s in r1.orientation.stories], abs=0.01)
    assert [s.height for s in r0.orientation.stories] == pytest.approx([s.height for s in r1.orientation.stories], abs=0.01)
    # every wall of r0 has a counterpart in r1 within 1 cm (ends may swap)
    p0 = _wall_points(r0) @ rel[:3, :3].T + rel[:3, 3]
    p1 = _wall_points(r1)
    assert len(p0) == len(p1)
    for seg in p0:
        d = np.minimum(np.abs(p1 - seg).max(axis=(1, 2)), np.abs(p1[:, ::-1] - seg).max(axis=(1, 2)))
        assert d.min() < 0.01
    a0 = sorted(r.area for r in r0.rooms)
    a1 = sorted(r.area for r in r1.rooms)
    assert len(a0) == len(a1) and np.allclose(a0, a1, rtol=0.005)
    # annotations follow
    assert np.allclose(r0.annotations.positions @ rel[:3, :3].T + rel[:3, 3], r1.annotations.positions, atol=1e-6)


@settings(max_examples=5, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**32 - 1))
def test_vertex_and_face_order_change_nothing(base, seed):
    from meshplan.export import plan_document

    scan, r0 = base
    rng = np.random.default_rng(seed)
    perm_v = rng.permutation(scan.mesh.n_vertices)
    inv = np.empty_like(perm_v)
    inv[perm_v] = np.arange(len(perm_v))
    faces = inv[scan.mesh.faces][rng.permutation(scan.mesh.n_faces)]
    faces = np.roll(faces, rng.integers(0, 3), axis=1)  # start each face at another corner
    r1 = _compute(Mesh(scan.mesh.vertices[perm_v], faces), scan.annotations)
    d0, d1 = plan_document(r0), plan_document(r1)
    for key in ("transform", "stories", "walls", "rooms", "openings", "annotations"):
        assert _close(d0[key], d1[key]), key


def _close(a, b, tol=1e-3) -> bool:
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_close(a[k], b[k], tol) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(_close(x, y, tol) for x, y in zip(a, b))
    if isinstance(a, float) or isinstance(b, float):
        return abs(a - b) <= tol
    return a == b


meshes = st.integers(3, 40).flatmap(
    lambda n: st.tuples(
        arrays(np.float64, (n, 3), elements=st.floats(-5, 5, allow_nan=False, width=32)),
        arrays(np.int64, st.tuples(st.integers(1, 60), st.just(3)), elements=st.integers(0, n - 1)),
    )
)


@FAST
@given(mesh=meshes)
def test_random_small_meshes_never_crash(mesh):
    vertices, faces = mesh
    try:
        from meshplan.io.mesh import clean_mesh

        cleaned, _ = clean_mesh(vertices, faces)
        if cleaned.n_faces:
            _compute(cleaned)
    except MeshplanError as exc:
        assert exc.message and "\n" not in exc.message


@FAST
@given(data=st.binary(min_size=1, max_size=2048), ext=st.sampled_from(["ply", "obj", "stl", "off", "glb", "gltf"]))
def test_random_bytes_never_crash(tmp_path_factory, data, ext):
    path = tmp_path_factory.mktemp("fuzz") / f"scan.{ext}"
    path.write_bytes(data)
    try:
        load_mesh(path)
    except MeshplanError as exc:
        assert exc.message and "\n" not in exc.message


@FAST
@given(header=st.sampled_from([b"ply\nformat ascii 1.0\n", b"ply\nformat binary_little_endian 1.0\n"]), body=st.binary(max_size=600),
       nv=st.integers(0, 50), nf=st.integers(0, 50))
def test_random_ply_bodies_never_crash(tmp_path_factory, header, body, nv, nf):
    text = header + (
        f"element vertex {nv}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {nf}\nproperty list uchar int vertex_indices\nend_header\n"
    ).encode() + body
    path = tmp_path_factory.mktemp("fuzzply") / "scan.ply"
    path.write_bytes(text)
    try:
        load_mesh(path)
    except MeshplanError as exc:
        assert exc.message and "\n" not in exc.message

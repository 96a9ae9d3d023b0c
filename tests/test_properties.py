"""Property and fuzz tests (hypothesis): the plan does not depend on how the scan is placed or
ordered, and no input makes meshplan fail with anything but a clear error.

Every test counts the cases it ran (the ``cases`` fixture) and fails if hypothesis ran fewer
than its ``max_examples``; together they run over 1,000 cases (issue 6 asks for 500), printed
at the end of the test session. The cases are the same on every run (see conftest.py).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from conftest import box_room
from meshplan.cli import main
from meshplan.errors import AnnotationError, MeshplanError
from meshplan.geometry import Annotations, Mesh, homogeneous
from meshplan.io import LoadStats, load_mesh
from meshplan.io.annotations import parse_annotations
from meshplan.options import RunOptions
from meshplan.pipeline import compute
from meshplan.synthetic import SynthParams, generate

pytestmark = pytest.mark.slow  # whole runs of meshplan: not part of the unit layer (-m "not slow")

OPTIONS = RunOptions.from_kwargs(slices=10)


def examples(n: int):
    """Run ``n`` generated cases (and check with the ``cases`` fixture that all of them ran)."""

    def wrap(fn):
        fn = settings(max_examples=n, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])(fn)
        return pytest.mark.hypothesis_cases(n)(fn)

    return wrap


@pytest.fixture
def cases(request, record_property):
    """A counter the test body increments once per generated case; checked after the test."""
    count = [0]
    yield count
    record_property("hypothesis_cases", count[0])
    wanted = request.node.get_closest_marker("hypothesis_cases").args[0]
    assert count[0] >= wanted, f"hypothesis ran {count[0]} cases, fewer than {wanted}"


def _clear(exc: MeshplanError) -> None:
    """A user error is one line: what is wrong; what to do."""
    assert exc.message and "\n" not in exc.message and exc.problem and exc.hint, exc.message


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


@examples(100)
@given(q=quaternions, t=shifts)
def test_rigid_motion_gives_the_same_plan(base, cases, q, t):
    """Walls within 1 cm, heights within 1 cm, room areas within 0.5 %, whatever the placement."""
    cases[0] += 1
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
    assert len(p0) == len(p1) >= 4
    for seg in p0:
        d = np.minimum(np.abs(p1 - seg).max(axis=(1, 2)), np.abs(p1[:, ::-1] - seg).max(axis=(1, 2)))
        assert d.min() < 0.01
    a0 = sorted(r.area for r in r0.rooms)
    a1 = sorted(r.area for r in r1.rooms)
    assert a0 and len(a0) == len(a1) and np.allclose(a0, a1, rtol=0.005)
    # annotations follow
    assert np.allclose(r0.annotations.positions @ rel[:3, :3].T + rel[:3, 3], r1.annotations.positions, atol=1e-6)


@examples(25)
@given(seed=st.integers(0, 2**32 - 1))
def test_vertex_and_face_order_change_nothing(base, cases, seed):
    from meshplan.export import plan_document

    cases[0] += 1
    scan, r0 = base
    rng = np.random.default_rng(seed)
    perm_v = rng.permutation(scan.mesh.n_vertices)
    inv = np.empty_like(perm_v)
    inv[perm_v] = np.arange(len(perm_v))
    faces = inv[scan.mesh.faces][rng.permutation(scan.mesh.n_faces)]
    faces = np.roll(faces, rng.integers(0, 3), axis=1)  # start each face at another corner
    r1 = _compute(Mesh(scan.mesh.vertices[perm_v], faces), scan.annotations)
    d0, d1 = plan_document(r0), plan_document(r1)
    # the plan as written (coordinates rounded to 0.1 mm) is exactly the same
    for key in ("transform", "stories", "walls", "rooms", "openings", "annotations", "levels"):
        assert d0[key] == d1[key], key
    assert r0.rooms and len(r0.walls) >= 4


@st.composite
def meshes(draw, kinds=("soup", "room", "part of a room", "room, scaled")) -> tuple[np.ndarray, np.ndarray]:
    """Small meshes: triangle soups, and coarse box rooms whole or in part, tilted, scaled
    (units), with NaN and infinite vertices; numpy draws the numbers from a hypothesis seed,
    so the cases are varied (hypothesis alone favours zeros, which make only degenerate faces)."""
    kind = draw(st.sampled_from(kinds))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    if kind == "soup":
        n = draw(st.integers(3, 40))
        vertices = rng.uniform(-5, 5, (n, 3))
        faces = rng.integers(0, n, (draw(st.integers(1, 60)), 3))
    else:
        vertices, faces = box_room(*rng.uniform([1.0, 1.0, 1.5], [8.0, 8.0, 5.0]), cell=rng.uniform(0.25, 0.8))
        vertices = vertices + rng.normal(0.0, draw(st.sampled_from([0.0, 0.005, 0.05])), vertices.shape)
        if kind == "part of a room":
            faces = faces[rng.random(len(faces)) < rng.uniform(0.05, 0.9)]
        if kind == "room, scaled":
            vertices = vertices * draw(st.sampled_from([0.01, 100.0, 1000.0]))
        tilt = homogeneous(_rotation(rng.normal(size=4)), rng.uniform(-100, 100, 3))
        vertices = vertices @ tilt[:3, :3].T + tilt[:3, 3]
    for _ in range(draw(st.integers(0, 3))):  # a few broken vertices
        vertices[rng.integers(len(vertices))] = rng.choice([math.nan, math.inf, -math.inf])
    return vertices, faces


@examples(300)
@given(mesh=meshes())
def test_random_small_meshes_never_crash(cases, mesh):
    from meshplan.io.mesh import clean_mesh

    cases[0] += 1
    vertices, faces = mesh
    try:
        cleaned, _ = clean_mesh(vertices, faces)
        if cleaned.n_faces:
            _compute(cleaned)
    except MeshplanError as exc:
        _clear(exc)


def test_segment_drawing_of_a_story_without_segments(base):
    """A story where the box DBSCAN found no segment at all still gets its (empty) drawing."""
    from dataclasses import replace

    import matplotlib.pyplot as plt

    from meshplan.render import make_sheet, segments_figure

    _, r0 = base
    walls = replace(r0.walls, face_segment=np.full(r0.mesh.n_faces, -1), segment_story=np.zeros(0, np.int64), segment_kept=np.zeros(0, bool))
    params = r0.options.render
    fig = segments_figure(r0.mesh.face_centroids, walls, 0, make_sheet(r0.mesh.face_centroids[:, [0, 2]], params), params)
    try:
        # a sheet with its plan axes, and not one pixel of segment on it (every face is in none)
        images = [im.get_array() for im in fig.images]  # the raster is a figure image (place_raster)
        assert fig.axes and images
        assert all(np.asarray(im)[..., 3].max() == 0 for im in images)
    finally:
        plt.close(fig)


@examples(25)
@given(mesh=meshes(("soup", "part of a room", "room, scaled")), ext=st.sampled_from(["obj", "ply"]))
def test_random_small_meshes_through_the_command_line(tmp_path_factory, capsys, cases, mesh, ext):
    """The whole command on random meshes: it succeeds, or says in one line what is wrong
    (exit status 2) and writes nothing; never an internal error (exit status 1)."""
    import trimesh

    cases[0] += 1
    d = tmp_path_factory.mktemp("cli")
    path = d / f"scan.{ext}"
    vertices, faces = mesh
    path.write_bytes(trimesh.Trimesh(vertices, faces, process=False).export(file_type=ext).encode() if ext == "obj" else
                     trimesh.Trimesh(vertices, faces, process=False).export(file_type=ext))
    code = main(["run", str(path), "-o", str(d / "out"), "--quiet", "--slices", "5", "--dpi", "30"])
    err = capsys.readouterr().err
    assert code in (0, 2) and "Traceback" not in err, err
    if code == 2:
        assert len(err.strip().splitlines()) == 1 and err.startswith("error: ") and "; " in err, err
        assert not (d / "out").exists()


@examples(300)
@given(data=st.binary(min_size=1, max_size=2048), ext=st.sampled_from(["ply", "obj", "stl", "off", "glb", "gltf"]))
def test_random_bytes_never_crash(tmp_path_factory, cases, data, ext):
    cases[0] += 1
    path = tmp_path_factory.mktemp("fuzz") / f"scan.{ext}"
    path.write_bytes(data)
    try:
        load_mesh(path)
    except MeshplanError as exc:
        _clear(exc)


@examples(200)
@given(header=st.sampled_from([b"ply\nformat ascii 1.0\n", b"ply\nformat binary_little_endian 1.0\n"]), body=st.binary(max_size=600),
       nv=st.integers(0, 50), nf=st.integers(0, 50))
def test_random_ply_bodies_never_crash(tmp_path_factory, cases, header, body, nv, nf):
    cases[0] += 1
    text = header + (
        f"element vertex {nv}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {nf}\nproperty list uchar int vertex_indices\nend_header\n"
    ).encode() + body
    path = tmp_path_factory.mktemp("fuzzply") / "scan.ply"
    path.write_bytes(text)
    try:
        load_mesh(path)
    except MeshplanError as exc:
        _clear(exc)


json_values = st.recursive(
    st.none() | st.booleans() | st.integers(-5, 5) | st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=6),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.sampled_from(["label", "kind", "position", "direction", "x"]), inner, max_size=5),
    max_leaves=12,
)
annotation_items = st.fixed_dictionaries(
    {"label": st.text(max_size=4) | json_values, "kind": st.sampled_from(["sensor", "door", "lamp"]) | json_values},
    optional={"position": st.lists(st.floats(-3, 3) | json_values, max_size=4), "direction": json_values},
)


@examples(200)
@given(doc=st.fixed_dictionaries({"annotations": st.lists(annotation_items, max_size=4)}) | json_values)
def test_random_annotation_documents_never_crash(cases, doc):
    """Malformed annotations (wrong types, missing fields, NaN) are refused with a clear error."""
    cases[0] += 1
    try:
        ann = parse_annotations(json.loads(json.dumps(doc)), "ann.json")
    except AnnotationError as exc:
        _clear(exc)
    else:
        assert np.all(np.isfinite(ann.positions))

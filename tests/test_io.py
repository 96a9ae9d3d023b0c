"""Reading meshes and annotations: formats, clean-up counts, units and clear errors."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh

from conftest import box_room
from meshplan.errors import AnnotationError, InputError, ParameterError
from meshplan.export.synth import obj_text
from meshplan.geometry import Mesh
from meshplan.io import load_annotations, load_mesh
from meshplan.io.annotations import annotations_document, parse_annotations


@pytest.fixture(scope="module")
def room():
    v, f = box_room(4.0, 3.0, 2.5, cell=0.25)
    return Mesh(v, f)


@pytest.mark.parametrize("fmt", ["obj", "ply", "stl", "off", "glb"])
def test_formats_round_trip(tmp_path, room, fmt):
    path = tmp_path / f"room.{fmt}"
    data = trimesh.Trimesh(room.vertices, room.faces, process=False).export(file_type=fmt)
    path.write_bytes(data if isinstance(data, bytes) else data.encode())
    loaded = load_mesh(path)
    assert loaded.mesh.n_faces == room.n_faces
    assert loaded.stats.dropped_faces == 0
    assert loaded.mesh.area == pytest.approx(room.area, rel=1e-5)
    assert np.allclose(loaded.mesh.bounds(), room.bounds(), atol=1e-5)


def test_ascii_ply(tmp_path, room):
    path = tmp_path / "room.ply"
    path.write_bytes(trimesh.Trimesh(room.vertices, room.faces, process=False).export(file_type="ply", encoding="ascii"))
    assert path.read_bytes().startswith(b"ply\nformat ascii")
    assert load_mesh(path).mesh.n_faces == room.n_faces


def test_multi_object_obj_is_flattened(tmp_path, room):
    groups = (room.face_centroids[:, 1] > 1.0).astype(int)  # two objects, each with own vertices
    path = tmp_path / "hololens.obj"
    path.write_text(obj_text(room.vertices, room.faces, groups, ("lower", "upper")))
    loaded = load_mesh(path)
    assert loaded.stats.objects == 2
    assert loaded.mesh.n_faces == room.n_faces
    # coincident vertices of the two objects are merged: the room is one connected surface
    assert loaded.mesh.n_vertices == len(np.unique(room.vertices, axis=0)) < loaded.stats.vertices_read


def test_glb_node_transforms_are_applied(tmp_path, room):
    scene = trimesh.Scene()
    tm = trimesh.Trimesh(room.vertices, room.faces, process=False)
    shift = np.eye(4)
    shift[:3, 3] = [10.0, 0.0, -3.0]
    scene.add_geometry(tm, transform=shift)
    path = tmp_path / "scene.glb"
    path.write_bytes(scene.export(file_type="glb"))
    loaded = load_mesh(path)
    assert np.allclose(loaded.mesh.bounds()[0], room.bounds()[0] + [10.0, 0.0, -3.0], atol=1e-5)


def test_units_scale_to_metres(tmp_path, room):
    path = tmp_path / "room_mm.ply"
    path.write_bytes(trimesh.Trimesh(room.vertices * 1000, room.faces, process=False).export(file_type="ply"))
    loaded = load_mesh(path, units="mm")
    assert np.allclose(loaded.mesh.bounds(), room.bounds(), atol=1e-6)
    assert loaded.stats.scale_to_m == 0.001
    with pytest.raises(ParameterError, match="unknown unit"):
        load_mesh(path, units="furlong")


def test_bad_faces_are_dropped_and_counted(tmp_path):
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [np.nan, 0, 0], [2, 0, 0]], float)
    f = np.array([
        [0, 1, 2],  # good
        [1, 3, 2],  # good
        [2, 1, 0],  # duplicate of the first (other winding)
        [0, 1, 4],  # NaN vertex
        [0, 1, 5],  # collinear: zero area
        [0, 0, 1],  # repeated vertex
    ])
    path = tmp_path / "bad.obj"
    path.write_text("".join(f"v {a} {b} {c}\n" for a, b, c in v) + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f))
    st = load_mesh(path).stats
    assert (st.faces, st.dropped_nonfinite, st.dropped_degenerate, st.dropped_duplicate) == (2, 1, 2, 1)
    assert st.faces_read == 6


def _clean_by_sorting(vertices, faces):
    """clean_mesh's rules written with numpy sorts (the implementation before its compiled
    pass): unique vertices in the order of their bit patterns, degenerate faces (a repeated
    vertex, no area) and repeats (same vertices, any order; the first kept) dropped."""
    from meshplan.io.mesh import MIN_FACE_AREA_M2

    v = vertices + 0.0
    bits = v.view(np.int64)
    order = np.lexsort((bits[:, 2], bits[:, 1], bits[:, 0]))
    new = np.r_[True, np.any(bits[order][1:] != bits[order][:-1], axis=1)]
    inverse = np.empty(len(v), np.int64)
    inverse[order] = np.cumsum(new) - 1
    uniq, f = v[order[new]], inverse[faces]
    tri = uniq[f]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    ok = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2]) & (0.5 * np.linalg.norm(cross, axis=1) > MIN_FACE_AREA_M2)
    f = f[ok]
    _, first = np.unique(np.sort(f, axis=1), axis=0, return_index=True)
    f = f[np.sort(first)]
    used, remap = np.unique(f, return_inverse=True)
    return uniq[used], remap.reshape(-1, 3), (int((~ok).sum()), int(ok.sum() - len(f)))


@pytest.mark.parametrize("hub", [0, 3000])
def test_clean_mesh_matches_sorting(hub):
    """The compiled clean-up (merge, renumber, degenerate and repeated faces) gives what sorting
    gives, to the bit, on a soup with coincident vertices (-0.0 among them), ties in x, repeats
    in other windings and unused vertices; with a fan of ``hub`` faces on one vertex, more than
    the chains allow (``CLEAN_MAX_CHAIN``), it finishes by its hash table with the same result."""
    from meshplan._kernels import CLEAN_MAX_CHAIN, clean_faces
    from meshplan.io.mesh import MIN_FACE_AREA_M2, _merge_vertices, clean_mesh

    rng = np.random.default_rng(7)
    v = np.round(rng.normal(size=(4000, 3)), 1)  # many coincident vertices, many ties
    v[:50, 0] = -0.0
    f = rng.integers(0, len(v) - 100, size=(12000, 3))  # the last vertices unused
    f[6000:6500] = f[:500][:, ::-1]  # repeats in the other winding
    f[7000:7100] = np.roll(f[100:200], 1, axis=1)  # repeats, turned
    if hub:  # vertex 0 first in the merged order: the lowest vertex of every face of the fan
        v[0] = [-1e-300, 0.0, 0.0]  # as a signed integer, the lowest bit pattern
        fan = rng.integers(1, len(v) - 100, size=(hub, 2))
        f = np.r_[f, np.c_[np.zeros(hub, np.int64), fan], np.c_[fan[:10, ::-1], np.zeros(10, np.int64)]]
    mesh, counts = clean_mesh(v, f)
    uniq, faces, (degenerate, repeated) = _clean_by_sorting(v, f)
    assert (counts["dropped_degenerate"], counts["dropped_duplicate"]) == (degenerate, repeated)
    assert repeated >= 500 and degenerate > 0
    uniq_all, inverse = _merge_vertices(v)
    buffers = np.empty((len(f), 3), np.int64), np.empty((len(f), 3, 3)), np.empty((len(f), 3))
    assert clean_faces(uniq_all, inverse, f, MIN_FACE_AREA_M2, False, *buffers)[-1] == (hub <= CLEAN_MAX_CHAIN)
    assert np.array_equal(mesh.vertices, uniq) and np.array_equal(mesh.faces, faces)
    t = uniq[faces]
    assert np.array_equal(mesh.triangles, t)
    assert np.allclose(mesh.face_areas, 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1), rtol=1e-12, atol=0)


@pytest.mark.parametrize(
    "name, content, message",
    [
        ("missing.obj", None, "file not found"),
        ("scan.xyz1", b"1 2 3", "unknown mesh format"),
        ("empty.ply", b"", "the file is empty"),
        ("garbage.ply", bytes(range(256)) * 10, "cannot be read as PLY"),
        ("points.ply", b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n", "point cloud"),
        ("degenerate.obj", b"v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n", "none of its 1 faces is usable"),
        ("binary.obj", bytes(range(256)) * 10, "holds binary data, not OBJ text"),
        ("binary.off", b"OFF\n\x00\x01\x02" * 100, "holds binary data, not OFF text"),
        ("broken.gltf", b'{"asset": ', "not a glTF file: not valid JSON"),
        ("cut.stl", bytes(80) + (1000).to_bytes(4, "little") + bytes(50 * 10), "corrupt header: header claims 1,000 faces but the file is only 584 bytes"),
        ("lying.ply", b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
         b"element face 5\nproperty list uchar int vertex_indices\nend_header\n" + bytes(36 + 13), "a face has fewer than three vertices"),
        ("lying_ascii.ply", b"ply\nformat ascii 1.0\nelement vertex 300\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n", "corrupt header: header claims 300 vertices but the file is only 108 bytes"),
    ],
)
def test_bad_files_give_clear_errors(tmp_path, name, content, message):
    path = tmp_path / name
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(InputError, match=message) as info:
        load_mesh(path)
    assert "\n" not in info.value.message and ";" in info.value.message


def test_directory_is_refused(tmp_path):
    with pytest.raises(InputError, match="is a directory"):
        load_mesh(tmp_path)


def test_max_faces_is_checked_before_loading(tmp_path, room):
    path = tmp_path / "room.ply"
    path.write_bytes(trimesh.Trimesh(room.vertices, room.faces, process=False).export(file_type="ply"))
    with pytest.raises(InputError, match=r"--max-faces"):
        load_mesh(path, max_faces=100)


@pytest.mark.parametrize("fmt", ["ply", "stl", "obj", "off", "glb"])
def test_a_mesh_too_large_for_memory_is_refused_up_front(tmp_path, room, fmt, monkeypatch):
    """The estimated need is stated, with --max-faces to override; the file is never read."""
    from meshplan.io import mesh as mesh_io

    path = tmp_path / f"room.{fmt}"
    data = trimesh.Trimesh(room.vertices, room.faces, process=False).export(file_type=fmt)
    path.write_bytes(data if isinstance(data, bytes) else data.encode())
    monkeypatch.setattr(mesh_io, "available_memory_bytes", lambda: 50_000)  # 50 kB "free"
    monkeypatch.setattr(mesh_io, "_read_with_trimesh", lambda *a: pytest.fail("read a file that cannot fit"))
    with pytest.raises(InputError) as info:
        load_mesh(path)
    faces = mesh_io.estimate_faces(path, fmt) or path.stat().st_size // 20
    assert faces >= room.n_faces
    assert info.value.message == (
        f"{path}: about {faces:,} faces would need about {faces * mesh_io.BYTES_PER_FACE / 1e9:.1f} GB of memory "
        f"and 0.0 GB are available; decimate the scan, or pass --max-faces {faces} to try anyway"
    )
    monkeypatch.undo()
    assert load_mesh(path, max_faces=faces).mesh.n_faces == room.n_faces  # the override works


# --------------------------------------------------------------------------------------------
# atomic output


def test_staged_directory_swaps_results_in_one_step(tmp_path):
    from meshplan.io import staged_directory
    from meshplan.io.atomic import _exchange

    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    (a / "x").write_text("a")
    if not _exchange(a, b):
        pytest.skip("this filesystem cannot exchange two paths atomically (two renames are used)")
    assert (b / "x").read_text() == "a" and not (a / "x").exists()
    out = tmp_path / "out"
    for text in ("first", "second"):
        with staged_directory(out, force=True) as tmp:
            assert tmp.parent == tmp_path and tmp.name.startswith(".out.meshplan-tmp-")
            (tmp / "plan.json").write_text(text)
        assert (out / "plan.json").read_text() == text
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a", "b", "out"]


def test_staged_directory_failures_leave_nothing(tmp_path):
    """A failure while writing: an OutputError in one line, no staged directory and none of the
    parents it created, the previous result untouched."""
    import errno

    from meshplan.errors import OutputError
    from meshplan.io import staged_directory
    from meshplan.io.atomic import KIND_PLANS, write_stamp

    target = tmp_path / "new" / "deeper" / "out"
    with pytest.raises(OutputError) as info:
        with staged_directory(target) as tmp:
            (tmp / "a.png").write_bytes(b"x")
            raise OSError(errno.ENOSPC, "No space left on device", str(tmp / "b.png"))
    assert info.value.message == (
        f"{target}: writing b.png failed (No space left on device) and nothing was changed; "
        "free some space or choose another output directory with -o"
    )
    assert list(tmp_path.iterdir()) == []
    previous = tmp_path / "previous"
    previous.mkdir()
    (previous / "plan.json").write_text("old")
    write_stamp(previous, KIND_PLANS)
    with pytest.raises(RuntimeError):
        with staged_directory(previous, force=True) as tmp:
            (tmp / "plan.json").write_text("new")
            raise RuntimeError("a bug while writing")
    assert [p.name for p in tmp_path.iterdir()] == ["previous"] and (previous / "plan.json").read_text() == "old"
    assert sorted(p.name for p in previous.iterdir()) == [".meshplan", "plan.json"]


def test_leftovers_of_a_killed_run_are_cleaned_up(tmp_path):
    """A run killed between the two renames (where the system cannot swap atomically) left the
    previous result under a hidden name: the next run puts it back; staged leftovers go."""
    from meshplan.io.atomic import _OLD_TAG, _TMP_TAG, remove_stale

    dead = 2**22 + 12345  # above the default pid_max: no such process
    old = tmp_path / f".out{_OLD_TAG}{dead}-abc"
    old.mkdir()
    (old / "plan.json").write_text("old")
    staged = tmp_path / f".out{_TMP_TAG}{dead}-def"
    staged.mkdir()
    (staged / "half.png").write_bytes(b"\x89PNG")
    remove_stale(tmp_path / "out")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    assert (tmp_path / "out" / "plan.json").read_text() == "old"


# --------------------------------------------------------------------------------------------
# annotations


def _write(tmp_path, doc) -> object:
    p = tmp_path / "ann.json"
    p.write_text(doc if isinstance(doc, str) else json.dumps(doc))
    return p


def test_annotations_round_trip(tmp_path):
    doc = {"annotations": [
        {"label": "S1", "kind": "sensor", "position": [1, 2, 3], "direction": [0, 0, 2]},
        {"label": "D1", "kind": "door", "position": [0, 1, 0]},
    ]}
    ann = load_annotations(_write(tmp_path, doc), scale_to_m=0.5)
    assert ann.labels == ("S1", "D1")
    assert np.allclose(ann.positions, [[0.5, 1, 1.5], [0, 0.5, 0]])
    assert np.allclose(ann.directions[0], [0, 0, 1]) and np.all(np.isnan(ann.directions[1]))
    again = parse_annotations(annotations_document(ann))
    assert np.allclose(again.positions, ann.positions)


@pytest.mark.parametrize(
    "doc, message",
    [
        ("{not json", "not valid JSON"),
        ({"items": []}, 'expected an object with an "annotations" list'),
        ({"annotations": [{"kind": "sensor", "position": [0, 0, 0]}]}, "has no 'label'"),
        ({"annotations": [{"label": "S1", "kind": "lamp", "position": [0, 0, 0]}]}, "unknown kind"),
        ({"annotations": [{"label": "S1", "kind": "sensor", "position": [0, 0]}]}, "list of three numbers"),
        ('{"annotations": [{"label": "S1", "kind": "sensor", "position": [NaN, 0, 0]}]}', "NaN or infinite"),
        ({"annotations": [{"label": "S1", "kind": "sensor", "position": [0, 0, 0], "direction": [0, 0, 0]}]}, "zero vector"),
        ({"annotations": [{"label": "S1", "kind": "sensor", "position": [0, 0, 0]}] * 2}, "duplicate label"),
    ],
)
def test_malformed_annotations(tmp_path, doc, message):
    with pytest.raises(AnnotationError, match=message):
        load_annotations(_write(tmp_path, doc))

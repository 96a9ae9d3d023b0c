"""Reads that are right or refused (issue 10): every hostile file is generated here, in
``tmp_path``, and the test checks the exact geometry read or the exact refusal."""

from __future__ import annotations

import json
import logging
import os
import struct
import subprocess
import sys
import time

import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from meshplan.cli import main
from meshplan.errors import InputError, MeshplanError
from meshplan.io import load_mesh
from meshplan.io import mesh as mesh_io

#: A unit square (two triangles) beside a unit triangle, as polygons: a quad and a triangle.
SQUARE_AND_TRIANGLE = (
    np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [3, 0, 0], [4, 0, 0], [3, 1, 0]], float),
    [[0, 1, 2, 3], [4, 5, 6]],
)


def triangles(loaded) -> set[tuple]:
    """The triangles of a loaded mesh as a set of corner-coordinate sets (order-free)."""
    tri = loaded.mesh.vertices[loaded.mesh.faces]
    return {frozenset(map(tuple, np.round(t, 9))) for t in tri}


def expected(vertices, polygons) -> set[tuple]:
    """The triangles of fan-triangulated polygons, as :func:`triangles` gives them."""
    v = np.asarray(vertices, float)
    out = set()
    for poly in polygons:
        for i in range(1, len(poly) - 1):
            out.add(frozenset(map(tuple, np.round(v[[poly[0], poly[i], poly[i + 1]]], 9))))
    return out


def ply_binary(vertices, polygons, endian="<", vtype="d", face_color=False, edge_element=False) -> bytes:
    """A binary PLY with polygons of any size (optionally a colour after each face's list and
    an ``edge`` element between the vertices and the faces)."""
    fmt = "binary_little_endian" if endian == "<" else "binary_big_endian"
    head = f"ply\nformat {fmt} 1.0\ncomment made by test_readers\nelement vertex {len(vertices)}\n"
    head += "".join(f"property {'double' if vtype == 'd' else 'float'} {c}\n" for c in "xyz")
    if edge_element:
        head += "element edge 2\nproperty int vertex1\nproperty int vertex2\n"
    head += f"element face {len(polygons)}\nproperty list uchar int vertex_indices\n"
    head += "property uchar red\n" if face_color else ""
    body = b"".join(struct.pack(endian + 3 * vtype, *v) for v in vertices)
    if edge_element:
        body += struct.pack(endian + "4i", 0, 1, 1, 2)
    for poly in polygons:
        body += struct.pack(f"{endian}B{len(poly)}i", len(poly), *poly) + (b"\x07" if face_color else b"")
    return (head + "end_header\n").encode() + body


def ply_ascii(vertices, polygons) -> bytes:
    head = f"ply\nformat ascii 1.0\nelement vertex {len(vertices)}\nproperty double x\nproperty double y\nproperty double z\n"
    head += f"element face {len(polygons)}\nproperty list uchar int vertex_indices\nproperty uchar red\nend_header\n"
    body = "".join(f"{float(x)!r} {float(y)!r} {float(z)!r}\n" for x, y, z in vertices)
    body += "".join(f"{len(p)} {' '.join(map(str, p))} 200\n" for p in polygons)
    return (head + body).encode()


def off_text(vertices, polygons, declared_faces=None) -> bytes:
    nf = len(polygons) if declared_faces is None else declared_faces
    text = f"OFF\n# a comment\n{len(vertices)} {nf} 0\n" + "".join(f"{float(x)!r} {float(y)!r} {float(z)!r}\n" for x, y, z in vertices)
    return (text + "".join(f"{len(p)} {' '.join(map(str, p))}\n" for p in polygons)).encode()


def stl_binary(vertices, triangles_) -> bytes:
    tri = np.asarray(vertices, np.float32)[np.asarray(triangles_)]
    rec = np.zeros(len(tri), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["v"] = tri
    return bytes(80) + struct.pack("<I", len(tri)) + rec.tobytes()


def one_error_line(argv, capsys) -> str:
    """Run ``meshplan run`` on ``argv``: exit status 2 and a single ``error:`` line."""
    code = main(["run", *argv])
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("error: ") and "; " in lines[0], (code, err)
    return lines[0]


# --------------------------------------------------------------------------------------------
# 1-2. OBJ: relative indices across objects and groups, byte-order mark, Latin-1


OBJ_RELATIVE = b"""# two objects and a group, each face given relative to the vertices read so far
o first
v 0 0 0
v 1 0 0
v 0 1 0
f -3 -2 -1
o second
v 10 0 0
v 11 0 0
v 10 1 0
v 11 1 0
vt 0 0
vn 0 0 1
f -4/-1/-1 -3/-1/-1 -2/-1/-1
g part
f -3//-1 -1//-1 -2//-1
f 1 3 -4
"""


def test_obj_relative_indices_count_from_the_whole_file(tmp_path):
    path = tmp_path / "relative.obj"
    path.write_bytes(OBJ_RELATIVE)
    loaded = load_mesh(path)
    v = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [10, 0, 0], [11, 0, 0], [10, 1, 0], [11, 1, 0]]
    # -4 after seven vertices is vertex 4 (10 0 0), not the first of the second object's block
    assert triangles(loaded) == expected(v, [[0, 1, 2], [3, 4, 5], [4, 6, 5], [0, 2, 3]])
    assert (loaded.stats.faces_read, loaded.stats.vertices_read, loaded.stats.objects) == (4, 7, 2)


def test_obj_polygons_are_fan_triangulated_and_extras_ignored(tmp_path):
    path = tmp_path / "quads.obj"
    path.write_bytes(b"mtllib x.mtl\nv 0 0 0 1\nv 1 0 0 1\nv 1 1 0 1\nv 0 1 0 1\ns off\nusemtl m\nf 1/1 2/2 3/3 4/4  # a quad\nl 1 2\n")
    loaded = load_mesh(path)
    assert triangles(loaded) == expected(SQUARE_AND_TRIANGLE[0], [[0, 1, 2, 3]])


@pytest.mark.parametrize("chunk", [7, 37, 1 << 20])
def test_obj_read_in_chunks_is_read_whole(tmp_path, monkeypatch, chunk):
    """Large OBJ files are parsed in chunks: relative indices and continued lines must not
    depend on where the chunks end."""
    from meshplan.io import readers

    monkeypatch.setattr(readers, "OBJ_CHUNK_BYTES", chunk)
    path = tmp_path / "chunks.obj"
    path.write_bytes(OBJ_RELATIVE + b"f -6 \\\n -1 \\\r\n -4\n")  # a face continued over three lines
    loaded = load_mesh(path)
    v = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [10, 0, 0], [11, 0, 0], [10, 1, 0], [11, 1, 0]]
    assert triangles(loaded) == expected(v, [[0, 1, 2], [3, 4, 5], [4, 6, 5], [0, 2, 3], [1, 6, 3]])
    assert loaded.stats.faces_read == 5


@pytest.mark.parametrize(
    "name, prefix, comment",
    [
        ("bom.obj", b"\xef\xbb\xbf", b"# exported\r\n"),
        ("latin1.obj", b"", "# caf\u00e9 de la gare, \u00e9tage 2\n".encode("latin-1")),
        ("latin1_name.obj", b"", "o pi\u00e8ce\t\n".encode("latin-1")),
    ],
)
def test_obj_encodings(tmp_path, name, prefix, comment):
    path = tmp_path / name
    path.write_bytes(prefix + comment + b"v 0 0 0\r\nv\t1 0 0\r\nv 0 1 0\r\nf 1 2 3\r\n")
    loaded = load_mesh(path)
    assert triangles(loaded) == expected([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])


@pytest.mark.parametrize(
    "text, message",
    [
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "refers to vertex 0"),
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\nf 1 2 3\n", "fewer than three vertices"),
        (b"v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n", "does not hold three numbers"),
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", "faces refer to vertices that do not exist"),
    ],
)
def test_obj_malformed_is_refused(tmp_path, text, message):
    path = tmp_path / "bad.obj"
    path.write_bytes(text)
    with pytest.raises(InputError, match=message):
        load_mesh(path)


# --------------------------------------------------------------------------------------------
# 3. PLY mixing quads and triangles, ASCII and binary; float64 kept


@pytest.mark.parametrize("endian", ["<", ">"])
@pytest.mark.parametrize("extras", [False, True])
def test_binary_ply_mixing_quads_and_triangles(tmp_path, endian, extras):
    v, polys = SQUARE_AND_TRIANGLE
    path = tmp_path / "mixed.ply"
    path.write_bytes(ply_binary(v, polys, endian, face_color=extras, edge_element=extras))
    loaded = load_mesh(path)
    assert triangles(loaded) == expected(v, polys)
    assert loaded.stats.faces_read == 3


def test_binary_ply_mixed_many_faces(tmp_path):
    """Irregularly mixed polygon sizes (the pointer-doubling path), against trimesh's reading of
    the same mesh written as triangles."""
    rng = np.random.default_rng(3)
    n = 500
    v = rng.random((n + 2, 3))
    sizes = rng.integers(3, 7, 200)
    polys = [list(range(s, s + k)) for s, k in zip(rng.integers(0, n - 6, 200), sizes)]
    path = tmp_path / "many.ply"
    path.write_bytes(ply_binary(v, polys, face_color=True))
    loaded = load_mesh(path)
    assert loaded.stats.faces_read == int((sizes - 2).sum())
    assert triangles(loaded) == expected(v, polys)


def test_ascii_ply_mixing_quads_and_triangles(tmp_path):
    v, polys = SQUARE_AND_TRIANGLE
    path = tmp_path / "mixed_ascii.ply"
    path.write_bytes(ply_ascii(v, polys))
    assert triangles(load_mesh(path)) == expected(v, polys)


@pytest.mark.parametrize("fmt", ["binary", "ascii", "obj", "off"])
def test_float64_coordinates_are_kept(tmp_path, fmt):
    """A georeferenced scan (5e6 m east) keeps its millimetres where the format has the digits."""
    v, polys = SQUARE_AND_TRIANGLE
    v = v * 0.001 + [5_000_000.0, 0.0, 0.0]  # millimetre-sized faces far from the origin
    data = {
        "binary": lambda: ply_binary(v, polys),
        "ascii": lambda: ply_ascii(v, polys),
        "off": lambda: off_text(v, polys),
        "obj": lambda: "".join(f"v {float(x)!r} {float(y)!r} {float(z)!r}\n" for x, y, z in v).encode() + b"f 1 2 3 4\nf 5 6 7\n",
    }[fmt]()
    path = tmp_path / f"geo.{'ply' if fmt in ('binary', 'ascii') else fmt}"
    path.write_bytes(data)
    loaded = load_mesh(path)
    assert np.array_equal(np.unique(loaded.mesh.vertices, axis=0), np.unique(v, axis=0))
    assert loaded.warnings == ()


def test_off_mixed_polygons_and_colours(tmp_path):
    v, polys = SQUARE_AND_TRIANGLE
    text = off_text(v, polys).replace(b"\n3 4 5 6\n", b"\n3 4 5 6 255 0 0\n").replace(b"OFF\n", b"COFF\n")
    path = tmp_path / "mixed.off"
    path.write_bytes(text)
    assert triangles(load_mesh(path)) == expected(v, polys)


# --------------------------------------------------------------------------------------------
# 4. truncation, for every format


def _room_bytes(fmt: str, encoding: str = "binary") -> bytes:
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
    f = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4], [2, 3, 7], [2, 7, 6]])
    if fmt == "off":
        return off_text(v, f.tolist())
    if fmt == "ply":
        return ply_ascii(v, f.tolist()) if encoding == "ascii" else ply_binary(v, f.tolist())
    if fmt == "stl":
        return stl_binary(v, f) if encoding == "binary" else trimesh.Trimesh(v, f, process=False).export(file_type="stl_ascii").encode()
    data = trimesh.Trimesh(v, f, process=False).export(file_type=fmt)
    return data if isinstance(data, bytes) else data.encode()


@pytest.mark.parametrize(
    "fmt, encoding, cut, message",
    [
        ("off", "ascii", -16, "is truncated: header says 8 faces, file holds 6"),
        ("off", "ascii", -2, "is truncated: header says 8 faces, file holds 7"),  # mid-line
        ("ply", "ascii", -19, "is truncated: header says 8 faces, file holds 6"),
        ("ply", "binary", -20, "is truncated: header says 8 faces, file holds 6"),
        ("ply", "binary", -8 * 13 - 8, "is truncated: header says 8 vertices and 8 faces, file holds 7 vertices and no face"),
        ("stl", "binary", -60, "is truncated: header says 8 faces, file holds 6"),
        ("stl", "ascii", -30, "is truncated: an ASCII STL ends with endsolid, this one stops after 7 complete facets"),
        ("glb", "binary", -40, "is truncated: header says 8 faces in"),
    ],
)
def test_truncated_files_are_refused(tmp_path, fmt, encoding, cut, message):
    data = _room_bytes(fmt, encoding)
    path = tmp_path / f"cut.{fmt}"
    path.write_bytes(data)
    assert load_mesh(path).stats.faces_read == 8  # whole, it reads
    path.write_bytes(data[:cut])
    with pytest.raises(InputError) as info:
        load_mesh(path)
    assert message in info.value.message
    assert info.value.hint.startswith("re-export the scan")


def test_a_truncated_obj_line_is_refused(tmp_path):
    path = tmp_path / "cut.obj"
    path.write_bytes(_room_bytes("obj")[:-3])
    with pytest.raises(InputError, match="cut short"):
        load_mesh(path)


# --------------------------------------------------------------------------------------------
# 5. float32 storage that lost precision


def test_float32_glb_far_from_the_origin_warns(tmp_path, caplog):
    v, polys = SQUARE_AND_TRIANGLE
    tm = trimesh.Trimesh(v + [5_000_000.0, 0, 0], [[0, 1, 2], [0, 2, 3], [4, 5, 6]], process=False)
    path = tmp_path / "geo.glb"
    path.write_bytes(tm.export(file_type="glb"))
    with caplog.at_level(logging.WARNING, logger="meshplan"):
        loaded = load_mesh(path)
    assert len(loaded.warnings) == 1
    w = loaded.warnings[0]
    assert "stored as float32" in w and "5,000,004 m from the origin" in w and "about 250 mm precision" in w, w
    # not logged by the reader: the run reports it once, in Result.warnings (printed by the CLI)
    assert [r.getMessage() for r in caplog.records if r.name == "meshplan"] == []


def test_float32_offset_in_a_node_transform_does_not_warn(tmp_path):
    """The same offset as a glTF node translation (float64 in the JSON) loses nothing."""
    v, _ = SQUARE_AND_TRIANGLE
    scene = trimesh.Scene()
    shift = np.eye(4)
    shift[:3, 3] = [5_000_000.0, 0, 0]
    scene.add_geometry(trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3], [4, 5, 6]], process=False), transform=shift)
    path = tmp_path / "node.glb"
    path.write_bytes(scene.export(file_type="glb"))
    loaded = load_mesh(path)
    assert loaded.warnings == ()
    assert np.allclose(loaded.mesh.bounds()[0], [5_000_000.0, 0, 0], atol=1e-6)


def test_float32_ply_in_millimetres_warns_in_metres(tmp_path):
    """The precision lost is stated after the unit conversion: 5e6 mm (5 km) in float32 keeps
    0.25 mm, no warning; 5e6 m keeps 250 mm."""
    v, polys = SQUARE_AND_TRIANGLE
    path = tmp_path / "f32.ply"
    path.write_bytes(ply_binary(v * 1000 + [5_000_000.0, 0, 0], polys, vtype="f"))
    assert load_mesh(path, units="mm").warnings == ()
    assert "250 mm" in load_mesh(path, units="m").warnings[0]


# --------------------------------------------------------------------------------------------
# 6. not a regular file


def test_fifo_device_and_directory_are_refused_up_front(tmp_path):
    fifo = tmp_path / "scan.obj"
    os.mkfifo(fifo)
    t0 = time.perf_counter()
    with pytest.raises(InputError, match=r"is a FIFO \(named pipe\), not a mesh file"):
        load_mesh(fifo)  # opening it would block until a writer comes
    assert time.perf_counter() - t0 < 5
    with pytest.raises(InputError, match="is a device, not a mesh file"):
        load_mesh("/dev/null")
    (tmp_path / "dir.ply").mkdir()
    with pytest.raises(InputError, match="is a directory, not a mesh file"):
        load_mesh(tmp_path / "dir.ply")


def test_fifo_through_the_command_line_does_not_hang(tmp_path):
    fifo = tmp_path / "scan.ply"
    os.mkfifo(fifo)
    proc = subprocess.run([sys.executable, "-m", "meshplan", "run", str(fifo), "-o", str(tmp_path / "out")],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip().splitlines() == [f"error: {fifo}: is a FIFO (named pipe), not a mesh file; save the scan to a regular file and give its path"]


# --------------------------------------------------------------------------------------------
# 7. memory: cgroup limits and headers that lie


def test_cgroup_v2_limit(tmp_path):
    (tmp_path / "memory.max").write_text("1073741824\n")  # 1 GiB
    (tmp_path / "memory.current").write_text(str(600 * 2**20))
    (tmp_path / "memory.stat").write_text(f"anon 1\ninactive_file {100 * 2**20}\nactive_file 5\n")
    assert mesh_io.cgroup_available_bytes(tmp_path) == (1024 - 600 + 100) * 2**20
    (tmp_path / "memory.max").write_text("max\n")
    assert mesh_io.cgroup_available_bytes(tmp_path) is None


def test_cgroup_v1_limit(tmp_path):
    mem = tmp_path / "memory"
    mem.mkdir()
    (mem / "memory.limit_in_bytes").write_text(str(2 * 2**30))
    (mem / "memory.usage_in_bytes").write_text(str(2 * 2**30 + 5))  # over: nothing left
    assert mesh_io.cgroup_available_bytes(tmp_path) == 0
    (mem / "memory.limit_in_bytes").write_text("9223372036854771712")  # v1's "no limit"
    assert mesh_io.cgroup_available_bytes(tmp_path) is None


def test_available_memory_is_the_least_of_host_and_cgroup(tmp_path, monkeypatch):
    host = mesh_io.available_memory_bytes()
    (tmp_path / "memory.max").write_text(str(40_000_000))
    (tmp_path / "memory.current").write_text(str(10_000_000))
    monkeypatch.setattr(mesh_io, "CGROUP_ROOT", tmp_path)
    assert mesh_io.available_memory_bytes() == min(host, 30_000_000)
    # a 100,000-face PLY (100 MB needed) is refused under a 40 MB container limit (30 MB left)
    v, polys = SQUARE_AND_TRIANGLE
    path = tmp_path / "big.ply"
    data = ply_binary(v, [[4, 5, 6]] * 100_000)
    path.write_bytes(data)
    with pytest.raises(InputError, match=r"100,000 faces would need about 0\.1 GB of memory and 0\.0 GB are available"):
        load_mesh(path)


@pytest.mark.parametrize(
    "name, data",
    [
        ("lie.ply", b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
         b"element face 1000000000\nproperty list uchar int vertex_indices\nend_header\n" + bytes(1000)),
        ("lie_ascii.ply", b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
         b"element face 1000000000\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
        ("lie.off", b"OFF\n3 1000000000 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
        ("lie.stl", bytes(80) + struct.pack("<I", 10**9) + bytes(50 * 3)),
    ],
)
def test_lying_headers_are_refused_before_the_memory_check(tmp_path, name, data, monkeypatch):
    monkeypatch.setattr(mesh_io, "available_memory_bytes", lambda: 10**9)  # 1 GB free: 1e9 faces would not fit
    path = tmp_path / name
    path.write_bytes(data)
    with pytest.raises(InputError) as info:
        load_mesh(path)
    assert info.value.message == (
        f"{path}: corrupt header: header claims 1,000,000,000 faces but the file is only {len(data):,} bytes; {mesh_io.REEXPORT}"
    )


def test_lying_glb_header(tmp_path, monkeypatch):
    monkeypatch.setattr(mesh_io, "available_memory_bytes", lambda: 10**9)
    glb = _room_bytes("glb")
    doc = json.loads(glb[20 : 20 + struct.unpack("<I", glb[12:16])[0]])
    doc["accessors"][doc["meshes"][0]["primitives"][0]["indices"]]["count"] = 3 * 10**9  # 1e9 triangles
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    rest = glb[20 + struct.unpack("<I", glb[12:16])[0] :]
    data = b"glTF" + struct.pack("<II", 2, 20 + len(text) + len(rest)) + struct.pack("<I", len(text)) + b"JSON" + text + rest
    path = tmp_path / "lie.glb"
    path.write_bytes(data)
    with pytest.raises(InputError, match=r"header claims 1,000,000,000 faces but the file is only"):
        load_mesh(path)


# --------------------------------------------------------------------------------------------
# 8. through the command line


def test_refusals_through_the_command_line(tmp_path, capsys):
    cut = tmp_path / "cut.off"
    cut.write_bytes(_room_bytes("off")[:-16])
    line = one_error_line([str(cut), "-o", str(tmp_path / "o1")], capsys)
    assert line == f"error: {cut}: is truncated: header says 8 faces, file holds 6; {mesh_io.REEXPORT}"
    lie = tmp_path / "lie.stl"
    lie.write_bytes(bytes(80) + struct.pack("<I", 10**9) + bytes(150))
    assert "header claims 1,000,000,000 faces but the file is only 234 bytes" in one_error_line([str(lie), "-o", str(tmp_path / "o2")], capsys)
    assert "is a directory" in one_error_line([str(tmp_path), "-o", str(tmp_path / "o3")], capsys)
    assert not any((tmp_path / o).exists() for o in ("o1", "o2", "o3"))


# --------------------------------------------------------------------------------------------
# fuzz: mutated and truncated small valid files never escape as anything but MeshplanError


def _seeds() -> dict[str, bytes]:
    v, polys = SQUARE_AND_TRIANGLE
    return {
        "obj": OBJ_RELATIVE,
        "ply": ply_binary(v, polys, face_color=True, edge_element=True),
        "ascii.ply": ply_ascii(v, polys),
        "off": off_text(v, polys),
        "stl": stl_binary(v, [[0, 1, 2], [0, 2, 3], [4, 5, 6]]),
        "ascii.stl": _room_bytes("stl", "ascii"),
    }


SEEDS = _seeds()
# 1,200 here and 800 of the annotation parser (test_validation.py): the 2,000 fuzz cases of issue 10
FUZZ_CASES = int(os.environ.get("MESHPLAN_FUZZ_CASES", 1200))


@pytest.fixture
def cases(record_property):
    """A counter the test body increments once per generated case, reported in the summary
    (see conftest.py) and checked: a fuzz test that silently ran few cases proves little."""
    count = [0]
    yield count
    record_property("hypothesis_cases", count[0])
    assert count[0] >= FUZZ_CASES, f"hypothesis ran {count[0]} cases, fewer than {FUZZ_CASES}"


@pytest.mark.hypothesis_cases(FUZZ_CASES)
@settings(max_examples=FUZZ_CASES, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(
    seed=st.sampled_from(sorted(SEEDS)),
    cut=st.one_of(st.none(), st.integers(0, 2000)),
    edits=st.lists(st.tuples(st.integers(0, 2000), st.sampled_from(["flip", "delete", "insert", "digit"]), st.integers(0, 255)), max_size=4),
)
def test_mutated_files_are_read_or_refused(tmp_path_factory, cases, seed, cut, edits):
    cases[0] += 1
    data = bytearray(SEEDS[seed])
    for pos, kind, byte in edits:
        pos %= max(len(data), 1)
        if kind == "flip" and data:
            data[pos] ^= 1 << (byte % 8)
        elif kind == "delete":
            del data[pos : pos + 1 + byte % 8]
        elif kind == "insert":
            data[pos:pos] = bytes([byte])
        elif data:
            data[pos] = ord("0") + byte % 10  # a changed digit: a count or an index that lies
    if cut is not None:
        data = data[: cut % (len(data) + 1)]
    path = tmp_path_factory.mktemp("fuzz") / f"scan.{seed}"
    path.write_bytes(bytes(data))
    try:
        loaded = load_mesh(path)
    except MeshplanError as exc:
        assert exc.message and "\n" not in exc.message and exc.hint, exc.message
    else:
        m = loaded.mesh
        assert m.n_faces > 0 and np.all(np.isfinite(m.vertices)) and m.faces.max() < m.n_vertices

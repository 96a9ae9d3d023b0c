"""Floor plans against ground truth: flat walls, slicing, drawings, DXF, plan.json."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import box_room
from meshplan.evaluate import evaluate, mapped_truth_walls, wall_scores
from meshplan.export import plan_document, plan_schema
from meshplan.geometry import Mesh
from meshplan.io import LoadStats
from meshplan.options import RunOptions
from meshplan.pipeline import compute
from meshplan.slicing import plane_heights, slice_mesh

pytestmark = pytest.mark.slow  # whole runs of meshplan: not part of the unit layer (-m "not slow")

SCENES = [
    ("apartment", 0, {}),
    ("apartment", 4, {"z_up": True, "winding": "outward"}),
    ("office", 3, {"winding": "mixed"}),  # every planar patch wound at random: walls face their floor
    ("office", 1, {}),
    ("multistory", 1, {}),
    ("room", 5, {"tilt_deg": 6.0}),
]


@pytest.mark.parametrize("preset, seed, kw", SCENES, ids=[f"{p}-{s}" for p, s, _ in SCENES])
def test_drafting_walls_match_truth(computed, preset, seed, kw):
    scan, result = computed(preset, seed, **kw)
    report = evaluate(plan_document(result), scan.truth)
    w = report["walls"]
    assert w["f1"] >= 0.9, w
    assert w["median_offset_m"] <= 0.02, w


def test_wall_scores_can_fail(computed):
    """The scorer is not a rubber stamp: shifted or turned walls do not match."""
    scan, result = computed("apartment", 0)
    doc = plan_document(result)
    p = np.asarray(doc["transform"]) @ np.asarray(scan.truth["transform"])
    truth = mapped_truth_walls(p, scan.truth)
    shifted = [dict(w, start=np.add(w["start"], np.multiply(w["normal"], 0.15)).tolist(), end=np.add(w["end"], np.multiply(w["normal"], 0.15)).tolist()) for w in doc["walls"]]
    assert wall_scores(shifted, truth)["f1"] < 0.2
    flipped = [dict(w, normal=(-np.asarray(w["normal"])).tolist()) for w in doc["walls"]]
    assert wall_scores(flipped, truth)["f1"] < 0.2


def test_upper_part_of_a_double_height_wall_is_a_wall():
    """A story-1 wall in the plane of a story-0 wall, scanned only up to 1 m above its floor (a
    void whose walls the scanner saw from the gallery), is still a wall of story 1: it continues
    the wall below. A wall of story 1 cut the same way with nothing below it is furniture."""
    from meshplan.synthetic import SynthParams, generate

    scan = generate(SynthParams(preset="multistory", seed=0, holes=False))
    truth = scan.truth
    walls = truth["walls"]

    def plane(w):
        n = np.asarray(w["normal"])
        return tuple(np.round(n, 3)), round(float(n @ w["start"]), 2)

    lower = {plane(w) for w in walls if w["story"] == 0}
    upper = [i for i, w in enumerate(walls) if w["story"] == 1 and plane(w) in lower and abs(np.subtract(w["end"], w["start"])).max() > 2.0]
    assert upper, "the preset has no story-1 wall above a story-0 wall"
    target = upper[0]
    # heights of the face centroids in the truth frame
    to_truth = np.linalg.inv(np.asarray(truth["transform"]))
    c = scan.mesh.face_centroids @ to_truth[:3, :3].T + to_truth[:3, 3]
    floor1 = truth["stories"][1]["floor"]
    drop = (scan.face_walls == target) & (c[:, 1] > floor1 + 1.0)
    mesh = scan.mesh.submesh(np.flatnonzero(~drop))
    stats = LoadStats("cut", "obj", "m", 1.0, 1, mesh.n_vertices, mesh.n_faces, 0, 0, 0, mesh.n_vertices, mesh.n_faces)
    result = compute(mesh, stats, scan.annotations, RunOptions())
    p = result.transform @ np.asarray(truth["transform"])
    t = mapped_truth_walls(p, truth)[target]
    doc = plan_document(result)
    found = [w for w in doc["walls"] if w["story"] == 1]
    assert wall_scores(found, [t])["recall"] == 1.0


def test_walls_face_into_rooms_and_reach_floor_to_ceiling(computed):
    scan, result = computed("apartment", 1)
    walls, st = result.walls, result.orientation.stories[0]
    assert np.all(walls.bottom < st.floor + 0.5) and np.all(walls.top > st.ceiling - 0.3)
    # the flat-wall mesh: two triangles per rectangle, normals = wall normals
    m = walls.mesh()
    assert m.n_faces == 2 * len(walls)
    # first triangles of every wall, then second triangles: both face the wall's normal
    w = len(walls)
    assert np.allclose(m.face_normals[:w, [0, 2]], walls.normal, atol=1e-9)
    assert np.allclose(m.face_normals[w:, [0, 2]], walls.normal, atol=1e-9)
    assert m.area == pytest.approx(float(np.sum(walls.length * (walls.top - walls.bottom))))
    # with the openings cut out, the model loses exactly their area
    holes = result.openings.holes()
    cut = walls.mesh(holes=holes)
    lost = sum((min(h[3], walls.top[i]) - max(h[2], walls.bottom[i])) * (h[1] - h[0]) for i, hs in holes.items() for h in hs)
    assert m.area - cut.area == pytest.approx(lost, rel=1e-6)


def test_pen_and_ink_slices_of_a_box_room_reproduce_its_walls():
    v, f = box_room(5.0, 4.0, 2.6, cell=0.1)
    mesh = Mesh(v, f)
    stats = LoadStats("box", "obj", "m", 1.0, 1, mesh.n_vertices, mesh.n_faces, 0, 0, 0, mesh.n_vertices, mesh.n_faces)
    opts = RunOptions.from_kwargs(up="+y")
    result = compute(mesh, stats, __import__("meshplan").geometry.Annotations(), opts)
    seg = result.stories[0].pen_and_ink.slices.segments
    assert len(seg) > 0
    # walls in the plan frame: the box turned onto the axes; every slice point lies on one
    pts = seg.reshape(-1, 2)
    xs, zs = pts[:, 0], pts[:, 1]
    x0, x1, z0, z1 = xs.min(), xs.max(), zs.min(), zs.max()
    assert sorted([x1 - x0, z1 - z0]) == pytest.approx([4.0, 5.0], abs=0.01)
    d = np.minimum.reduce([np.abs(xs - x0), np.abs(xs - x1), np.abs(zs - z0), np.abs(zs - z1)])
    assert d.max() < 0.01
    # 101 planes, floor and ceiling removed: each inner plane cuts the full perimeter
    levels = result.stories[0].pen_and_ink.slices.level
    for i in (1, 50, 99):
        s = seg[levels == i]
        assert np.linalg.norm(s[:, 1] - s[:, 0], axis=1).sum() == pytest.approx(18.0, abs=0.05)


def test_slicing_is_vectorized_over_planes_and_triangles():
    rng = np.random.default_rng(0)
    tri = rng.uniform(0, 3, size=(2000, 3, 3))
    h = plane_heights(0.0, 3.0, 100)
    s = slice_mesh(tri, h)
    # every segment end lies on its plane's triangle and is at that height in 3D
    for k in rng.choice(len(s), 50, replace=False):
        t = tri[s.face[k]]
        y = h[s.level[k]]
        assert t[:, 1].min() <= y <= t[:, 1].max()


def test_chained_slice_segments_cover_every_segment_once():
    """The DXF's slice polylines: a box room cut between two grid rows gives one closed loop,
    and the chains hold exactly the segments of the cut."""
    from meshplan.slicing import chain_segments

    v, f = box_room(5.0, 4.0, 2.6, cell=0.1)
    segs = slice_mesh(v[f], np.array([1.25])).segments
    chains = chain_segments(segs[np.random.default_rng(1).permutation(len(segs))])
    assert len(chains) == 1 and np.allclose(chains[0][0], chains[0][-1])  # one closed ring
    assert sum(len(c) - 1 for c in chains) == len(segs)
    ring = chains[0]
    assert np.isclose(np.abs(np.sum(ring[:-1, 0] * ring[1:, 1] - ring[1:, 0] * ring[:-1, 1])) / 2, 20.0)
    # an open chain, a T junction and a lone segment stay apart, each segment used once
    extra = np.array([[[10, 0], [11, 0]], [[11, 0], [12, 0]], [[11, 0], [11, 1]], [[20, 0], [21, 1]]], float)
    chains = chain_segments(extra)
    assert sum(len(c) - 1 for c in chains) == 4 and len(chains) == 4


def test_plan_json_validates_against_its_schema(computed):
    import jsonschema

    _, result = computed("multistory", 1)
    doc = plan_document(result)
    doc["timings"] = {"total": 1.0}
    jsonschema.validate(doc, plan_schema())
    assert len(doc["stories"]) == 2
    assert {w["story"] for w in doc["walls"]} == {0, 1}
    # contract: the transform is rigid and maps input to plan
    m = np.asarray(doc["transform"])
    assert np.allclose(m[:3, :3] @ m[:3, :3].T, np.eye(3), atol=1e-5)
    assert np.linalg.det(m[:3, :3]) == pytest.approx(1.0, abs=1e-5)


def test_annotations_follow_the_mesh(computed):
    scan, result = computed("apartment", 2)
    p = result.transform @ np.asarray(scan.truth["transform"])
    truth = {a["label"]: a for a in scan.truth["annotations"]}
    for label, pos, d in zip(result.annotations.labels, result.annotations.positions, result.annotations.directions):
        expected = p[:3, :3] @ truth[label]["position"] + p[:3, 3]
        assert np.linalg.norm(pos - expected) < 1e-6
        assert np.linalg.norm(d - p[:3, :3] @ truth[label]["direction"]) < 1e-6


def test_files_are_written_and_open(tmp_path):
    import ezdxf
    import trimesh

    from meshplan import run
    from meshplan.export.synth import write_synthetic
    from meshplan.synthetic import SynthParams, generate

    scan = generate(SynthParams(preset="apartment", seed=3, triangle_size_m=(0.08, 0.14)))
    path = write_synthetic(scan, tmp_path / "scan", "ply")
    result = run(path, annotations=tmp_path / "scan" / "annotations.json", output=tmp_path / "out", ifc=False)
    out = tmp_path / "out"
    names = {p.name for p in out.iterdir()}
    for n in ("plan.json", "oriented.glb", "story-0.glb", "levels.png", "normals.png", "flat-walls-0.glb", "wall-segments-0.png"):
        assert n in names
    for style in ("pen-and-ink", "drafting"):
        for ext in ("svg", "png", "pdf"):
            assert f"{style}-0.{ext}" in names
    assert (out / "drafting-0.pdf").read_bytes().startswith(b"%PDF")
    assert b"<svg" in (out / "drafting-0.svg").read_bytes()[:500]
    doc = json.loads((out / "plan.json").read_text())
    assert set(doc["timings"]) >= {"load", "orient", "walls", "slice_draw", "write", "total"}
    # DXF: named layers, metres, walls where plan.json says
    dxf = ezdxf.readfile(out / "drafting-0.dxf")
    assert dxf.units == ezdxf.units.M
    layers = {layer.dxf.name for layer in dxf.layers}
    assert {"WALLS", "SLICES", "ANNOTATIONS", "TEXT", "ROOMS", "DIMENSIONS"} <= layers
    lines = [e for e in dxf.modelspace() if e.dxftype() == "LINE" and e.dxf.layer == "WALLS"]
    long_lines = [e for e in lines if (e.dxf.end - e.dxf.start).magnitude > 0.3]
    assert long_lines
    starts = np.array([w["start"] for w in doc["walls"]])
    ends = np.array([w["end"] for w in doc["walls"]])
    for e in long_lines:  # wall lines (split at openings) lie on plan.json walls
        mid = np.array([(e.dxf.start.x + e.dxf.end.x) / 2, -(e.dxf.start.y + e.dxf.end.y) / 2])
        d = ends - starts
        t = np.clip(np.einsum("ij,ij->i", mid - starts, d) / np.einsum("ij,ij->i", d, d), 0, 1)
        assert np.min(np.linalg.norm(starts + t[:, None] * d - mid, axis=1)) < 0.01
    dims = [e for e in dxf.modelspace() if e.dxftype() == "DIMENSION"]
    assert len(dims) >= 4 * len(doc["rooms"]) - 2
    texts = " ".join(e.text for e in dxf.modelspace() if e.dxftype() == "MTEXT")
    for room in doc["rooms"]:
        assert room["label"] in texts
    # GLB models open and sit in the plan frame
    story = trimesh.load(out / "story-0.glb", force="mesh")
    top = doc["stories"][0]["ceiling"]
    assert story.bounds[1][1] < top + 0.2
    assert len(result.rooms) == len(doc["rooms"]) > 0


def test_a_glb_holds_the_scan_and_shares_the_markers_repeated_shapes():
    """export.glb writes the binary chunk from the arrays themselves: the scan comes back as it
    was (float32 positions), and accessors equal byte for byte are written once (every marker's
    sphere has the same triangles), whatever their order."""
    import io
    import json
    import struct

    import trimesh

    from meshplan.export.glb import glb_bytes
    from meshplan.geometry import Annotations, Mesh

    rng = np.random.default_rng(2)
    v = rng.normal(size=(5000, 3))
    f = rng.integers(0, len(v), size=(9000, 3))
    ann = Annotations(("t1", "s1", "s2"), ("thermostat", "sensor", "sensor"), rng.normal(size=(3, 3)), np.eye(3))
    data = glb_bytes(Mesh(v, f), ann, "scan")
    (length,) = struct.unpack("<I", data[12:16])
    doc = json.loads(data[20 : 20 + length])
    assert len(data) % 4 == 0 and struct.unpack("<I", data[8:12])[0] == len(data)
    indices = [m["primitives"][0]["indices"] for m in doc["meshes"]]
    assert len(indices) == 4 and len(set(indices[1:])) == 1 and indices[0] != indices[1]  # the markers share theirs
    assert all(view["byteOffset"] % 4 == 0 for view in doc["bufferViews"])
    scene = trimesh.load(io.BytesIO(data), file_type="glb", process=False)
    scan = scene.geometry["scan"]
    np.testing.assert_array_equal(scan.faces, f)
    np.testing.assert_array_equal(scan.vertices, v.astype(np.float32))

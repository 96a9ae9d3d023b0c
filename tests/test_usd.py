"""USD/USDZ in (issue 14): stages flattened into world coordinates, metres per unit and up axis
applied; RoomPlan exports read as their PLY conversions are, and their parametric elements used
as such (doors and windows from their boxes, furniture kept out of the walls)."""

from __future__ import annotations

import json
import sys
from dataclasses import replace

import numpy as np
import pytest

import meshplan
from conftest import SCANS, SHARED
from meshplan.cli import main
from meshplan.evaluate import evaluate
from meshplan.evaluate_real import evaluate_real, map_truth_xz, truth_to_plan_matrix
from meshplan.export import plan_document
from meshplan.export.planjson import plan_schema
from meshplan.geometry import Annotations
from meshplan.io import load_mesh
from meshplan.io.usd import Z_UP_TO_Y_UP, read_usd
from meshplan.options import RunOptions
from meshplan.pipeline import compute
from meshplan.synthetic import SynthParams, generate

pxr = pytest.importorskip("pxr")
from pxr import Gf, Usd, UsdGeom, Vt  # noqa: E402


def write_stage(path, vertices, faces, *, meters_per_unit=1.0, up="Y", cube_at=None):
    """A stage holding one Mesh (``vertices`` in the stage's units and axes) and, optionally, a
    2-unit cube under an Xform turned 90 degrees about the up axis and moved to ``cube_at``."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageMetersPerUnit(stage, meters_per_unit)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z if up == "Z" else UsdGeom.Tokens.y)
    root = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(root.GetPrim())
    mesh = UsdGeom.Mesh.Define(stage, "/World/Scan")
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(vertices, np.float32)))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(faces), 3, np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.asarray(faces, np.int32).reshape(-1)))
    if cube_at is not None:
        x = UsdGeom.Xform.Define(stage, "/World/Group")
        x.AddTranslateOp().Set(Gf.Vec3d(*cube_at))
        x.AddRotateZOp().Set(90.0) if up == "Z" else x.AddRotateYOp().Set(90.0)
        UsdGeom.Cube.Define(stage, "/World/Group/Box").CreateSizeAttr(2.0)
    stage.GetRootLayer().Save()


def test_transforms_units_and_up_axis(tmp_path):
    tri = np.array([[0.0, 0.0, 0.0], [100.0, 0.0, 0.0], [0.0, 0.0, 100.0]])
    write_stage(tmp_path / "z.usda", tri, [[0, 1, 2]], meters_per_unit=0.01, up="Z", cube_at=(500.0, 0.0, 0.0))
    scene = read_usd(tmp_path / "z.usda")
    assert scene.meters_per_unit == pytest.approx(0.01) and scene.up_axis == "Z"
    assert scene.parts == {"Mesh": 1, "Cube": 1} and len(scene.faces) == 1 + 12
    assert np.allclose(scene.vertices[:3], tri @ Z_UP_TO_Y_UP)  # z up in the file, y up read
    cube = scene.vertices[3:]
    assert np.allclose(cube.mean(axis=0), np.array([500.0, 0.0, 0.0]) @ Z_UP_TO_Y_UP) and np.allclose(np.ptp(cube, axis=0), 2.0)
    loaded = load_mesh(tmp_path / "z.usda")
    assert loaded.stats.format == "usda" and loaded.stats.scale_to_m == pytest.approx(0.01)
    assert np.allclose(loaded.mesh.bounds()[1], [5.01, 1.0, 0.01], atol=1e-6)  # centimetres read as metres


@pytest.mark.slow
def test_synthetic_apartment_as_a_z_up_usd_in_centimetres(tmp_path):
    scan = generate(SynthParams(preset="apartment", seed=1))
    # the scan's y-up metres written as a z-up stage in centimetres: read back, it is the scan
    write_stage(tmp_path / "apartment.usdc", 100.0 * scan.mesh.vertices @ Z_UP_TO_Y_UP.T, scan.mesh.faces, meters_per_unit=0.01, up="Z")
    result = meshplan.run(tmp_path / "apartment.usdc")
    report = evaluate(plan_document(result), scan.truth)
    heights = [h["error_m"] for h in report["heights"]]
    rooms = report["rooms"]
    errors = [abs(r["error_pct"]) for r in rooms["rows"] if r["error_pct"] is not None]
    assert report["gravity_error_deg"] <= 0.2 and max(heights) <= 0.02
    assert report["walls"]["f1"] >= 0.9 and rooms["found"] == rooms["true_rooms"] and np.median(errors) <= 1.0


def test_missing_usd_core_is_one_line_before_any_work(tmp_path, monkeypatch, capsys):
    path = tmp_path / "room.usdz"
    path.write_bytes(b"PK not read")
    monkeypatch.setitem(sys.modules, "pxr", None)
    out = tmp_path / "out"
    assert main(["run", str(path), "-o", str(out)]) == 2
    assert capsys.readouterr().err.strip() == "error: reading USD needs usd-core; pip install 'meshplan[usd]'"
    assert not out.exists()


ROOMPLAN = ["roomplan_sekhar_small_room", "roomplan_sekhar_library"]


def roomplan_files(name):
    usdz, ply = SCANS / f"{name}.usdz", SCANS / f"{name}_parametric.ply"
    truth = SHARED / "truth" / f"{name}_parametric.truth.json"
    if not (usdz.is_file() and ply.is_file() and truth.is_file()):
        pytest.skip(f"{name} not available (../shared/scans, ../shared/truth)")
    return usdz, ply, json.loads(truth.read_text())


def plain_stats(stats):
    """The same stats without the parametric elements: what a PLY conversion gives."""
    return replace(stats, parametric=None)


@pytest.mark.realscan
@pytest.mark.parametrize("name", ROOMPLAN)
def test_roomplan_usdz_reads_as_its_ply_conversion(name):
    usdz, ply, _ = roomplan_files(name)
    scene = read_usd(usdz)
    assert scene.roomplan and scene.parts["wall"] >= 9 and scene.parts["floor"] == 1
    a, b = load_mesh(usdz), load_mesh(ply)
    assert a.stats.faces == b.stats.faces
    assert np.allclose(np.sort(a.mesh.vertices, axis=0), np.sort(b.mesh.vertices, axis=0), atol=1e-5)
    # the boxes: every part but the floor, each box's corners among the mesh's vertices
    el = a.stats.parametric
    assert el is not None and b.stats.parametric is None
    assert el.counts() == {k: n for k, n in scene.parts.items() if k != "floor"} == scene.parametric.counts()
    assert np.allclose(el.corners, scene.parametric.corners)
    assert all(el.kind[h] == "wall" for h in el.host[el.of_kind("door", "window", "opening")])
    # without the elements the pipeline makes of the USDZ exactly what it makes of the PLY
    ra = compute(a.mesh, plain_stats(a.stats), Annotations(), RunOptions())
    rb = meshplan.run(ply)
    da, db = plan_document(ra), plan_document(rb)
    assert len(da["walls"]) == len(db["walls"])
    assert np.allclose(sorted(w["length"] for w in da["walls"]), sorted(w["length"] for w in db["walls"]), atol=0.01)
    assert np.allclose(sorted(r["area"] for r in da["rooms"]), sorted(r["area"] for r in db["rooms"]), rtol=0.01)
    assert {o["source"] for o in db["openings"]} <= {"detected"} and "parametric" not in db["input"]


@pytest.mark.realscan
@pytest.mark.parametrize("name", ROOMPLAN)
def test_roomplan_elements_give_the_truths_openings_and_keep_furniture_out_of_the_walls(name):
    usdz, ply, truth = roomplan_files(name)
    da, db = plan_document(meshplan.run(usdz)), plan_document(meshplan.run(ply))
    import jsonschema

    jsonschema.validate(da, plan_schema())
    counts = da["input"]["parametric"]["elements"]
    assert da["input"]["parametric"]["kind"] == "roomplan" and counts["wall"] >= 9
    ea, eb = evaluate_real(da, truth)["total"], evaluate_real(db, truth)["total"]
    # every door and window of the truth, from the boxes: where, how wide, how high
    m = truth_to_plan_matrix(da, truth)
    for key, kind in (("doors", "door"), ("windows", "window")):
        assert ea[key]["truth"] == len(truth[key]) and ea[key]["matched"] == ea[key]["truth"] == ea[key]["found"], key
        found = [o for o in da["openings"] if o["kind"] == kind]
        assert all(o["source"] == "parametric" and o["confidence"]["level"] == "high" for o in found)
        for t in truth[key]:
            centre = map_truth_xz(m, [t["center"]], 0.5 * (t["bottom"] + t["top"]))[0]
            o = min(found, key=lambda o: float(np.linalg.norm(np.subtract(o["center"], centre))))
            assert np.linalg.norm(np.subtract(o["center"], centre)) <= 0.02
            assert o["width"] == pytest.approx(t["width"], abs=0.005)
            assert o["bottom"] == pytest.approx(t["bottom"], abs=0.005) and o["top"] == pytest.approx(t["top"], abs=0.005)
            assert (o["sill"] is None) == (kind == "door") and (kind == "door" or o["sill"] == pytest.approx(t["bottom"], abs=0.005))
    # the furniture's fronts are no walls; the walls are those of the PLY where no furniture is
    assert ea["walls"]["furniture_length_m"] <= 0.01 and ea["walls"]["precision"] >= 0.999
    assert ea["walls"]["f1"] >= eb["walls"]["f1"] - 1e-9 and ea["walls"]["recall"] >= eb["walls"]["recall"] - 0.02
    assert len(da["rooms"]) == len(db["rooms"])
    assert np.allclose(sorted(r["area"] for r in da["rooms"]), sorted(r["area"] for r in db["rooms"]), rtol=0.01)
    assert ea["rooms"]["matched"] == eb["rooms"]["matched"] >= 1


def write_roomplan(path, *, meters_per_unit, up):
    """A RoomPlan-like stage (RoomPlan's prim layout) of a 5 x 4 m room, walls 2.5 m high: a door
    (0.9 x 2.1 m) in Wall0, listed again as an opening in a duplicate piece of Wall0, a window
    (1.2 x 1.0 m, sill 0.9 m) in Wall1, a pass-through opening (0.8 x 0.6 m, sill 1.0 m) in
    Wall3, a 2.4 m tall bookcase (Storage0, 1.5 x 0.45 m) against Wall2 and a table; in the given
    units and up axis. Returns the openings' sizes in metres, narrowest first."""
    k = 1.0 / meters_per_unit
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageMetersPerUnit(stage, meters_per_unit)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z if up == "Z" else UsdGeom.Tokens.y)
    stage.SetDefaultPrim(UsdGeom.Xform.Define(stage, "/Room").GetPrim())

    def to_stage(p, at=(0.31, -1.37, 0.23)):  # room frame (y up) to the stage's axes, in its units
        p = (np.asarray(p, float) + at) * k
        return p @ Z_UP_TO_Y_UP.T if up == "Z" else p

    def box(prim_path, centre, size, yaw_deg=0.0):
        """A RoomPlan box: a unit Cube scaled to (width, height, depth) and turned about up."""
        parent = prim_path.rsplit("/", 1)[0]
        for i in range(2, len(parent.split("/")) + 1):
            UsdGeom.Xform.Define(stage, "/".join(parent.split("/")[:i]))
        cube = UsdGeom.Cube.Define(stage, prim_path)
        cube.CreateSizeAttr(1.0)
        cube.AddTranslateOp().Set(Gf.Vec3d(*to_stage(centre)))
        (cube.AddRotateZOp() if up == "Z" else cube.AddRotateYOp()).Set(yaw_deg)
        w, h, d = np.asarray(size, float) * k
        cube.AddScaleOp().Set(Gf.Vec3f(w, d, h) if up == "Z" else Gf.Vec3f(w, h, d))

    H, thin = 2.5, 1e-4
    arch = "/Room/Parametric_grp/Arch_grp"
    # walls: Wall0 along x at z = 0, Wall1 along z at x = 5, Wall2 along x at z = 4, Wall3 at x = 0
    box(f"{arch}/Wall_0_grp/Wall0", (2.5, H / 2, 0.0), (5.0, H, thin))
    box(f"{arch}/Wall_1_grp/Wall1", (5.0, H / 2, 2.0), (4.0, H, thin), 90.0)
    box(f"{arch}/Wall_2_grp/Wall2", (2.5, H / 2, 4.0), (5.0, H, thin))
    box(f"{arch}/Wall_3_grp/Wall3", (0.0, H / 2, 2.0), (4.0, H, thin), 90.0)
    box(f"{arch}/Wall_0_grp/Door0", (1.5, 1.05, 0.0), (0.9, 2.1, 5e-4))
    box(f"{arch}/Wall_1_grp/Window0", (5.0, 1.4, 2.5), (1.2, 1.0, 5e-4), 90.0)
    # RoomPlan lists a doorway twice where it doubled a wall: a piece of Wall0 again, with an
    # opening where the door is; and a pass-through (an opening with a sill) in Wall3
    box(f"{arch}/Wall_4_grp/Wall4", (1.5, H / 2, 0.0), (1.2, H, thin))
    box(f"{arch}/Wall_4_grp/Opening0", (1.5, 1.05, 0.0), (0.9, 2.1, 5e-4))
    box(f"{arch}/Wall_3_grp/Opening1", (0.0, 1.3, 2.0), (0.8, 0.6, 5e-4), 90.0)
    box("/Room/Parametric_grp/Object_grp/Storage_grp/Storage0", (2.5, 1.2, 4.0 - 0.225), (1.5, 2.4, 0.45))
    box("/Room/Parametric_grp/Object_grp/Table_grp/Table0", (2.5, 0.375, 2.0), (1.6, 0.75, 0.8))
    UsdGeom.Xform.Define(stage, "/Room/Parametric_grp/Floor_grp")
    floor = UsdGeom.Mesh.Define(stage, "/Room/Parametric_grp/Floor_grp/Floor0")
    corners = to_stage([[0.0, 0.0, 0.0], [5.0, 0.0, 0.0], [5.0, 0.0, 4.0], [0.0, 0.0, 4.0]])
    floor.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(corners.astype(np.float32)))
    floor.CreateFaceVertexCountsAttr(Vt.IntArray([4]))
    floor.CreateFaceVertexIndicesAttr(Vt.IntArray([0, 3, 2, 1] if up == "Y" else [0, 1, 2, 3]))
    # RoomPlan models no ceiling; a ceiling mesh beside its groups (as another capture would add)
    # gives the thin walls' paired faces no chance to pass for a floor and a ceiling
    ceiling = UsdGeom.Mesh.Define(stage, "/Room/Ceiling")
    ceiling.CreatePointsAttr(Vt.Vec3fArray.FromNumpy((corners + to_stage([0.0, H, 0.0], at=(0.0, 0.0, 0.0))).astype(np.float32)))
    ceiling.CreateFaceVertexCountsAttr(Vt.IntArray([4]))
    ceiling.CreateFaceVertexIndicesAttr(Vt.IntArray([0, 1, 2, 3] if up == "Y" else [0, 3, 2, 1]))
    # RoomPlan's section: the room's label at its centre; an unidentified one beside it
    UsdGeom.Xform.Define(stage, "/Room/Section_grp")
    for name, centre in (("bedroom0", (2.5, 1.2, 2.0)), ("unidentified0", (2.0, 1.2, 2.5))):
        UsdGeom.Xform.Define(stage, f"/Room/Section_grp/{name}").AddTranslateOp().Set(Gf.Vec3d(*to_stage(centre)))
    stage.GetRootLayer().Save()
    return {
        "door": [{"width": 0.9, "bottom": 0.0, "top": 2.1}],
        "window": [{"width": 0.8, "bottom": 1.0, "top": 1.6}, {"width": 1.2, "bottom": 0.9, "top": 1.9}],
    }


@pytest.mark.slow
@pytest.mark.parametrize("meters_per_unit, up", [(1.0, "Y"), (0.01, "Z")])
def test_roomplan_like_stage_in_any_units_and_up_axis(tmp_path, meters_per_unit, up):
    path = tmp_path / "room.usda"
    truth = write_roomplan(path, meters_per_unit=meters_per_unit, up=up)
    scene = read_usd(path)
    assert scene.roomplan and scene.parametric.counts() == {"door": 1, "opening": 2, "storage": 1, "table": 1, "wall": 5, "window": 1}
    loaded = load_mesh(path)
    # read Y-up in metres whatever the stage's axes and units: +y is up (refused otherwise)
    options = RunOptions.from_kwargs(up="+y")
    with_elements = compute(loaded.mesh, loaded.stats, Annotations(), options)
    without = compute(loaded.mesh, plain_stats(loaded.stats), Annotations(), options)
    doc, plain = plan_document(with_elements), plan_document(without)
    assert doc["input"]["parametric"]["elements"]["wall"] == 5 and doc["input"]["scale_to_m"] == pytest.approx(meters_per_unit)
    # one door (the doorway listed twice is one), two windows (the pass-through is one), each
    # the size of its box
    for kind in ("door", "window"):
        found = sorted((o for o in doc["openings"] if o["kind"] == kind), key=lambda o: o["width"])
        assert len(found) == len(truth[kind]) and all(o["source"] == "parametric" for o in found)
        for o, t in zip(found, truth[kind]):
            assert o["width"] == pytest.approx(t["width"], abs=0.005)
            assert o["bottom"] == pytest.approx(t["bottom"], abs=0.005) and o["top"] == pytest.approx(t["top"], abs=0.005)
    # the bookcase (in the plan frame): walls wholly within its footprint are its front and sides
    el = loaded.stats.parametric
    (k,) = el.of_kind("storage")
    t = with_elements.transform
    corners = (el.corners[k] * loaded.stats.scale_to_m) @ t[:3, :3].T + t[:3, 3]
    lo, hi = corners[:, [0, 2]].min(axis=0) - 0.02, corners[:, [0, 2]].max(axis=0) + 0.02

    def on_bookcase(d):
        ends = np.array([[w["start"], w["end"]] for w in d["walls"]])
        return int(np.sum(np.all((ends >= lo) & (ends <= hi), axis=(1, 2))))

    # with RoomPlan's element list, and without it (a PLY conversion: the bookcase is still a
    # closed 12-triangle box thicker than a wall, meshplan.walls.solids), no wall on the bookcase
    assert on_bookcase(doc) == 0 and on_bookcase(plain) == 0
    # the room: 5 x 4 m, the bookcase's floor included
    assert len(doc["rooms"]) == 1 and doc["rooms"][0]["area"] == pytest.approx(20.0, rel=0.005)
    # named by RoomPlan's section (read in the stage's units and axes), not "Room 1"
    assert el.section_label == ("bedroom", "unidentified")
    assert doc["rooms"][0]["name"] == "Bedroom" and doc["rooms"][0]["label"] == "Bedroom"
    assert plain["rooms"][0]["name"] == "Room 1"
    assert plain["rooms"][0]["area"] == pytest.approx(doc["rooms"][0]["area"], rel=0.005)

"""USD/USDZ in (issue 14): stages flattened into world coordinates, metres per unit and up axis
applied; RoomPlan exports read as their PLY conversions are."""

from __future__ import annotations

import sys

import numpy as np
import pytest

import meshplan
from conftest import SCANS
from meshplan.cli import main
from meshplan.evaluate import evaluate
from meshplan.export import plan_document
from meshplan.io import load_mesh
from meshplan.io.usd import Z_UP_TO_Y_UP, read_usd
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


@pytest.mark.realscan
@pytest.mark.parametrize("name", ["roomplan_sekhar_small_room", "roomplan_sekhar_library"])
def test_roomplan_usdz_reads_as_its_ply_conversion(name):
    usdz, ply = SCANS / f"{name}.usdz", SCANS / f"{name}_parametric.ply"
    if not (usdz.is_file() and ply.is_file()):
        pytest.skip(f"{name} not available (../shared/scans)")
    scene = read_usd(usdz)
    assert scene.roomplan and scene.parts["wall"] >= 9 and scene.parts["floor"] == 1
    a, b = load_mesh(usdz), load_mesh(ply)
    assert a.stats.faces == b.stats.faces
    assert np.allclose(np.sort(a.mesh.vertices, axis=0), np.sort(b.mesh.vertices, axis=0), atol=1e-5)
    ra, rb = meshplan.run(usdz), meshplan.run(ply)
    da, db = plan_document(ra), plan_document(rb)
    assert len(da["walls"]) == len(db["walls"])
    assert np.allclose(sorted(w["length"] for w in da["walls"]), sorted(w["length"] for w in db["walls"]), atol=0.01)
    assert np.allclose(sorted(r["area"] for r in da["rooms"]), sorted(r["area"] for r in db["rooms"]), rtol=0.01)

"""The energy model (issue 13): gbXML 7.03 (``--gbxml``), read by its real consumer, OpenStudio,
which validates it against the gbXML schema, reads it into a model and translates that to
EnergyPlus (``--idf``, ``--osm``); the envelope summary in plan.json, the report and the summary.

Every synthetic preset and every real scan with rooms (``realscan``): the gbXML validates,
OpenStudio reads it and writes the IDF with no error, each space's floor area and volume are the
plan's (within 1 %), the exterior walls and windows are the envelope summary's, and every wall
two rooms share is one surface with both spaces.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from shapely.geometry import Point

from conftest import SCANS, real_scan_names
from meshplan.export.gbxml import energy_model, envelope_summary, gbxml_bytes
from meshplan.options import ExportParams

openstudio = pytest.importorskip("openstudio")

from meshplan.export.energy import openstudio_model, require_openstudio, translate_idf  # noqa: E402

NS = {"g": "http://www.gbxml.org/schema"}
#: Relative tolerance of areas and volumes (the issue's 1 %).
AREA_RTOL = 0.01

PRESETS = [
    ("room", 1, {}),
    ("apartment", 1, {}),
    ("office", 1, {}),
    ("multistory", 1, {"stories": 2}),
    ("multistory", 2, {"stories": 3}),
]


def _validate(data: bytes, tmp_path) -> None:
    require_openstudio()
    path = tmp_path / "model.xml"
    path.write_bytes(data)
    v = openstudio.XMLValidator.gbxmlValidator()
    assert v.validate(openstudio.path(str(path))), [str(e.logMessage()) for e in v.errors()][:3]


def _newell(points: np.ndarray) -> np.ndarray:
    p = np.asarray(points, float)
    n = np.cross(p, np.roll(p, -1, axis=0)).sum(axis=0)
    return n / np.linalg.norm(n)


def _facing_length(a, b, reach: float, step: float = 0.02) -> float:
    """Length of ``a``'s outline from which ``b`` lies straight across (along the outward normal,
    within ``reach``), sampled every ``step``: the stretch of wall the two rooms share, measured
    without the edge pairing the exporter uses."""
    from shapely.geometry import LineString
    from shapely.geometry.polygon import orient

    ring = np.asarray(orient(a, 1.0).exterior.coords)  # counter-clockwise in (x, z): outside on the right
    total = 0.0
    for p, q in zip(ring[:-1], ring[1:]):
        v = q - p
        n_len = np.hypot(*v)
        if n_len < step:
            continue
        d = v / n_len
        out = np.array([d[1], -d[0]])
        for t in np.arange(step / 2, n_len, step):
            x = p + t * d
            if LineString([x + 0.002 * out, x + reach * out]).intersects(b):
                total += step
    return total


def check_energy_model(result, tmp_path) -> dict:
    """Every check of the issue on one result; returns the measured numbers."""
    em = energy_model(result)
    data = gbxml_bytes(result, em)
    _validate(data, tmp_path)
    env = envelope_summary(result, 6, em)
    heights = {s.index: s.height for s in result.orientation.stories}

    # gbXML itself: one Space and one Zone per room, closed shells, shared walls with two spaces
    root = ET.fromstring(data)
    spaces = root.findall(".//g:Space", NS)
    assert len(spaces) == len(result.rooms) == len(root.findall("g:Zone", NS))
    for el in spaces:
        assert el.find("g:ShellGeometry/g:ClosedShell", NS) is not None and el.find("g:PlanarGeometry", NS) is not None
    for el in root.findall(".//g:Surface", NS):
        adj = el.findall("g:AdjacentSpaceId", NS)
        assert 1 <= len(adj) <= 2
        if len(adj) == 2:
            assert el.get("surfaceType") in ("InteriorWall", "Ceiling") and adj[0].get("spaceIdRef") != adj[1].get("spaceIdRef")

    # orientation: right-hand normals point away from the first space (counter-clockwise seen
    # from outside), walls vertical, floors down, ceilings and roofs up
    for s in em.surfaces:
        n = _newell(s.polygon)
        assert np.allclose(n, s.normal, atol=1e-3), (s.id, s.kind, n, s.normal)
        first = em.spaces[s.spaces[0]]
        if s.is_wall:
            mid = s.polygon.mean(axis=0)[:2]
            assert not first.polygon.contains(Point(mid + 0.002 * n[:2])) and first.polygon.buffer(1e-4).contains(Point(mid - 0.002 * n[:2])), s.id
        elif s.kind in ("SlabOnGrade", "InteriorFloor", "ExposedFloor"):
            assert n[2] < -0.999
        else:
            assert n[2] > 0.999
        for op in s.openings:
            assert np.allclose(_newell(op.polygon), n, atol=1e-3)
            if not op.clipped:
                i = op.index
                assert op.width == pytest.approx(result.openings.width[i], abs=1e-6)
                assert op.height == pytest.approx(result.openings.top[i] - result.openings.bottom[i], abs=1e-6)

    # shared walls: every pair of rooms facing each other across a wall has one surface
    max_gap = result.options.walls.max_wall_thickness_m + 0.1
    shared: dict[tuple[int, int], float] = {}
    for s in em.surfaces:
        if s.kind == "InteriorWall" and len(s.spaces) == 2:
            a, b = sorted(em.spaces[k].room for k in s.spaces)
            shared[(a, b)] = shared.get((a, b), 0.0) + s.area / (heights[s.story])
    rooms = result.rooms
    for a in range(len(rooms)):
        for b in range(a + 1, len(rooms)):
            ra, rb = rooms[a], rooms[b]
            if ra.story != rb.story or ra.polygon.distance(rb.polygon) > max_gap:
                continue
            facing = _facing_length(ra.polygon, rb.polygon, 0.8 * max_gap)
            if facing > 0.3:  # a real stretch of wall, not two corners touching
                assert (a, b) in shared, (ra.label, rb.label, facing)
                assert shared[(a, b)] >= 0.9 * facing - 0.05, (ra.label, rb.label, facing, shared[(a, b)])

    # OpenStudio's model: spaces, areas, volumes, the envelope, adjacencies
    m = openstudio_model(result, em, data)
    idf = translate_idf(result, m, em)
    assert idf.count("\nZone,") == len(result.rooms)
    by_label = {sp.label: sp for sp in em.spaces}
    os_spaces = m.getSpaces()
    assert len(os_spaces) == len(result.rooms)
    worst = 0.0
    for sp in os_spaces:
        mine = by_label[sp.nameString()]
        room = result.rooms[mine.room]
        worst = max(worst, abs(sp.floorArea() - room.area) / room.area)
        assert sp.floorArea() == pytest.approx(room.area, rel=AREA_RTOL), sp.nameString()
        assert sp.volume() == pytest.approx(room.area * heights[room.story], rel=AREA_RTOL), sp.nameString()
    walls = [s for s in m.getSurfaces() if s.surfaceType() == "Wall" and s.outsideBoundaryCondition() == "Outdoors"]
    windows = [w for s in walls for w in s.subSurfaces() if "Window" in w.subSurfaceType()]
    total = env["total"]
    assert len(walls) == total["walls"] == sum(s.kind == "ExteriorWall" for s in em.surfaces)
    assert sum(s.grossArea() for s in walls) == pytest.approx(total["wall_area"], rel=AREA_RTOL, abs=1e-6)
    assert len(windows) == total["windows"]
    assert sum(w.grossArea() for w in windows) == pytest.approx(total["window_area"], rel=AREA_RTOL, abs=1e-6)
    pairs = {}
    for s in m.getSurfaces():
        other = s.adjacentSurface()
        if other.is_initialized():
            assert other.get().adjacentSurface().get().handle() == s.handle()
            key = tuple(sorted((s.space().get().nameString(), other.get().space().get().nameString())))
            pairs[key] = pairs.get(key, 0) + 1
    mine_pairs = {}
    for s in em.surfaces:
        if len(s.spaces) == 2:
            key = tuple(sorted(em.spaces[k].label for k in s.spaces))
            mine_pairs[key] = mine_pairs.get(key, 0) + 2  # both copies
    assert pairs == mine_pairs
    return {"spaces": len(os_spaces), "worst_area_error": worst, "walls": total["walls"], "windows": total["windows"], "shared": len(shared)}


@pytest.mark.parametrize("preset,seed,kw", PRESETS, ids=[f"{p}-{s}-{kw.get('stories', 1)}" for p, s, kw in PRESETS])
def test_presets_energy_model(computed, preset, seed, kw, tmp_path):
    _, result = computed(preset, seed, **kw)
    numbers = check_energy_model(result, tmp_path)
    assert numbers["spaces"] == len(result.rooms) > 0
    assert numbers["walls"] > 0
    if preset != "room":
        assert numbers["shared"] > 0


def test_a_results_energy_model_is_made_once(computed, monkeypatch):
    # plan.json, the report page and the summary each ask for it: one model per result, made
    # anew for another result (here: another north), and gone with its result
    import gc

    from meshplan.export import gbxml

    _, result = computed("apartment", 1)
    made: list[object] = []
    real = gbxml._energy_model
    monkeypatch.setattr(gbxml, "_energy_model", lambda r: made.append(r) or real(r))
    first = energy_model(result)
    assert energy_model(result) is first and envelope_summary(result) == envelope_summary(result)
    turned = dataclasses.replace(result, options=dataclasses.replace(result.options, export=ExportParams(north_deg=90.0)))
    assert energy_model(turned) is not first and energy_model(turned).north_deg != first.north_deg
    assert made[-1] is turned and len(made) <= 2  # the first result's, unless made before
    assert turned in gbxml._MODELS and result in gbxml._MODELS
    held = len(gbxml._MODELS)
    del turned
    made.clear()
    gc.collect()
    assert len(gbxml._MODELS) == held - 1 and result in gbxml._MODELS


def test_envelope_orientations_follow_north(computed):
    _, result = computed("apartment", 1)
    base = envelope_summary(result)
    turned = envelope_summary(dataclasses.replace(result, options=dataclasses.replace(result.options, export=ExportParams(north_deg=90.0))))
    by = {o["orientation"]: o for o in base["orientations"]}
    by90 = {o["orientation"]: o for o in turned["orientations"]}
    # up the page faces east now: the north facade is the east one, the east the south one
    for a, b in (("N", "E"), ("E", "S"), ("S", "W"), ("W", "N")):
        assert by90[b]["wall_area"] == pytest.approx(by[a]["wall_area"])
        assert by90[b]["windows"] == by[a]["windows"]
    assert base["total"]["wwr"] == pytest.approx(base["total"]["window_area"] / base["total"]["wall_area"], abs=1e-4)
    assert sum(f["wall_area"] for f in base["facades"]) == pytest.approx(base["total"]["wall_area"], abs=1e-3)


@pytest.mark.slow
def test_gbxml_is_deterministic_on_a_300k_face_apartment():
    """Byte-identical twice on a large scan (its speed, under 0.2 s, is checked by make bench)."""
    from meshplan.io import LoadStats
    from meshplan.options import RunOptions
    from meshplan.pipeline import compute
    from meshplan.synthetic import SynthParams, generate

    scan = generate(SynthParams(preset="apartment", seed=3, target_faces=300_000))
    mesh = scan.mesh
    assert mesh.n_faces > 250_000
    stats = LoadStats("synthetic", "obj", "m", 1.0, 1, mesh.n_vertices, mesh.n_faces, 0, 0, 0, mesh.n_vertices, mesh.n_faces)
    result = compute(mesh, stats, scan.annotations, RunOptions())
    data = gbxml_bytes(result)
    assert data.startswith(b"<?xml") and gbxml_bytes(result) == data


def _write_room(tmp_path):
    from meshplan.export.synth import write_synthetic
    from meshplan.synthetic import SynthParams, generate

    return write_synthetic(generate(SynthParams(preset="room", seed=1, triangle_size_m=(0.12, 0.2))), tmp_path / "room")


@pytest.mark.slow
def test_run_writes_gbxml_idf_osm_and_the_envelope(tmp_path):
    import jsonschema

    import meshplan
    from meshplan.export import plan_schema

    scan = _write_room(tmp_path)
    out = tmp_path / "out"
    result = meshplan.run(scan, annotations=scan.parent / "annotations.json", output=out, gbxml=True, idf=True, osm=True, site_lat_deg=48.14, north_deg=30.0)
    for name in ("model.gbxml", "model.idf", "model.osm"):
        assert name in result.files and (out / name).stat().st_size > 1000
    doc = json.loads((out / "plan.json").read_text())
    jsonschema.validate(doc, plan_schema())
    assert doc["envelope"]["north_deg"] == 30.0 and doc["envelope"]["site"]["latitude_deg"] == 48.14
    assert doc["envelope"]["total"]["walls"] > 0
    idf = (out / "model.idf").read_text()
    assert "! meshplan energy model" in idf and "thermostat T1" in idf and "48.14" in idf
    m = openstudio.model.Model.load(openstudio.path(str(out / "model.osm")))
    assert m.is_initialized() and len(m.get().getThermalZones()) == len(result.rooms)
    assert m.get().getBuilding().northAxis() == pytest.approx(30.0)
    report = (out / "report.html").read_text()
    assert 'id="envelope-0"' in report and "window-to-wall ratio" in report
    gb = ET.fromstring((out / "model.gbxml").read_bytes())
    params = gb.findall(".//g:Space/g:AnalysisParameter", NS)
    assert any(p.get("parameterType") == "ThermostatLocation" and p.find("g:Name", NS).text == "T1" for p in params)
    assert gb.find(".//g:Location/g:CADModelAzimuth", NS).text.startswith("30.")


@pytest.mark.slow
def test_cli_json_summary_has_the_envelope(tmp_path):
    from meshplan.cli import main

    scan = _write_room(tmp_path)
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        status = main(["run", str(scan), "-o", str(tmp_path / "out"), "--gbxml", "--north-deg", "90", "--json"])
    assert status == 0
    summary = json.loads(buf.getvalue())
    assert summary["envelope"]["north_deg"] == 90.0
    assert {o["orientation"] for o in summary["envelope"]["orientations"]} == {"N", "E", "S", "W"}
    assert (tmp_path / "out" / "model.gbxml").is_file() and not (tmp_path / "out" / "model.idf").exists()


@pytest.mark.parametrize("flag,module,extra", [("--idf", "openstudio", "energy"), ("--osm", "openstudio", "energy"), ("--ifc", "ifcopenshell", "ifc")])
def test_missing_extra_is_refused_before_any_work(tmp_path, monkeypatch, capsys, flag, module, extra):
    import importlib.util

    import meshplan
    from meshplan.cli import main
    from meshplan.errors import MeshplanError

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a, **k: None if name == module else real(name, *a, **k))
    missing = tmp_path / "no-such-scan.obj"  # the extra is checked before the scan is looked for
    with pytest.raises(MeshplanError, match=rf"needs {module}.*meshplan\[{extra}\]"):
        meshplan.run(missing, output=tmp_path / "out", **{flag[2:]: True})
    assert main(["run", str(missing), flag]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and f"meshplan[{extra}]" in err[0]
    assert not (tmp_path / "out").exists()


@pytest.mark.realscan
@pytest.mark.slow
@pytest.mark.parametrize("name", real_scan_names((".ply", ".obj", ".glb", ".stl", ".off")) or ["(no real scans)"])
def test_real_scans_energy_model(name, tmp_path):
    import meshplan

    path = SCANS / name
    if not path.is_file():
        pytest.skip("real scans not available (../shared/scans)")
    try:
        result = meshplan.run(path)
    except meshplan.MeshplanError as exc:  # a fragment with no floor: nothing to model
        pytest.skip(f"{name}: {exc}")
    if not result.rooms:
        pytest.skip(f"{name}: no rooms")
    numbers = check_energy_model(result, tmp_path)
    assert numbers["worst_area_error"] < AREA_RTOL
    assert math.isfinite(numbers["worst_area_error"])

"""Building elements (issue 16): physical walls meeting at their centre lines, openings once each
on their wall with the rooms they connect and their leaf, room types and numbers with rooms.json,
confidences, and the IFC model with the annotations as the elements of their kind."""

from __future__ import annotations

import json

import jsonschema
import numpy as np
import pytest
from shapely.geometry import LineString, Point, Polygon

from meshplan.evaluate import _map_xz, truth_to_plan
from meshplan.export.planjson import plan_document, plan_schema
from meshplan.options import RunOptions
from meshplan.plan.elements import (
    MarkedDrafting,
    load_room_edits,
    mark_low_confidence,
    reading_order,
    rooms_document,
)
from meshplan.walls.physical import JOIN_REACH_M


def _truth_thickness(walls, truth, p) -> list[tuple[float, float]]:
    """``(measured, true)`` thickness of every wall measured from both faces, the truth's from
    the truth faces on either side of its centre line."""
    faces = [
        {"story": w["story"], "start": s, "end": e, "normal": n}
        for w in truth["walls"]
        for (s, e), n in [(_map_xz(p, [w["start"], w["end"]], 0.5 * (w["bottom"] + w["top"])), _map_dir(p, w["normal"]))]
    ]
    out = []
    for w in walls:
        if not w.paired:
            continue
        c = 0.5 * (np.asarray(w.start) + np.asarray(w.end))
        d, n = w.direction, w.normal
        span = sorted(((np.asarray(w.start) - c) @ d, (np.asarray(w.end) - c) @ d))
        sides = []
        for f in faces:
            if f["story"] != w.story or abs(f["normal"] @ n) < 0.99:
                continue
            off = float((0.5 * (f["start"] + f["end"]) - c) @ n)
            fs = sorted(((f["start"] - c) @ d, (f["end"] - c) @ d))
            if abs(off) <= w.thickness / 2 + 0.08 and min(span[1], fs[1]) - max(span[0], fs[0]) > 0.3:
                sides.append(off)
        pos, neg = [o for o in sides if o > 0], [o for o in sides if o < 0]
        if pos and neg:
            out.append((w.thickness, float(np.median(pos) - np.median(neg))))
    return out


def _map_dir(p, d):
    v = p[:3, :3] @ np.array([d[0], 0.0, d[1]])
    return v[[0, 2]] / np.linalg.norm(v[[0, 2]])


@pytest.mark.parametrize("preset", ["apartment", "office"])
def test_physical_walls_thickness_and_junctions(computed, preset):
    scan, result = computed(preset, 1)
    p = truth_to_plan({"transform": result.transform.tolist()}, scan.truth)
    pairs = _truth_thickness(result.physical_walls, scan.truth, p)
    assert len(pairs) >= 4
    err = np.abs([a - b for a, b in pairs])
    assert np.median(err) < 0.02  # within 2 cm where both faces were scanned
    # every face in exactly one wall
    faces = sorted(f for w in result.physical_walls for f in w.faces)
    assert faces == list(range(len(result.walls)))
    # the centre lines end on each other: no gap at a corner or a T junction
    walls = result.physical_walls
    gaps = []
    for i, w in enumerate(walls):
        for end in (w.start, w.end):
            near = [
                LineString([v.start, v.end]).distance(Point(end))
                for j, v in enumerate(walls)
                if j != i and v.story == w.story and abs(float(w.direction @ v.direction)) < 0.9
            ]
            if near and min(near) < JOIN_REACH_M:
                gaps.append(min(near))
    assert len(gaps) >= 8 and max(gaps) < 1e-3


def test_plan_json_elements(computed):
    from dataclasses import replace

    scan, result = computed("apartment", 1)
    doc = plan_document(replace(result, timings={**result.timings, "total": 1.0}))  # as written
    jsonschema.validate(doc, plan_schema())
    pw = doc["physical_walls"]
    assert len(pw) == len(result.physical_walls)
    for k, w in enumerate(pw):
        assert w["confidence"]["level"] in ("high", "medium", "low") and w["confidence"]["reason"]
        for f in w["faces"]:
            assert doc["walls"][f]["physical_wall"] == k
        assert w["height"] > 2.0 and w["thickness"] > 0
    exterior = [w for w in pw if w["exterior"]]
    assert len(exterior) == 4  # the four outer walls of the apartment
    # seen from inside only: the default thickness, or the depth of their openings' reveals where
    # deeper (plan.elements.reveal_thickness)
    default = RunOptions().walls.default_wall_thickness_m
    for w in exterior:
        if w["thickness_measured"]:
            assert default < w["thickness"] <= 0.6 and "reveals" in w["confidence"]["reason"], w
        else:
            assert w["thickness"] == pytest.approx(default), w
    # doors and windows once each, as many as the truth's labels
    labels = {(o["kind"], o["label"]) for o in scan.truth["openings"]}
    for kind in ("door", "window"):
        assert sum(o["kind"] == kind for o in doc["openings"]) == sum(k == kind for k, _ in labels)
        assert result.summary()[kind + "s"] == sum(k == kind for k, _ in labels)
    for o in doc["openings"]:
        assert o["confidence"]["level"] in ("high", "medium", "low")
        assert 0 <= o["physical_wall"] < len(pw)
        assert o["wall"] in pw[o["physical_wall"]]["faces"]
        if o["kind"] == "window":
            assert 0.7 < o["sill"] < 1.1 and "outside" in o["connects"]
        else:
            assert o["sill"] is None and o["swing"] is None  # no leaves in this scan
            assert all(c is not None for c in o["connects"])
    interior = [o for o in doc["openings"] if o["kind"] == "door" and "outside" not in o["connects"]]
    assert interior and all(o["confidence"]["level"] == "high" for o in interior)
    for r in doc["rooms"]:
        assert r["confidence"]["level"] == {"walls": "high", "extension": "medium", "floor": "low"}[r["closed_by"]]


def test_rooms_numbered_typed_and_renamed(computed):
    from meshplan.io import LoadStats
    from meshplan.options import RunOptions
    from meshplan.pipeline import compute

    scan, result = computed("apartment", 1)
    rooms = result.rooms
    assert [r.number for r in rooms] == [f"0.{k + 1:02d}" for k in range(len(rooms))]
    assert reading_order(rooms) == list(range(len(rooms)))
    # the hall (long, narrow, six doors) is a corridor; the others rooms
    p = truth_to_plan({"transform": result.transform.tolist()}, scan.truth)
    hall = next(t for t in scan.truth["rooms"] if t["kind"] == "hall")
    tp = Polygon(_map_xz(p, hall["polygon"], 0.0))
    best = max(rooms, key=lambda r: r.polygon.intersection(tp).area / r.polygon.union(tp).area)
    assert best.type == "corridor"
    assert all(r.type == "room" for r in rooms if r is not best)
    # a rooms.json edited by hand carries over to a re-run, matched by position
    doc = rooms_document(rooms)
    doc["rooms"][0]["name"] = "Living room"
    doc["rooms"][0]["number"] = "0.10"
    doc["rooms"][1].update(name="Pantry", type="closet")
    for item in doc["rooms"]:  # what the user kept: a centre, moved a little
        item.pop("polygon")
        item["center"] = [item["center"][0] + 0.05, item["center"][1] - 0.05]
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "rooms.json"
        path.write_text(json.dumps(doc))
        edits = load_room_edits(path)
    m = scan.mesh
    stats = LoadStats("synthetic", "obj", "m", 1.0, 1, m.n_vertices, m.n_faces, 0, 0, 0, m.n_vertices, m.n_faces)
    again = compute(m, stats, scan.annotations, RunOptions(), room_edits=edits)
    by_name = {r.name: r for r in again.rooms}
    assert by_name["Living room"].number == "0.10" and by_name["Living room"].label == "Living room"
    assert by_name["Living room"].polygon.equals_exact(rooms[0].polygon, 1e-9)
    assert by_name["Pantry"].type == "closet" and by_name["Pantry"].polygon.equals_exact(rooms[1].polygon, 1e-9)
    assert sorted(r.number for r in again.rooms) == sorted(["0.10", *[r.number for r in rooms[1:]]])
    assert plan_document(again)["rooms"][-1]["name"] == "Living room"  # listed by number


def test_bad_rooms_file(tmp_path):
    from meshplan.errors import InputError

    bad = tmp_path / "rooms.json"
    bad.write_text('{"rooms": [{"story": 0, "name": "x"}]}')
    with pytest.raises(InputError, match="neither a polygon nor a center"):
        load_room_edits(bad)
    bad.write_text('{"rooms": [{"story": 0, "center": [1, 2], "type": "garage"}]}')
    with pytest.raises(InputError, match="type"):
        load_room_edits(bad)


def test_door_leaves(computed):
    scan, result = computed("apartment", 1, open_doors=True)
    doc = plan_document(result)
    p = truth_to_plan(doc, scan.truth)
    comp = [Polygon(r["polygon"]) for r in doc["rooms"]]
    seen = 0
    for o in scan.truth["openings"]:
        if o["kind"] != "door" or "leaf" not in o or o["leaf"]["angle_deg"] < 20:
            continue
        hinge = _map_xz(p, [o["leaf"]["hinge"]], 1.0)[0]
        found = [d for d in doc["openings"] if d["kind"] == "door" and d["swing"] and np.linalg.norm(np.subtract(d["swing"]["hinge"], hinge)) < 0.3]
        assert found, o["label"]
        seen += 1
        room = o["leaf"]["room"]
        if room is None:
            assert found[0]["opens_to"] == "outside"
        else:
            tp = Polygon(_map_xz(p, next(t["polygon"] for t in scan.truth["rooms"] if t["label"] == room), 0.0))
            assert found[0]["opens_to"] == int(np.argmax([c.intersection(tp).area / c.union(tp).area for c in comp]))
    assert seen >= 5


def test_low_confidence_dashed(computed):
    from dataclasses import replace

    from meshplan.render import make_sheet
    from meshplan.render.plans import LOW_CONFIDENCE_COLOR, drafting_figure

    _, result = computed("apartment", 1)
    sp = result.stories[0]
    assert isinstance(sp.drafting, MarkedDrafting)
    # the first wall made low-confidence: its cut is drawn apart, the rest stays solid
    walls = (replace(result.physical_walls[0], confidence="low"), *result.physical_walls[1:])
    marked = mark_low_confidence(sp.drafting, result.walls, walls, result.rooms, result.openings, result.opening_elements)
    assert len(marked.dashed) > 0 and len(marked.dashed) + len(marked.solid) == len(sp.drafting.slices.segments)
    o = result.orientation
    sheet = make_sheet(result.mesh.face_centroids[o.face_story == 0][:, [0, 2]], result.options.render)
    fig = drafting_figure(marked, sp.annotations, sheet, result.options.render)
    from matplotlib.colors import to_hex

    dashed = [c for c in fig.axes[0].collections if any(to_hex(x) == LOW_CONFIDENCE_COLOR for x in c.get_edgecolor())]
    assert dashed and any(ls[1] is not None for c in dashed for ls in c.get_linestyle())


def test_sensor_types():
    from meshplan.export.ifc import sensor_type

    assert sensor_type("CO2 kitchen") == "CO2SENSOR"
    assert sensor_type("Temp 3") == "TEMPERATURESENSOR"
    assert sensor_type("humidity-bath") == "HUMIDITYSENSOR"
    assert sensor_type("PIR hall") == "MOVEMENTSENSOR"
    assert sensor_type("S1") == "NOTDEFINED"
    assert sensor_type("Contemporary") == "NOTDEFINED"  # a word that only starts like one


@pytest.mark.parametrize("preset", ["apartment", "multistory"])
def test_ifc_elements_and_annotations(computed, tmp_path, preset):
    pytest.importorskip("ifcopenshell")
    import ifcopenshell
    import ifcopenshell.util.element as element
    import ifcopenshell.util.placement as placement
    import ifcopenshell.validate

    from meshplan.export.ifc import ifc_bytes

    scan, result = computed(preset, 1)
    path = tmp_path / "model.ifc"
    path.write_bytes(ifc_bytes(result))
    f = ifcopenshell.open(str(path))
    log = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(f, log, express_rules=True)
    assert log.statements == []
    truth = scan.truth
    labels = {(o["kind"], o["label"]) for o in truth["openings"]}
    assert len(f.by_type("IfcDoor")) == sum(k == "door" for k, _ in labels) == sum(k == "door" for k in result.openings.kind)
    assert len(f.by_type("IfcWindow")) == sum(k == "window" for k, _ in labels)
    assert len(f.by_type("IfcOpeningElement")) == len(result.openings)
    assert len(f.by_type("IfcUnitaryControlElement")) == sum(a["kind"] == "thermostat" for a in truth["annotations"])
    marks = {}
    for e in f.by_type("IfcProduct"):
        ps = element.get_psets(e).get("meshplan_annotation")
        if ps:
            marks[ps["label"]] = (e, ps)
    p = truth_to_plan({"transform": result.transform.tolist()}, truth)
    klass = {"sensor": "IfcSensor", "thermostat": "IfcUnitaryControlElement", "door": "IfcDoor", "window": "IfcWindow", "other": "IfcAnnotation"}
    rooms_t = [(t["story"], Polygon(_map_xz(p, t["polygon"], truth["stories"][t["story"]]["floor"]))) for t in truth["rooms"]]
    for a in truth["annotations"]:
        e, ps = marks[a["label"]]
        assert e.is_a(klass[a["kind"]]), a["label"]
        q = p @ np.r_[a["position"], 1.0]
        want = np.array([q[0], -q[2], q[1]])  # IFC is z-up
        assert np.linalg.norm(np.array([ps["x"], ps["y"], ps["z"]]) - want) < 0.01
        if a["kind"] in ("door", "window"):
            assert ps["detected"] and e.FillsVoids  # the detected element, in its wall
        else:
            assert np.linalg.norm(placement.get_local_placement(e.ObjectPlacement)[:3, 3] - want) < 0.01
        if a["kind"] == "thermostat":
            parts = [r.RelatedObjects for r in e.IsDecomposedBy]
            assert any(s.is_a("IfcSensor") and s.PredefinedType == "TEMPERATURESENSOR" for group in parts for s in group)
        # in (or referenced by) the space of the truth room its probe points into
        story = next(k for k, s in enumerate(truth["stories"]) if s["floor"] - 0.3 <= a["position"][1] <= s["ceiling"] + 0.1)
        d = p[:3, :3] @ np.asarray(a.get("direction", [0.0, 0.0, 0.0]), float)
        spot = Point(q[0] + 0.3 * d[0], q[2] + 0.3 * d[2])
        tp = next(poly for s, poly in rooms_t if s == story and poly.buffer(0.05).contains(spot))
        iou = [r.polygon.intersection(tp).area / r.polygon.union(tp).area if r.story == story else 0.0 for r in result.rooms]
        number = result.rooms[int(np.argmax(iou))].number
        spaces = [r.RelatingStructure for r in e.ContainedInStructure or ()] + [r.RelatingStructure for r in e.ReferencedInStructures or ()]
        assert any(s.is_a("IfcSpace") and s.Name == number for s in spaces), a["label"]


def test_opening_confidence_reads_the_detector_limits(computed):
    """An opening's size is judged by the detector's own limits (``PlanParams``), so a user's
    ``--set door_width_m`` reaches the confidence: with doors limited to 0.6-0.7 m, every door
    found wider than that (plus the stated margin) is low-confidence for its size."""
    from dataclasses import replace

    from meshplan.plan.elements import ODD_WIDTH_MARGIN, opening_elements

    _, result = computed("apartment", 1)
    o = result.openings
    args = (o, result.walls, result.physical_walls, result.rooms, result.orientation.stories, result.mesh)
    plain = opening_elements(*args, result.options.plan)
    narrow = opening_elements(*args, replace(result.options.plan, door_width_m=(0.6, 0.7)))
    widths = o.u_max - o.u_min
    doors = [i for i, k in enumerate(o.kind) if k == "door"]
    assert doors and not any("unusual size" in plain[i].confidence_reason for i in doors)
    wide = [i for i in doors if widths[i] > 0.7 * (1 + ODD_WIDTH_MARGIN)]
    assert wide
    for i in doors:
        assert ("unusual size" in narrow[i].confidence_reason) == (i in wide)
        assert (narrow[i].confidence == "low") or i not in wide


def test_a_room_wrapping_round_a_walls_end_does_not_make_it_interior():
    """An outer wall whose end pokes into the corner of an L-shaped room has that room within a
    probe's slack of its outer side only near the end: the wall is still exterior (RoomPlan's
    walls overshoot their corners: 13 of the library's 39 were drawn as interior walls)."""
    from meshplan.orient import Story
    from meshplan.plan.elements import SIDE_PROBE_M, SIDE_SLACK_M, wall_elements
    from meshplan.plan.rooms import Room
    from meshplan.walls.physical import PhysicalWall

    # the wall along x at z = 0 (body 0.15 m, centre line at z = 0): its normal (0, -1), so
    # rooms[0] lie at z < 0; the room lies at z > 0 and wraps round the east end from x = 3.75
    wall = PhysicalWall(0, (0,), (0.0, 0.0), (4.0, 0.0), 0.15, False, 0.0, 2.5)
    assert np.allclose(wall.normal, [0.0, -1.0])
    room = Polygon([(0, 0.075), (3.75, 0.075), (3.75, -3), (6, -3), (6, 3), (0, 3)])
    (behind,) = shapely_points_near(room, wall, SIDE_PROBE_M, SIDE_SLACK_M)
    assert behind, "the test's room must come within a probe's slack behind the wall near its end"
    story = Story(0, 0.0, 2.5, True, -np.inf, np.inf)
    (out,) = wall_elements((wall,), (Room(0, "Room 1", room, "walls"),), (story,), 0.1, 0.3)
    assert out.rooms == ((), (0,)) and out.exterior


def shapely_points_near(room, wall, probe_m, slack_m):
    """Whether the probe behind the wall at 90 % of its length lies within the slack of ``room``."""
    a, b = np.asarray(wall.start), np.asarray(wall.end)
    p = a + 0.9 * (b - a) + (wall.thickness / 2 + probe_m) * wall.normal
    return (room.distance(Point(p)) <= slack_m,)

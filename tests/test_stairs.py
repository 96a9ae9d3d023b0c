"""Stairs (issue 16 item 4): found from the stepped horizontal surfaces as elements with their
footprint, direction, risers, rise, going and the stories they connect; the stairwell a room of
type ``stair``; the void over each in the upper floor; exported to plan.json (with its schema)
and IFC (IfcStair with its flights); scored by ``meshplan evaluate``."""

from __future__ import annotations

from dataclasses import replace
from functools import cache

import jsonschema
import numpy as np
import pytest
from shapely.geometry import Polygon

from conftest import real_scan
from meshplan.evaluate import evaluate, format_report
from meshplan.export.planjson import plan_document, plan_schema
from meshplan.geometry import Mesh
from meshplan.orient.stories import Story
from meshplan.plan.stairs import RISE_M, find_stairs
from meshplan.synthetic import generate
from meshplan.synthetic.truth import stair_footprint


def _stories(truth: dict) -> tuple[Story, ...]:
    return tuple(Story(s["index"], s["floor"], s["ceiling"], True, s["floor"] - 0.1, s["ceiling"] + 0.1) for s in truth["stories"])


@cache
def _truth_frame(stories: int, seed: int):
    s = generate(preset="multistory", seed=seed, stories=stories)
    return s.truth, find_stairs(s.truth_mesh(), _stories(s.truth))


@pytest.mark.parametrize("stories", [2, 3])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_every_multistory_stair_found(stories, seed):
    truth, found = _truth_frame(stories, seed)
    assert len(truth["stairs"]) == stories - 1
    assert len(found) == len(truth["stairs"])  # and nothing else: no furniture is a stair
    for t in truth["stairs"]:
        poly = Polygon(stair_footprint(t))
        s = next(s for s in found if s.story == t["story"])
        assert s.to_story == t["story"] + 1
        iou = s.footprint.intersection(poly).area / s.footprint.union(poly).area
        assert iou >= 0.8
        assert s.risers == t["risers"]
        assert abs(s.rise - t["rise"]) < 0.01
        assert abs(s.going - t["going"]) < 0.03
        assert abs(s.width - t["width"]) < 0.1
        assert s.shape == "U" and len(s.flights) == 2
        # the drawing's data: treads bottom first, a landing between the flights, the arrow
        heights = [tr.height for tr in s.treads]
        assert heights == sorted(heights) and sum(tr.landing for tr in s.treads) == 1
        assert len(s.walking_line) == len(s.treads)
        d = np.asarray(s.flights[0].direction) @ np.asarray(s.flights[1].direction)
        assert d < -0.9  # a U: the second flight comes back
        assert s.void is not None and s.void.intersection(poly).area >= 0.8 * poly.area


@pytest.mark.parametrize(("preset", "seed"), [("apartment", 1), ("apartment", 2), ("apartment", 3), ("office", 1), ("office", 2)])
def test_no_stairs_in_furniture(preset, seed):
    s = generate(preset=preset, seed=seed)
    assert find_stairs(s.truth_mesh(), _stories(s.truth)) == ()


def _treads_mesh(rects: list[tuple[float, float, float, float, float]]) -> Mesh:
    """Tread tops ``(x0, x1, z0, z1, y)``, each a grid of small up-facing triangles."""
    verts, faces = [], []
    for x0, x1, z0, z1, y in rects:
        u, v = np.meshgrid(np.linspace(x0, x1, 6), np.linspace(z0, z1, 6), indexing="ij")
        base = sum(len(a) for a in verts)
        verts.append(np.c_[u.ravel(), np.full(u.size, y), v.ravel()])
        i, j = np.meshgrid(np.arange(5), np.arange(5), indexing="ij")
        k = (i * 6 + j).ravel() + base
        # counter-clockwise seen from +y: normals up
        faces.append(np.c_[k, k + 1, k + 7])
        faces.append(np.c_[k, k + 7, k + 6])
    return Mesh(np.vstack(verts), np.vstack(faces))


STORIES = (Story(0, 0.0, 2.5, True, -0.1, 2.6), Story(1, 2.7, 5.2, True, 2.6, 5.3))


def test_straight_and_l_stairs():
    rise, going, width = 0.18, 0.27, 0.9
    straight = [(k * going, (k + 1) * going, 0.0, width, (k + 1) * rise) for k in range(14)]
    (s,) = find_stairs(_treads_mesh(straight), STORIES)
    assert (s.shape, s.story, s.to_story, s.risers) == ("straight", 0, 1, 15)
    assert s.rise == pytest.approx(0.18, abs=1e-6) and s.going == pytest.approx(going, abs=0.01)
    assert np.allclose(s.direction, (1.0, 0.0), atol=0.01)
    assert s.confidence == "high"
    assert s.footprint.area == pytest.approx(14 * going * width, rel=0.02)
    assert s.cut_height == pytest.approx(1.2)
    # an L: 7 treads along +x, a square landing, 6 treads along +z
    ell = [(k * going, (k + 1) * going, 0.0, width, (k + 1) * rise) for k in range(7)]
    ell.append((7 * going, 7 * going + width, 0.0, width, 8 * rise))
    ell += [(7 * going, 7 * going + width, width + k * going, width + (k + 1) * going, (9 + k) * rise) for k in range(6)]
    (s,) = find_stairs(_treads_mesh(ell), STORIES)
    assert (s.shape, s.risers, len(s.flights)) == ("L", 15, 2)
    assert [t.landing for t in s.treads].count(True) == 1
    # the L's empty quarter is not in its footprint
    assert not s.footprint.contains(Polygon([(0.3, 1.2), (1.5, 1.2), (1.5, 2.0), (0.3, 2.0)]).centroid)


def test_irregular_tops_are_not_stairs():
    # a bookcase's shelves: regular, but stacked
    shelves = [(0.0, 0.9, 0.0, 0.3, 0.18 * (k + 1)) for k in range(8)]
    assert find_stairs(_treads_mesh(shelves), STORIES) == ()
    # seat, armrest, back of a sofa: a rise apart, but no regular going along one direction
    sofa = [(0.0, 0.6, 0.0, 0.6, 0.42), (0.6, 0.8, 0.0, 0.6, 0.6), (0.0, 0.8, 0.6, 0.8, 0.8)]
    assert find_stairs(_treads_mesh(sofa), STORIES) == ()
    assert RISE_M == (0.14, 0.22)


def test_pipeline_plan_json_ifc_and_evaluate(computed, tmp_path):
    scan, result = computed("multistory", 1)
    assert len(result.stairs) == 1
    s = result.stairs[0]
    assert (s.story, s.to_story, s.risers) == (0, 1, scan.truth["stairs"][0]["risers"])
    assert abs(s.rise - scan.truth["stairs"][0]["rise"]) < 0.01
    # the stairwell is a room of type stair, and so is the room it arrives in
    assert s.room is not None and result.rooms[s.room].type == "stair"
    assert result.rooms[s.room].type_reason.startswith("holds a stair")
    assert s.room_above is not None and result.rooms[s.room_above].story == 1 and result.rooms[s.room_above].type == "stair"
    doc = plan_document(replace(result, timings={**result.timings, "total": 1.0}))
    jsonschema.validate(doc, plan_schema())
    (st,) = doc["stairs"]
    assert st["risers"] == s.risers and st["to_story"] == 1 and len(st["treads"]) == len(s.treads)
    (void,) = doc["voids"]
    assert void["story"] == 1 and void["stair"] == 0 and void["area"] > 0.8 * st["area"]
    report = evaluate(doc, scan.truth)
    sc = report["stairs"]
    assert (sc["found"], sc["true"], sc["risers_exact"], sc["connects"]) == (1, 1, 1, 1)
    assert sc["precision"] == 1.0 and sc["min_iou"] >= 0.8 and sc["max_rise_error_m"] < 0.01
    assert "stairs   1/1 found" in format_report(report)
    pytest.importorskip("ifcopenshell")
    import ifcopenshell

    from meshplan.export.ifc import ifc_bytes

    path = tmp_path / "model.ifc"
    path.write_bytes(ifc_bytes(result))
    model = ifcopenshell.open(str(path))
    (stair,) = model.by_type("IfcStair")
    assert stair.PredefinedType == "HALF_TURN_STAIR"
    flights = model.by_type("IfcStairFlight")
    assert len(flights) == 2 and sum(f.NumberOfRisers for f in flights) == s.risers
    assert len(model.by_type("IfcSlab")) == 1  # the landing
    assert stair.ContainedInStructure[0].RelatingStructure.Name == "Story 0"


def test_real_two_story_apartment_stair():
    import meshplan

    result = meshplan.run(real_scan("hl2_su_apartment_two_story.ply"))
    assert result.stairs, "the staircase of the two-story apartment is found"
    s = max(result.stairs, key=lambda x: len(x.treads))
    assert (s.story, s.to_story) == (0, 1)
    assert len(s.treads) >= 5 and RISE_M[0] <= s.rise <= RISE_M[1]
    story = result.orientation.stories
    assert s.risers == round((story[1].floor - story[0].floor) / s.rise)

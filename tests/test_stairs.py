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
from meshplan.plan.stairs import RISE_M, find_stairs, turned_pieces
from meshplan.synthetic import generate
from meshplan.synthetic.truth import stair_footprint


def _stories(truth: dict) -> tuple[Story, ...]:
    return tuple(Story(s["index"], s["floor"], s["ceiling"], True, s["floor"] - 0.1, s["ceiling"] + 0.1) for s in truth["stories"])


@cache
def _truth_frame(stories: int, seed: int):
    s = generate(preset="multistory", seed=seed, stories=stories)
    return s.truth, find_stairs(s.truth_mesh(), _stories(s.truth))


@pytest.mark.slow
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


@pytest.mark.slow
@pytest.mark.parametrize(("preset", "seed"), [("apartment", 1), ("apartment", 2), ("apartment", 3), ("office", 1), ("office", 2)])
def test_no_stairs_in_furniture(preset, seed):
    s = generate(preset=preset, seed=seed)
    assert find_stairs(s.truth_mesh(), _stories(s.truth)) == ()


def _treads_mesh(rects: list[tuple[float, float, float, float, float]], down: int = 0) -> Mesh:
    """Tread tops ``(x0, x1, z0, z1, y)``, each a grid of small up-facing triangles (the last
    ``down`` of them wound the other way: facing down)."""
    verts, faces = [], []
    for x0, x1, z0, z1, y in rects:
        u, v = np.meshgrid(np.linspace(x0, x1, 6), np.linspace(z0, z1, 6), indexing="ij")
        base = sum(len(a) for a in verts)
        verts.append(np.c_[u.ravel(), np.full(u.size, y), v.ravel()])
        i, j = np.meshgrid(np.arange(5), np.arange(5), indexing="ij")
        k = (i * 6 + j).ravel() + base
        # counter-clockwise seen from +y: normals up
        tri = np.r_[np.c_[k, k + 1, k + 7], np.c_[k, k + 7, k + 6]]
        faces.append(tri[:, ::-1] if len(faces) >= len(rects) - down else tri)
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


def test_a_u_stair_whose_upper_flight_was_turned_over_is_found_whole():
    """hl2_su_apartment's stair: the winding repair turns each connected piece of the mesh by
    its floors and ceilings, and the piece holding the upper flight (treads passing the lower
    story's ceiling height, which vote as a ceiling seen from the wrong side) was turned over.
    Found on up-facing faces alone, the stair stopped halfway (7 of 14 treads, low confidence,
    straight); its treads are treads whichever way they face."""
    rise, going, width = 0.18, 0.27, 0.9
    first = [(k * going, (k + 1) * going, 0.0, width, (k + 1) * rise) for k in range(7)]
    landing = [(7 * going, 7 * going + width, 0.0, 2 * width, 8 * rise)]
    second = [((6 - k) * going, (7 - k) * going, width, 2 * width, (9 + k) * rise) for k in range(6)]
    mesh = _treads_mesh(first + landing + second, down=len(second))
    (s,) = find_stairs(mesh, STORIES)
    assert (s.shape, s.story, s.to_story, s.risers, len(s.treads)) == ("U", 0, 1, 15, 14)
    assert s.confidence == "high"
    # the upper flight's faces (6 treads of 50 triangles), and they alone, are turned back
    # for the models; each tread is a piece of its own here
    turned = turned_pieces(mesh, (s,))
    assert np.array_equal(np.flatnonzero(turned), np.flatnonzero(mesh.face_normals[:, 1] < 0))
    assert turned.sum() == 6 * 50 and np.all(mesh.with_flipped(turned).face_normals[:, 1] > 0)
    # the upper flight alone, the lower one missing: no stair from one floor is made up
    assert find_stairs(_treads_mesh(second, down=len(second)), STORIES) == ()


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


@pytest.mark.slow
def test_real_two_story_apartment_stair():
    import meshplan

    result = meshplan.run(real_scan("hl2_su_apartment_two_story.ply"))
    assert result.stairs, "the staircase of the two-story apartment is found"
    s = max(result.stairs, key=lambda x: len(x.treads))
    assert (s.story, s.to_story) == (0, 1)
    assert len(s.treads) >= 5 and RISE_M[0] <= s.rise <= RISE_M[1]
    # a U (a dogleg): 10 risers to a landing at 1.85 m, one to the second landing, four to the
    # upper floor; its upper flight's piece of mesh turned over by the winding repair
    assert (s.shape, len(s.treads), s.confidence) == ("U", 14, "high")
    # and the piece of mesh holding its upper flight turned back: the treads face up in the
    # models (193 of its 311 tread faces faced down)
    faces = np.concatenate([t.faces for t in s.treads])
    assert np.mean(result.mesh.face_normals[faces, 1] > 0) > 0.95
    story = result.orientation.stories
    assert s.risers == round((story[1].floor - story[0].floor) / s.rise)


# --- drawing the stairs (issue 12 / 16: the symbol on both stories, DXF, IFC footprint) --------


def test_stair_symbol_of_a_straight_stair():
    """A straight flight of 14 treads, cut at 1.2 m: the risers below the cut solid and those
    above dashed on either side of the break line, the walking line from the first riser to the
    last with the arrow along the ascent; on the upper story every riser seen, no cut, the void."""
    from meshplan.plan.symbols import stair_symbols

    rise, going, width = 0.18, 0.27, 0.9
    straight = [(k * going, (k + 1) * going, 0.0, width, (k + 1) * rise) for k in range(14)]
    (s,) = find_stairs(_treads_mesh(straight), STORIES)
    (low,) = stair_symbols(0, (s,))
    assert low.role == "lower" and len(low.void) == 0
    # the cut meets the walking line between the 6th tread (1.08 m) and the 7th (1.26 m)
    cut_x = (5.5 + 0.12 / 0.18) * going
    slant = 0.35 * width / 2 + 0.06
    xs = lambda segs: np.asarray(segs)[:, :, 0]  # noqa: E731
    assert len(low.lines) and len(low.hidden)
    assert xs(low.lines).min() == pytest.approx(0.0, abs=0.02)  # the first riser
    assert np.all(xs(low.hidden) >= cut_x - slant - 1e-6)
    assert np.all(xs(low.lines) <= cut_x + slant + 1e-6)
    assert np.ptp(low.cut[:, 0]) > 0.1 and np.ptp(low.cut[:, 1]) >= width  # across the flight, slanted
    assert np.allclose(low.arrow, (1.0, 0.0), atol=0.02)
    assert low.walk[0][0] == pytest.approx(0.0, abs=0.02) and low.walk_hidden[-1][0] == pytest.approx(14 * going, abs=0.03)
    assert low.walk[-1][0] == pytest.approx(low.walk_hidden[0][0], abs=1e-6)  # one line, split at the cut
    assert "15 R 0.18 / 0.27" == low.text
    (up,) = stair_symbols(1, (s,))
    assert up.role == "upper" and len(up.hidden) == 0 and len(up.cut) == 0
    risers = [seg for seg in up.lines if abs(seg[0][0] - seg[1][0]) < 1e-6]
    assert len(risers) == 15  # 14 treads between 15 risers, all seen from above
    assert stair_symbols(2, (s,)) == ()


@pytest.mark.slow
def test_stairs_drawn_on_both_stories_and_exported(computed, tmp_path):
    """The multistory preset: the stair's symbol on the drafting sheets of both stories it
    connects (with its legend entries), on the DXF's STAIRS layer, and the IfcStair with its
    footprint, the IFC valid."""
    import io

    import ezdxf

    from meshplan.export.dxf import drafting_dxf
    from meshplan.plan.symbols import plan_symbols
    from meshplan.render import drafting_figure, make_sheet

    _, result = computed("multistory", 1)
    (stair,) = result.stairs
    for story, role in ((0, "lower"), (1, "upper")):
        sp = result.stories[story]
        symbols = plan_symbols(story, result.walls, result.openings, result.rooms, result.physical_walls, stairs=result.stairs)
        (sym,) = symbols.stairs
        assert sym.role == role
        if role == "lower":
            assert len(sym.cut) and len(sym.hidden) and len(sym.void) == 0
        else:
            assert len(sym.void) and len(sym.cross) == 2 and len(sym.hidden) == 0
            assert _polygon(sym.void).area == pytest.approx(stair.void.area, rel=1e-6)
        # every line of the symbol lies on the stair's footprint
        pts = np.concatenate([sym.lines.reshape(-1, 2), sym.walk])
        assert stair.footprint.buffer(0.1).contains(_points(pts)).all()
        m = result.mesh
        sheet = make_sheet(m.face_centroids[result.orientation.face_story == story][:, [0, 2]], result.options.render)
        fig = drafting_figure(sp.drafting, sp.annotations, sheet, result.options.render, 2, symbols)
        names = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
        assert "stair: walking line, arrow up" in names
        assert ("stair above the cut" in names) == (role == "lower")
        assert ("void in the floor (over a stair)" in names) == (role == "upper")
        rooms = [r for r in result.rooms if r.story == story]
        doc = ezdxf.read(io.StringIO(drafting_dxf(sp.drafting.slices.segments, sp.reference, sp.annotations, "", symbols, rooms).decode()))
        on = doc.modelspace().query('*[layer=="STAIRS"]')
        assert len(on.query("LINE")) == len(sym.lines) + len(sym.hidden) + len(sym.cross)
        assert len(on.query("HATCH")) == 1  # the arrow head
        dashed = [e for e in on if e.dxf.get("linetype") in ("DASHED", "DASHDOT")]
        assert len(dashed) == (len(sym.hidden) + 1 if role == "lower" else 1)  # hidden treads and walking line / the void
    pytest.importorskip("ifcopenshell")
    import ifcopenshell
    import ifcopenshell.validate

    from meshplan.export.ifc import ifc_bytes

    path = tmp_path / "model.ifc"
    path.write_bytes(ifc_bytes(result))
    model = ifcopenshell.open(str(path))
    (ifc_stair,) = model.by_type("IfcStair")
    (rep,) = ifc_stair.Representation.Representations
    assert (rep.RepresentationIdentifier, rep.RepresentationType) == ("FootPrint", "Curve2D")
    ring = np.array([p.Coordinates for p in rep.Items[0].Points])
    assert abs(_polygon(np.c_[ring[:, 0], -ring[:, 1]]).area - stair.footprint.area) < 0.01
    assert ifc_stair.ContainedInStructure[0].RelatingStructure.Name == "Story 0"
    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(model, logger)
    assert logger.statements == []


@pytest.mark.slow
def test_room_labels_keep_off_the_stair_symbol(computed):
    """On both stories a stair connects, a room label stands where the room is free of the
    stair's symbol (treads and arrow below, the void above) when the room has room for it
    there."""
    import shapely
    from shapely.ops import polylabel

    from meshplan.plan.symbols import LABEL_FREE_RADIUS_M, STAIR_LABEL_CLEAR_M, plan_symbols

    _, result = computed("multistory", 1)
    (stair,) = result.stairs
    moved = 0
    for story in (stair.story, stair.to_story):
        symbols = plan_symbols(story, result.walls, result.openings, result.rooms, result.physical_walls, stairs=result.stairs)
        for outline, label in zip(symbols.room_outlines, symbols.room_labels):
            room = shapely.Polygon(outline)
            free = room.difference(stair.footprint.buffer(STAIR_LABEL_CLEAR_M))
            roomy = [p for p in shapely.get_parts(free) if p.area > 0 and p.exterior.distance(polylabel(p, tolerance=0.02)) >= LABEL_FREE_RADIUS_M]
            if room.intersects(stair.footprint) and roomy:
                assert not stair.footprint.contains(shapely.Point(label.position)), (story, label.name)
                moved += 1
    assert moved >= 1  # the stairwell (or the room holding the stair) on at least one story


@pytest.mark.slow
def test_stacked_stairs_middle_story(computed):
    """Three stories: on the middle one the stair arriving from below and the one starting up
    are both drawn; the arriving one is hidden under the visible part of the starting one, whose
    part above the cut is left out; the void there is outlined, not crossed."""
    from meshplan.plan.symbols import plan_symbols

    _, result = computed("multistory", 2, stories=3)
    assert len(result.stairs) == 2
    sym = plan_symbols(1, result.walls, result.openings, result.rooms, result.physical_walls, stairs=result.stairs)
    roles = {s.role: s for s in sym.stairs}
    assert set(roles) == {"lower", "upper"}
    low, up = roles["lower"], roles["upper"]
    assert len(low.cut) and len(low.hidden) == 0 and len(low.walk_hidden) == 0
    assert len(up.void) and len(up.cross) == 0
    # nothing of the arriving stair is drawn over the starting one's treads below the cut
    import shapely

    below = shapely.MultiLineString([seg.tolist() for seg in low.lines]).convex_hull.buffer(-0.05)
    mids = _points(np.asarray(up.lines).mean(axis=1))
    assert below.area > 0.5 and not shapely.contains(below, mids).any()
    assert len(up.lines) > 10  # the rest of it is drawn


def _polygon(ring):
    from shapely.geometry import Polygon

    return Polygon(ring)


def _points(pts):
    import shapely

    return shapely.points(np.asarray(pts))

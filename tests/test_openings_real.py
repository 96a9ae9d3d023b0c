"""Doors and windows on the real scans against their hand-digitized truth (issue 9 item 5,
issue 16): doors between collinear wall pieces, next to corners, seen from one side, and
parametric doors (a hole in a wall box, a separate box or quad in the wall plane). Skipped
when ../shared is absent.

Scored with the real-scan scorer (one-to-one, centres within 40 cm; recall on *sure* truth
openings). The numbers are the level reached, each one failing on the detector before it.
"""

from __future__ import annotations

import json

import pytest

from conftest import SHARED

SCANS = SHARED / "scans"
TRUTH = SHARED / "truth"

#: Per scan: the fewest sure truth windows found, the most windows found that match no truth
#: window. Before the window panels, no window was found on any real scan. The glazing of the
#: windows of hl2_su_office_chroje (glass and blinds 4-6 cm behind the face) and
#: iphone_polycam_tamatebox_tatami_room (a lattice 0.2 m deep) was scanned in their reveals, so
#: they leave no gap in the wall: found as recesses since issue 16 (before: 0 of 1 each). The
#: tatami room's 3 cm recessed sliding-door panel (an unsure door) must not be a window.
REAL_WINDOWS = {
    # two 0.4 x 0.3-0.5 m holes (0.13-0.18 m2) in the scanned walls were windows, one of them
    # by chance within 40 cm of the truth's unsure 2.2 m window; under window_area_m2 they are not
    "hl2_su_apartment_two_story.ply": (0, 0),
    # two 0.4 x 0.3 m holes (vents or scan holes: the hall's truth has no window) are none; a
    # recess 1.25 m wide from 1.65 to 2.8 m, its surface 10 cm behind the face of the east wall
    # (a reveal by every measure), is found since the slab searched follows a wall drawn at its
    # own angle (the wall runs 7-8 degrees off the axes): the truth names no window there, but
    # it was digitized from slices at 0.3, 1.2 and 3.19 m (its PNG), none of which cuts it
    "hl1_hemkinator_large_hall.ply": (0, 1),
    "hl2_su_office_chroje.ply": (1, 0),  # 1.5 m of glass and blinds 5.5 cm behind the face, 1.15-2.1 m
    "iphone_polycam_tamatebox_tatami_room.glb": (1, 0),  # a lattice 0.2 m deep (found 0.55 of its 0.85 m)
    "quest_mruk_radiotwin_lab_parametric.obj": (1, 0),  # a glazing quad over an uncut wall, sill 0.15 m
    "roomplan_sekhar_library_parametric.ply": (1, 0),  # a window box in the wall plane
    "roomplan_sekhar_small_room_parametric.ply": (0, 0),
    # two regions 0.8 m wide and 0.9-1.15 m high 3 cm or more behind a face warped by 2.6 cm (its
    # standard deviation), stepping by 1-1.6 cm at their edges: hollows of the mesh, no reveals
    "tango_rainfiel_room_closed.ply": (0, 0),
}

#: Per scan: the fewest sure truth doors found, the most doors found that match no truth door.
#: Before issue 16 these were 2/3, 0/1, 0/2, 0/3 and 0/1 sure doors.
REAL_DOORS = {
    # a gap past the end of the north wall's piece, its far "jamb" a counter's end in the line
    # (no wall there), was a door
    "hl1_ashro_room_45deg.obj": (0, 0),
    # a gap under the rounded-off corner between the east wall and the ceiling, its "lintel" at
    # 2.47 m, was a door (no door is visible there)
    "hl1_cuny_room_sparse_walls.obj": (0, 0),
    # the leaf of a closed door stands back in its frame: a 0.75 m rectangle 5 cm behind the
    # bedroom's west wall, from the floor to a straight head at 2.0 m, is a door since; the truth
    # names none there (it lists such recesses on the west wall as unsure doors)
    "hl2_su_apartment_two_story.ply": (2, 1),
    # the NE door, its leaf 15 cm back in its frame, found since (0 of 1 before); a 0.95 m
    # recess 8.5 cm deep from the floor to a straight head at 2.1 m in the north wall is a door
    # too, where the truth notes "a 1 m high recess (radiator niche?)" from its slices at 0.3
    # and 1.2 m (the faces there stand 8.5 cm back from 0.4 to 2.05 m, the wall's plane above)
    "hl1_hemkinator_large_hall.ply": (1, 1),
    "hl2_su_office_chroje.ply": (1, 0),  # a 0.75 m door between two pieces of wall, no lintel above the scan's top
    "quest_mruk_radiotwin_lab_parametric.obj": (2, 0),  # door quads over an uncut wall
    "roomplan_sekhar_library_parametric.ply": (3, 0),  # door boxes in the wall plane
    "roomplan_sekhar_small_room_parametric.ply": (1, 0),  # a hole in a wall box, next to a corner
}


def _scores(name: str) -> dict:
    import meshplan
    from meshplan.evaluate_real import evaluate_real
    from meshplan.export import plan_document

    result = meshplan.run(SCANS / name, output=None)
    truth = json.loads((TRUTH / f"{name.rsplit('.', 1)[0]}.truth.json").read_text())
    return evaluate_real(plan_document(result), truth)["total"]


@pytest.fixture(scope="module")
def real_openings():
    if not SCANS.is_dir() or not TRUTH.is_dir():
        pytest.skip("real scans not available (../shared)")
    return {name: _scores(name) for name in sorted(set(REAL_DOORS) | set(REAL_WINDOWS)) if (SCANS / name).is_file()}


@pytest.mark.realscan
@pytest.mark.parametrize(
    "key, name", [("doors", n) for n in sorted(REAL_DOORS)] + [("windows", n) for n in sorted(REAL_WINDOWS)]
)
def test_real_openings(real_openings, key, name):
    if name not in real_openings:
        pytest.skip(f"{name} not available")
    sure_min, extra_max = (REAL_DOORS if key == "doors" else REAL_WINDOWS)[name]
    d = real_openings[name][key]
    assert d["matched_sure"] >= sure_min, d
    assert d["found"] - d["matched"] <= extra_max, d


@pytest.mark.realscan
def test_real_doors_pooled(real_openings):
    """Over the scans: at least 9 of the 10 sure doors (10 of 11 with hemkinator's), and no door
    that is not one but the two closed-door recesses the truth does not list (REAL_DOORS)."""
    scored = [r for name, r in real_openings.items() if name in REAL_DOORS]
    sure = sum(r["doors"]["sure_truth"] for r in scored)
    matched = sum(r["doors"]["matched_sure"] for r in scored)
    extra = sum(r["doors"]["found"] - r["doors"]["matched"] for r in scored)
    assert matched >= 0.9 * sure - 1e-9
    assert extra <= 2


"""The real-scan scorer (meshplan.evaluate_real) against fake plans made from the truth itself.

A fake plan is the truth turned 30 degrees about +y and shifted, with ``transform`` set so that
``transform @ truth_to_input`` is that motion: it must score perfectly. A fake plan perturbed
in known ways (a wall shifted 30 cm, a room shrunk by 20 % of its area, a door removed) must
score exactly the numbers those changes imply. The hand-made truth below needs nothing outside
the repository; the tests over the 13 real truth files read ../shared/truth (``realscan``) and
are skipped when it is absent.
"""

from __future__ import annotations

import copy
import json
import os
from pathlib import Path

import numpy as np
import pytest

from meshplan.evaluate import evaluate, format_report
from meshplan.evaluate_real import (
    OPENING_DISTANCE_M,
    WALL_ANGLE_DEG,
    WALL_DISTANCE_M,
    WALL_SAMPLE_M,
    covered_lengths,
    evaluate_real,
    is_real_truth,
)

ROOT = Path(__file__).resolve().parents[1]
TRUTH_DIR = Path(os.environ.get("MESHPLAN_SHARED", ROOT.parent / "shared")) / "truth"

#: The truth files of ../shared/truth (named here so that the test list is the same with or
#: without them; each is skipped when absent).
TRUTH_STEMS = [
    "hl1_ashro_room_45deg",
    "hl1_cuny_room_sparse_walls",
    "hl1_hemkinator_large_hall",
    "hl1_holosoma_room_sparse_walls",
    "hl1_mrtk_example_office",
    "hl2_su_apartment_two_story",
    "hl2_su_office_chroje",
    "iphone_polycam_tamatebox_tatami_room",
    "quest_mruk_radiotwin_lab_parametric",
    "roomplan_sekhar_library_parametric",
    "roomplan_sekhar_small_room_parametric",
    "tango_rainfiel_office_open",
    "tango_rainfiel_room_closed",
]

#: The fake plan's motion from the truth frame: turned about +y, shifted (also up, which the
#: story matching must see through).
TURN_DEG = 30.0
SHIFT_M = (1.7, 0.25, -2.3)
#: How far the perturbed wall is moved across itself (m): twice the wall tolerance.
WALL_SHIFT_M = 0.30
#: Fraction of its area a perturbed room loses.
ROOM_SHRINK = 0.20
#: Default ceiling height (m) written into a fake plan whose truth has no ceiling.
FAKE_CEILING_M = 2.5


def load_truth(stem: str) -> dict:
    path = TRUTH_DIR / f"{stem}.truth.json"
    if not path.is_file():
        pytest.skip(f"truth file {path.name} not available (../shared/truth)")
    return json.loads(path.read_text(encoding="utf-8"))


def motion(turn_deg: float = TURN_DEG, shift=SHIFT_M) -> np.ndarray:
    """4x4 rigid motion: a turn about +y, then a shift."""
    c, s = np.cos(np.radians(turn_deg)), np.sin(np.radians(turn_deg))
    a = np.eye(4)
    a[:3, :3] = [[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]]
    a[:3, 3] = shift
    return a


def fake_plan(truth: dict, turn_deg: float = TURN_DEG, shift=SHIFT_M) -> dict:
    """A plan.json made from the truth itself, moved by :func:`motion`.

    Walls are the truth's wall face lines with the schema's normal, rooms the truth's main
    outlines and areas, openings the truth's doors and windows, stories its floors and ceilings
    (``wall_top`` or a default where it has none).
    """
    a = motion(turn_deg, shift)

    def xz(p, y=0.0):
        q = a @ [p[0], y, p[1], 1.0]
        return [float(q[0]), float(q[2])]

    def y(h):
        return float(h + a[1, 3])

    stories = []
    for st in truth["stories"]:
        ceiling = st["ceiling"] if st.get("ceiling") is not None else st.get("wall_top") or st["floor"] + FAKE_CEILING_M
        stories.append({"index": st["index"], "floor": y(st["floor"]), "ceiling": y(ceiling), "height": ceiling - st["floor"], "ceiling_found": st.get("ceiling") is not None})
    walls = []
    for w in truth["walls"]:
        s, e = np.array(xz(w["start"])), np.array(xz(w["end"]))
        d = e - s
        n = np.array([d[1], -d[0]]) / np.linalg.norm(d)
        walls.append({"story": w["story"], "start": s.tolist(), "end": e.tolist(), "normal": n.tolist(), "length": float(np.linalg.norm(d)), "bottom": y(w["bottom"]), "top": y(w["top"]), "points": 1})
    rooms = [
        {"story": r["story"], "label": str(r["id"]), "polygon": [xz(p) for p in r["polygon"]], "area": r["area"], "width": 1.0, "depth": 1.0}
        for r in truth["rooms"]
    ]
    openings = [
        {"story": o["story"], "kind": kind, "wall": o["wall"], "center": xz(o["center"]), "width": o["width"], "bottom": y(o["bottom"]), "top": y(o["top"])}
        for kind, key in (("door", "doors"), ("window", "windows"))
        for o in truth.get(key, [])
    ]
    return {
        "transform": (a @ np.linalg.inv(np.asarray(truth["truth_to_input"], float))).tolist(),
        "input": {"units": "m"},
        "stories": stories,
        "walls": walls,
        "rooms": rooms,
        "openings": openings,
    }


def assert_perfect(report: dict, truth: dict) -> None:
    assert report["gravity_error_deg"] == pytest.approx(0.0, abs=1e-6)
    # the truth's walls run along its axes, the fake plan's are turned by TURN_DEG
    assert report["alignment_error_deg"] == pytest.approx(min(TURN_DEG % 90, 90 - TURN_DEG % 90), abs=1e-6)
    assert report["unscored_plan_stories"] == []
    for s, st in zip(report["stories"], truth["stories"]):
        assert s["plan_story"] == st["index"]
        assert s["floor_error_m"] == pytest.approx(0.0, abs=1e-9)
        if st.get("ceiling") is None:
            assert s["ceiling_error_m"] is None
        else:
            assert s["ceiling_error_m"] == pytest.approx(0.0, abs=1e-9)
    t = report["total"]
    w = t["walls"]
    assert w["precision"] == pytest.approx(1.0, abs=1e-12)
    assert w["recall"] == pytest.approx(1.0, abs=1e-12)
    assert w["f1"] == pytest.approx(1.0, abs=1e-12)
    assert w["furniture_length_m"] == pytest.approx(0.0, abs=1e-9)
    r = t["rooms"]
    assert (r["precision"], r["recall"]) == (1.0, 1.0)
    assert r["mean_iou"] == pytest.approx(1.0, abs=1e-9)
    assert r["mean_area_error"] == pytest.approx(0.0, abs=1e-12)
    for key in ("doors", "windows"):
        o = t[key]
        assert o["matched"] == o["truth"] == o["found"] == len(truth.get(key, []))
        assert o["precision"] == (1.0 if o["found"] else None)
        assert o["recall"] == (1.0 if o["sure_truth"] else None)


# ------------------------------------------------------------------- a hand-made truth file


def toy_truth() -> dict:
    """Two 2 x 3 m rooms side by side (story 0), the input frame turned 50 degrees from the
    truth frame, a closet front as an unsure wall, two sure doors and an unsure window."""
    t2i = motion(50.0, (3.0, -1.4, 0.6))
    walls = [
        ((0, 0), (4, 0), "sure"),
        ((4, 0), (4, 3), "sure"),
        ((4, 3), (0, 3), "sure"),
        ((0, 3), (0, 0), "sure"),
        ((2, 0), (2, 3), "sure"),
        ((3.0, 2.0), (3.8, 2.0), "unsure"),  # closet front: a predicted wall there is not furniture
    ]
    return {
        "scan": "toy.ply",
        "truth_to_input": t2i.tolist(),
        "input_to_truth": np.linalg.inv(t2i).tolist(),
        "stories": [{"index": 0, "floor": 0.0, "ceiling": 2.5}],
        "walls": [
            {"id": i, "story": 0, "start": list(s), "end": list(e), "bottom": 0.0, "top": 2.5, "confidence": c, "length": float(np.hypot(e[0] - s[0], e[1] - s[1]))}
            for i, (s, e, c) in enumerate(walls)
        ],
        "rooms": [
            {"id": "R0", "story": 0, "type": "room", "polygon": [[0, 0], [2, 0], [2, 3], [0, 3]], "area": 6.0, "partial": False},
            {"id": "R1", "story": 0, "type": "room", "polygon": [[2, 0], [4, 0], [4, 3], [2, 3]], "area": 6.0, "partial": False},
        ],
        "doors": [
            {"story": 0, "center": [1.0, 3.0], "width": 0.9, "bottom": 0.0, "top": 2.0, "wall": 2, "confidence": "sure"},
            {"story": 0, "center": [2.0, 1.5], "width": 0.9, "bottom": 0.0, "top": 2.0, "wall": 4, "confidence": "sure"},
        ],
        "windows": [{"story": 0, "center": [4.0, 1.5], "width": 1.2, "bottom": 1.0, "top": 2.0, "wall": 1, "confidence": "unsure"}],
    }


def shift_wall(plan: dict, i: int, by: float) -> None:
    w = plan["walls"][i]
    n = np.asarray(w["normal"])
    w["start"] = (np.asarray(w["start"]) + by * n).tolist()
    w["end"] = (np.asarray(w["end"]) + by * n).tolist()


def shrink_room(plan: dict, i: int, fraction: float) -> None:
    """Scales a room about its vertex mean so that it loses ``fraction`` of its area."""
    r = plan["rooms"][i]
    p = np.asarray(r["polygon"])
    c = p.mean(axis=0)
    r["polygon"] = (c + np.sqrt(1.0 - fraction) * (p - c)).tolist()
    r["area"] = r["area"] * (1.0 - fraction)


def test_detects_real_truth():
    assert is_real_truth(toy_truth())
    assert not is_real_truth({"transform": np.eye(4).tolist()})


def test_toy_fake_plan_scores_perfectly():
    truth = toy_truth()
    report = evaluate(fake_plan(truth), truth)  # through the dispatcher of meshplan.evaluate
    assert_perfect(report, truth)
    assert report["total"]["walls"]["sure_length_m"] == pytest.approx(17.0)
    assert report["total"]["walls"]["predicted_length_m"] == pytest.approx(17.8)


def test_toy_perturbed_plan_scores_expected_numbers():
    truth = toy_truth()
    plan = fake_plan(truth)
    shift_wall(plan, 0, WALL_SHIFT_M)  # the 4 m north wall moved 30 cm across itself: no match
    shrink_room(plan, 1, ROOM_SHRINK)  # R1 keeps 80 % of its area, inside its truth outline
    del plan["openings"][0]  # the door at (1, 3)
    report = evaluate_real(plan, truth)
    w = report["total"]["walls"]
    # 17.8 m predicted (17 m sure walls and the 0.8 m closet front), of which the 4 m wall is off
    assert w["matched_length_m"] == pytest.approx(13.8, abs=1e-9)
    assert w["precision"] == pytest.approx(13.8 / 17.8, abs=1e-12)
    assert w["recall"] == pytest.approx(13.0 / 17.0, abs=1e-12)
    p, r = 13.8 / 17.8, 13.0 / 17.0
    assert w["f1"] == pytest.approx(2 * p * r / (p + r), abs=1e-12)
    assert w["furniture_length_m"] == pytest.approx(4.0, abs=1e-9)
    rooms = report["total"]["rooms"]
    assert (rooms["precision"], rooms["recall"]) == (1.0, 1.0)
    ious = {pair["truth"]: pair["iou"] for pair in rooms["pairs"]}
    assert ious["R0"] == pytest.approx(1.0, abs=1e-9)
    assert ious["R1"] == pytest.approx(1.0 - ROOM_SHRINK, abs=1e-9)
    assert rooms["mean_iou"] == pytest.approx(1.0 - ROOM_SHRINK / 2, abs=1e-9)
    assert rooms["mean_area_error"] == pytest.approx(ROOM_SHRINK / 2, abs=1e-12)
    doors = report["total"]["doors"]
    assert (doors["found"], doors["matched"], doors["precision"], doors["recall"]) == (1, 1, 1.0, 0.5)
    windows = report["total"]["windows"]
    assert (windows["precision"], windows["recall"]) == (1.0, None)  # the only window is unsure
    assert "walls     F1" in format_report(report)


def test_toy_room_shrunk_below_iou_threshold_is_unmatched():
    truth = toy_truth()
    plan = fake_plan(truth)
    shrink_room(plan, 0, 0.6)  # IoU 0.4 < 0.5
    rooms = evaluate_real(plan, truth)["total"]["rooms"]
    assert (rooms["matched"], rooms["precision"], rooms["recall"]) == (1, 0.5, 0.5)


def test_toy_wrong_story_height_scores_nothing():
    truth = toy_truth()
    plan = fake_plan(truth)
    plan["stories"][0]["floor"] += 0.6  # beyond the 0.5 m story match
    report = evaluate_real(plan, truth)
    assert report["stories"][0]["plan_story"] is None
    assert report["total"]["walls"]["recall"] == 0.0
    assert report["unscored_plan_stories"] == [0]


def test_toy_openings_nearest_first_within_40cm():
    truth = toy_truth()
    plan = fake_plan(truth)
    doors = [o for o in plan["openings"] if o["kind"] == "door"]
    along = np.array([np.cos(np.radians(TURN_DEG)), np.sin(np.radians(TURN_DEG))])  # truth +x
    doors[0]["center"] = (np.asarray(doors[0]["center"]) + (OPENING_DISTANCE_M - 0.01) * along).tolist()
    doors[1]["center"] = (np.asarray(doors[1]["center"]) + (OPENING_DISTANCE_M + 0.01) * along).tolist()
    d = evaluate_real(plan, truth)["total"]["doors"]
    assert (d["matched"], d["recall"]) == (1, 0.5)
    assert d["pairs"][0]["distance_m"] == pytest.approx(OPENING_DISTANCE_M - 0.01)


def test_partial_wall_overlap_is_measured_not_all_or_nothing():
    # 10 cm off a truth wall that starts half-way along: matched from where the 15 cm distance
    # to the truth segment's end is reached
    pred = np.array([[[0.0, 0.1], [2.0, 0.1]]])
    truth = np.array([[[1.0, 0.0], [3.0, 0.0]]])
    expected = 2.0 - (1.0 - np.sqrt(WALL_DISTANCE_M**2 - 0.1**2))
    assert covered_lengths(pred, truth)[0] == pytest.approx(expected, abs=WALL_SAMPLE_M)
    assert covered_lengths(truth, pred)[0] == pytest.approx(expected, abs=WALL_SAMPLE_M)


@pytest.mark.parametrize("deg, matched", [(WALL_ANGLE_DEG - 1, True), (WALL_ANGLE_DEG + 1, False), (180 - WALL_ANGLE_DEG + 1, True)])
def test_wall_angle_tolerance(deg, matched):
    t = np.radians(deg)
    pred = np.array([[[1.0, 0.0], [1.0 + 0.5 * np.cos(t), 0.5 * np.sin(t)]]])  # within 9 cm of the truth wall
    truth = np.array([[[0.0, 0.0], [2.0, 0.0]]])
    assert (covered_lengths(pred, truth)[0] > 0.49) == matched


def test_cli_evaluate_real_truth(tmp_path, capsys):
    from meshplan.cli import main

    truth = toy_truth()
    (tmp_path / "plan.json").write_text(json.dumps(fake_plan(truth)))
    (tmp_path / "truth.json").write_text(json.dumps(truth))
    assert main(["evaluate", str(tmp_path / "plan.json"), str(tmp_path / "truth.json"), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["total"]["walls"]["f1"] == pytest.approx(1.0)


# -------------------------------------------------------------------- the real truth files


@pytest.mark.realscan
@pytest.mark.parametrize("stem", TRUTH_STEMS)
def test_fake_plan_from_real_truth_scores_perfectly(stem):
    truth = load_truth(stem)
    assert is_real_truth(truth)
    assert_perfect(evaluate(fake_plan(truth), truth), truth)


def _unit(w: dict) -> np.ndarray:
    d = np.subtract(w["end"], w["start"])
    return d / np.linalg.norm(d)


def _isolated_sure_wall(truth: dict) -> int | None:
    """A sure wall that no other wall of its story runs near (within the angle tolerance and
    the shift plus the distance tolerance, with a margin), so that shifted it matches nothing."""
    from shapely.geometry import LineString

    clearance = WALL_SHIFT_M + WALL_DISTANCE_M + 0.1
    walls = truth["walls"]
    for w in sorted(walls, key=lambda w: -w["length"]):
        if w["confidence"] != "sure":
            continue
        line = LineString([w["start"], w["end"]])
        clash = any(
            o is not w
            and o["story"] == w["story"]
            and abs(float(_unit(w) @ _unit(o))) >= np.cos(np.radians(WALL_ANGLE_DEG))
            and line.distance(LineString([o["start"], o["end"]])) < clearance
            for o in walls
        )
        if not clash:
            return w["id"]
    return None


@pytest.mark.realscan
@pytest.mark.parametrize("stem", TRUTH_STEMS)
def test_perturbed_fake_plan_from_real_truth(stem):
    """One isolated sure wall shifted 30 cm and one sure door removed cost exactly their share."""
    truth = load_truth(stem)
    plan = fake_plan(truth)
    wall = _isolated_sure_wall(truth)
    if wall is not None:
        shift_wall(plan, wall, WALL_SHIFT_M)
    doors = [i for i, o in enumerate(plan["openings"]) if o["kind"] == "door" and truth["doors"][i]["confidence"] == "sure"]
    if doors:
        del plan["openings"][doors[0]]
    if wall is None and not doors:
        pytest.skip(f"{stem}: no isolated sure wall and no sure door to perturb")
    w = evaluate_real(plan, truth)["total"]["walls"]
    lengths = np.array([np.hypot(*np.subtract(x["end"], x["start"])) for x in truth["walls"]])
    sure = np.array([x["confidence"] == "sure" for x in truth["walls"]])
    lost = lengths[wall] if wall is not None else 0.0
    assert w["precision"] == pytest.approx((lengths.sum() - lost) / lengths.sum(), abs=1e-12)
    assert w["recall"] == pytest.approx((lengths[sure].sum() - lost) / lengths[sure].sum(), abs=1e-12)
    assert w["furniture_length_m"] == pytest.approx(lost, abs=1e-9)
    if doors:
        d = evaluate_real(plan, truth)["total"]["doors"]
        n_sure = sum(o["confidence"] == "sure" for o in truth["doors"])
        assert d["recall"] == pytest.approx((n_sure - 1) / n_sure)
        assert d["precision"] == (1.0 if d["found"] else None)


def test_perturbing_does_not_touch_the_truth():
    truth = toy_truth()
    before = copy.deepcopy(truth)
    plan = fake_plan(truth)
    shift_wall(plan, 0, 0.3)
    evaluate_real(plan, truth)
    assert truth == before


def test_the_truth_levelling_levels_a_tilted_room_on_its_floor():
    """The truth's levelling (its README's plane fit to the floor) finds the floor's normal of a
    room tilted by 1.5 degrees, from the file's +y, and ignores the ceiling and a table top."""
    from conftest import angle_deg, box_room
    from meshplan.evaluate_real import truth_levelling
    from meshplan.geometry import Mesh

    v, f = box_room(4.0, 3.0, 2.5, cell=0.1)
    table = np.array([[1.0, 0.75, 1.0], [2.0, 0.75, 1.0], [2.0, 0.75, 2.0], [1.0, 0.75, 2.0]])
    v = np.r_[v, table]
    f = np.r_[f, len(v) - 4 + np.array([[0, 2, 1], [0, 3, 2]])]
    t = np.radians(1.5)
    rot = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(t), -np.sin(t)], [0.0, np.sin(t), np.cos(t)]])
    mesh = Mesh(v @ rot.T, f)
    up = truth_levelling(mesh.face_centroids, mesh.face_normals, mesh.face_areas, [0.0, 1.0, 0.0])
    assert angle_deg(up, rot @ [0.0, 1.0, 0.0]) < 0.01
    assert angle_deg(up, [0.0, 1.0, 0.0]) > 1.4

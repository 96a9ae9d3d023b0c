"""Tests of the synthetic scan generator against its own ground truth."""

from __future__ import annotations

import json
from functools import cache

import numpy as np
import pytest

from meshplan.errors import ParameterError
from meshplan.geometry import Mesh, is_rigid, transform_points
from meshplan.io import annotations_document, parse_annotations
from meshplan.synthetic import PRESETS, SURFACE_KINDS, SyntheticScan, SynthParams, generate

KIND = {k: i for i, k in enumerate(SURFACE_KINDS)}
COARSE = (0.15, 0.25)  # big triangles keep the tests fast


@cache
def scan(preset: str = "apartment", seed: int = 0, **kw) -> SyntheticScan:
    kw.setdefault("triangle_size_m", COARSE)
    return generate(preset=preset, seed=seed, **kw)


def back(s: SyntheticScan) -> Mesh:
    return s.truth_mesh()


def shoelace(poly) -> float:
    p = np.asarray(poly, dtype=float)
    return 0.5 * float(np.dot(p[:, 0], np.roll(p[:, 1], -1)) - np.dot(np.roll(p[:, 0], -1), p[:, 1]))


def inside(poly, x: float, z: float) -> bool:
    p = np.asarray(poly, dtype=float)
    out = False
    for (ax, az), (bx, bz) in zip(p, np.roll(p, -1, axis=0)):
        if (az > z) != (bz > z) and x < ax + (z - az) * (bx - ax) / (bz - az):
            out = not out
    return out


# --------------------------------------------------------------------------------------------
# API and determinism


@pytest.mark.parametrize("preset", PRESETS)
def test_every_preset_generates(preset):
    s = scan(preset, 1)
    t = s.truth
    assert s.mesh.n_faces == t["faces"] == len(s.face_groups) == len(s.face_kinds) == len(s.face_walls)
    assert s.mesh.n_vertices == t["vertices"]
    assert t["format"] == "meshplan-synthetic-truth/1" and t["preset"] == preset and t["seed"] == 1
    assert json.loads(json.dumps(t)) == t  # JSON-ready, plain types
    assert set(np.unique(s.face_groups)) <= set(range(len(s.group_names)))
    assert len(set(s.group_names)) == len(s.group_names)
    assert np.all(np.isfinite(s.mesh.vertices))
    assert s.mesh.face_areas.min() > 1e-10
    assert is_rigid(np.array(t["transform"]))
    assert len(t["stories"]) == (2 if preset == "multistory" else 1)
    n_rooms = len(t["rooms"])
    assert {"room": (1, 1), "apartment": (5, 7), "office": (8, 13), "multistory": (10, 18)}[preset][0] <= n_rooms
    # every room shell and every furniture item has faces
    assert np.all(np.bincount(s.face_groups, minlength=len(s.group_names)) > 0)


def test_same_seed_is_bit_identical_and_seeds_differ():
    a = generate(preset="apartment", seed=7, triangle_size_m=COARSE)
    b = generate(SynthParams(preset="apartment", seed=7, triangle_size_m=COARSE))
    assert np.array_equal(a.mesh.vertices, b.mesh.vertices)
    assert np.array_equal(a.mesh.faces, b.mesh.faces)
    assert np.array_equal(a.face_groups, b.face_groups)
    assert np.array_equal(a.annotations.positions, b.annotations.positions)
    assert a.truth == b.truth
    c = scan("apartment", 8)
    assert c.mesh.n_faces != a.mesh.n_faces or not np.array_equal(c.mesh.vertices, a.mesh.vertices)
    assert c.truth["rooms"] != a.truth["rooms"]


def test_streams_are_independent():
    """Furniture and triangle size do not change the building or the pose."""
    a = scan("apartment", 3)
    b = scan("apartment", 3, furniture=False, triangle_size_m=(0.2, 0.3))
    for key in ("rooms", "walls", "openings", "annotations", "transform", "missing"):
        assert a.truth[key] == b.truth[key]
    assert not b.truth["furniture"] and a.truth["furniture"]


def test_parameters_are_validated():
    for bad in (
        dict(preset="castle"),
        dict(preset="apartment", stories=2),
        dict(preset="multistory", stories=4),
        dict(triangle_size_m=(0.1, 0.05)),
        dict(triangle_size_m=(0.0, 0.05)),
        dict(noise_m=(-0.01, 0.01)),
        dict(max_tilt_deg=90),
        dict(winding="sideways"),
        dict(target_faces=10),
        dict(seed=-1),
        dict(z_up="yes"),
    ):
        with pytest.raises(ParameterError):
            SynthParams(**bad)
    with pytest.raises(ParameterError):
        generate(colour="red")
    d = SynthParams(preset="multistory", stories=3).to_dict()
    assert json.loads(json.dumps(d)) == d and d["triangle_size_m"] == [0.04, 0.10]


# --------------------------------------------------------------------------------------------
# Geometry against the truth


@pytest.mark.parametrize("preset", ["apartment", "multistory"])
def test_floors_lie_at_the_truth_heights(preset):
    s = scan(preset, 2)
    m = back(s)
    floors = np.array([st["floor"] for st in s.truth["stories"]])
    ceilings = np.array([st["ceiling"] for st in s.truth["stories"]])
    for kind, levels, sign in (("floor", floors, 1), ("ceiling", ceilings, -1)):
        sel = s.face_kinds == KIND[kind]
        y = m.face_centroids[sel, 1]
        dist = np.min(np.abs(y[:, None] - levels[None, :]), axis=1)
        amp = s.truth["noise_m"]
        assert np.median(dist) < max(0.01, amp)
        assert dist.max() < 5 * amp + 0.01
        assert np.mean(sign * m.face_normals[sel, 1] > 0.9) > 0.99  # facing into the room


def test_wall_faces_lie_on_the_truth_walls():
    s = scan("apartment", 4, noise_m=(0.004, 0.004))
    m = back(s)
    sel = s.face_walls >= 0
    assert np.all(s.face_kinds[sel] == KIND["wall"])
    walls = s.truth["walls"]
    start = np.array([w["start"] for w in walls])
    end = np.array([w["end"] for w in walls])
    normal = np.array([w["normal"] for w in walls])
    wi = s.face_walls[sel]
    c = m.face_centroids[sel][:, [0, 2]]
    dist = np.einsum("ij,ij->i", c - start[wi], normal[wi])
    assert np.median(np.abs(dist)) < 0.01
    assert np.mean(np.einsum("ij,ij->i", m.face_normals[sel][:, [0, 2]], normal[wi]) > 0.9) > 0.99
    # and within the wall's extent, between its floor and ceiling
    d = end - start
    along = np.einsum("ij,ij->i", c - start[wi], d[wi]) / np.einsum("ij,ij->i", d[wi], d[wi])
    assert along.min() > -0.01 and along.max() < 1.01
    y = m.face_centroids[sel, 1]
    assert np.all(y > np.array([w["bottom"] for w in walls])[wi] - 0.03)
    assert np.all(y < np.array([w["top"] for w in walls])[wi] + 0.03)
    # every wall face of the truth is scanned
    assert set(np.unique(wi)) == set(range(len(walls)))


def test_noise_free_scan_is_exact():
    s = scan("room", 5, noise_m=(0.0, 0.0))
    assert s.truth["noise_m"] == 0.0
    m = back(s)
    sel = s.face_kinds == KIND["floor"]
    assert np.allclose(m.face_centroids[sel, 1], 0.0, atol=1e-9)
    sel = s.face_walls >= 0
    w = s.truth["walls"]
    start = np.array([x["start"] for x in w])[s.face_walls[sel]]
    nrm = np.array([x["normal"] for x in w])[s.face_walls[sel]]
    assert np.allclose(np.einsum("ij,ij->i", m.face_centroids[sel][:, [0, 2]] - start, nrm), 0.0, atol=1e-9)


@pytest.mark.parametrize("preset", PRESETS)
def test_rooms_polygons_areas_and_walls(preset):
    t = scan(preset, 6).truth
    total = 0.0
    for r in t["rooms"]:
        p = np.array(r["polygon"])
        a = shoelace(p)
        assert a < 0  # counter-clockwise seen from above (x right, z down the page)
        assert r["area"] == pytest.approx(-a, abs=1e-5)
        assert r["width"] == pytest.approx(np.ptp(p[:, 0]), abs=1e-5)
        assert r["depth"] == pytest.approx(np.ptp(p[:, 1]), abs=1e-5)
        if r["kind"] != "corridor":
            assert min(r["width"], r["depth"]) >= 2.0
        total += r["area"]
        walls = [w for w in t["walls"] if w["room"] == r["label"]]
        assert len(walls) == len(p)
        for w in walls:
            s, e, n = np.array(w["start"]), np.array(w["end"]), np.array(w["normal"])
            assert abs(np.dot(e - s, n)) < 1e-6 and np.linalg.norm(n) == pytest.approx(1.0)
            probe = 0.5 * (s + e) + 0.05 * n
            assert inside(p, *probe)  # the normal points into the room
    footprint = -shoelace(t["footprint"]) * len(t["stories"])
    assert total < footprint


def test_annotations_map_back_onto_the_truth():
    s = scan("multistory", 3)
    t = s.truth
    inv = np.linalg.inv(s.transform)
    truth_pos = np.array([a["position"] for a in t["annotations"]])
    assert np.allclose(transform_points(inv, s.annotations.positions), truth_pos, atol=1e-5)
    truth_dir = np.array([a["direction"] for a in t["annotations"]])
    assert np.allclose(s.annotations.directions @ s.transform[:3, :3], truth_dir, atol=1e-5)
    assert list(s.annotations.labels) == [a["label"] for a in t["annotations"]]
    assert len(set(s.annotations.labels)) == len(s.annotations)
    # the annotation file round-trips
    again = parse_annotations(annotations_document(s.annotations))
    assert np.allclose(again.positions, s.annotations.positions, atol=1e-5)
    kinds = [a["kind"] for a in t["annotations"]]
    assert kinds.count("thermostat") == len(t["stories"])
    assert kinds.count("door") == len({o["label"] for o in t["openings"] if o["kind"] == "door"})
    assert kinds.count("window") == sum(o["kind"] == "window" for o in t["openings"])
    floors = [st["floor"] for st in t["stories"]]
    for a in t["annotations"]:
        p = np.array(a["position"])
        # on the plane of some wall of its story, pointing along that wall's normal
        ok = False
        for w in t["walls"]:
            s0, e0, n = np.array(w["start"]), np.array(w["end"]), np.array(w["normal"])
            if not (w["bottom"] <= p[1] <= w["top"]) or abs(np.dot(p[[0, 2]] - s0, n)) > 1e-5:
                continue
            u = np.dot(p[[0, 2]] - s0, e0 - s0) / np.dot(e0 - s0, e0 - s0)
            if 0 <= u <= 1 and np.allclose(a["direction"], [n[0], 0, n[1]], atol=1e-5):
                ok = True
        assert ok, a["label"]
        h = p[1] - max(f for f in floors if f <= p[1] + 1e-9)
        if a["kind"] == "sensor":
            assert 1.2 <= h <= 1.8
        elif a["kind"] == "thermostat":
            assert h == pytest.approx(1.5)
        elif a["kind"] == "door":
            assert h == pytest.approx(1.0)


@pytest.mark.parametrize("preset", ["apartment", "office"])
def test_openings_lie_on_their_walls_and_are_cut(preset):
    s = scan(preset, 9, holes=False)
    t = s.truth
    m = back(s)
    walls = t["walls"]
    labels = {}
    for o in t["openings"]:
        w = walls[o["wall"]]
        s0, e0, n = np.array(w["start"]), np.array(w["end"]), np.array(w["normal"])
        c = np.array(o["center"])
        assert abs(np.dot(c - s0, n)) < 1e-6
        u = np.dot(c - s0, e0 - s0) / np.linalg.norm(e0 - s0)
        assert o["width"] / 2 < u < np.linalg.norm(e0 - s0) - o["width"] / 2
        floor = w["bottom"]
        if o["kind"] == "door":
            assert 0.8 <= o["width"] <= 0.9 and 2.0 <= o["top"] - floor <= 2.1 and o["bottom"] == floor
        else:
            assert 0.9 <= o["width"] <= 1.8 and 0.8 <= o["bottom"] - floor <= 1.0 and 2.0 <= o["top"] - floor <= 2.2
        labels.setdefault(o["label"], []).append(o)
        # no wall face inside the opening
        sel = s.face_walls == o["wall"]
        cc = m.face_centroids[sel]
        uu = (cc[:, [0, 2]] - s0) @ ((e0 - s0) / np.linalg.norm(e0 - s0))
        hole = (np.abs(uu - u) < o["width"] / 2 - 0.02) & (cc[:, 1] > o["bottom"] + 0.02) & (cc[:, 1] < o["top"] - 0.02)
        assert not hole.any()
    for ops in labels.values():  # interior doors: once per side, same place
        assert len(ops) in (1, 2)
        if len(ops) == 2:
            assert not ops[0]["exterior"] and ops[0]["kind"] == "door"
            assert np.linalg.norm(np.subtract(ops[0]["center"], ops[1]["center"])) < 0.4
            assert walls[ops[0]["wall"]]["room"] != walls[ops[1]["wall"]]["room"]
        else:
            assert ops[0]["exterior"]


@pytest.mark.parametrize("preset", PRESETS)
def test_every_room_is_reachable(preset):
    t = scan(preset, 11).truth
    rooms = [(r["story"], r["label"]) for r in t["rooms"]]
    links = {r: set() for r in rooms}
    by_label = {}
    for o in t["openings"]:
        if o["kind"] == "door":
            w = t["walls"][o["wall"]]
            by_label.setdefault(o["label"], []).append((w["story"], w["room"]))
    for ends in by_label.values():
        if len(ends) == 2:
            links[ends[0]].add(ends[1])
            links[ends[1]].add(ends[0])
    for st in t["stairs"]:  # a stair joins its stairwell to the room above its opening
        op = np.array(st["opening"]).mean(axis=0)
        above = [(r["story"], r["label"]) for r in t["rooms"] if r["story"] == st["story"] + 1 and inside(r["polygon"], *op)]
        assert len(above) == 1
        links[(st["story"], st["room"])].add(above[0])
        links[above[0]].add((st["story"], st["room"]))
    seen, todo = {rooms[0]}, [rooms[0]]
    while todo:
        for nxt in links[todo.pop()] - seen:
            seen.add(nxt)
            todo.append(nxt)
    assert seen == set(rooms)
    assert sum(1 for ends in by_label.values() if len(ends) == 1) >= 1  # an entrance


# --------------------------------------------------------------------------------------------
# Pose


def test_tilt_yaw_and_up():
    for seed in range(6):
        s = scan("room", seed)
        t = s.truth
        up = s.transform[:3, :3] @ [0.0, 1.0, 0.0]
        assert np.allclose(up, t["up"], atol=1e-6)
        tilt = np.degrees(np.arccos(np.clip(up[1], -1, 1)))
        assert tilt <= 6.0 + 1e-6 and tilt == pytest.approx(t["tilt_deg"], abs=1e-4)
        # the scan starts at head height in the first room: the origin is 1.6 m above its floor
        origin = transform_points(np.linalg.inv(s.transform), np.zeros(3))[0]
        assert origin[1] == pytest.approx(1.6, abs=1e-6)
        assert inside(t["rooms"][0]["polygon"], origin[0], origin[2])
    s = generate(preset="room", seed=1, yaw_deg=30.0, tilt_deg=0.0, triangle_size_m=COARSE)
    r = s.transform[:3, :3]
    assert np.allclose(r @ [1, 0, 0], [np.cos(np.radians(30)), 0, -np.sin(np.radians(30))], atol=1e-9)
    assert s.truth["yaw_deg"] == 30.0 and s.truth["tilt_deg"] == 0.0


def test_z_up():
    s = scan("apartment", 2, z_up=True)
    up = np.array(s.truth["up"])
    assert s.truth["z_up"] and np.degrees(np.arccos(up[2])) <= 6.0 + 1e-6
    # floors face +z (up to the tilt) in scan coordinates
    sel = s.face_kinds == KIND["floor"]
    assert np.median(s.mesh.face_normals[sel] @ up) > 0.99
    a = scan("apartment", 2)
    assert np.allclose(back(s).vertices, back(a).vertices, atol=1e-9)  # same building, same pose


def test_target_faces_300k():
    s = generate(preset="apartment", seed=0, target_faces=300_000)
    assert 255_000 <= s.mesh.n_faces <= 345_000
    lo, hi = s.truth["triangle_size_m"]
    assert 0.005 < lo <= hi < 0.2


# --------------------------------------------------------------------------------------------
# Defects


def test_winding_outward_and_mixed():
    base = scan("apartment", 5)
    out = scan("apartment", 5, winding="outward")
    mixed = scan("apartment", 5, winding="mixed")
    assert out.truth["winding"] == "outward" and mixed.truth["winding"] == "mixed"
    assert np.array_equal(base.mesh.faces, out.mesh.faces[:, ::-1])
    assert np.array_equal(base.mesh.vertices, out.mesh.vertices)
    for s, lo, hi in ((base, 0.99, 1.0), (out, 0.0, 0.01), (mixed, 0.1, 0.9)):
        sel = s.face_kinds == KIND["floor"]
        frac = np.mean(back(s).face_normals[sel, 1] > 0)
        assert lo <= frac <= hi


def test_bevels():
    s = scan("apartment", 5)
    d = s.truth["bevel_m"]
    assert 0.03 <= d <= 0.10
    m = back(s)
    sel = s.face_kinds == KIND["bevel"]
    ny = np.abs(m.face_normals[sel, 1])
    # floor and ceiling bevels at 45 degrees, vertical corner bevels, corner triangles between
    assert np.mean(np.abs(ny - np.sqrt(0.5)) < 0.2) > 0.4
    assert np.mean(ny < 0.2) > 0.2
    # floors stop d short of the walls
    floor = m.face_centroids[s.face_kinds == KIND["floor"]]
    for r in s.truth["rooms"]:
        p = np.array(r["polygon"])
        if len(p) != 4:
            continue
        x0, z0 = p.min(axis=0)
        x1, z1 = p.max(axis=0)
        inr = (floor[:, 0] > x0 - 0.01) & (floor[:, 0] < x1 + 0.01) & (floor[:, 2] > z0 - 0.01) & (floor[:, 2] < z1 + 0.01)
        f = floor[inr]
        gap = np.min(np.stack([f[:, 0] - x0, x1 - f[:, 0], f[:, 2] - z0, z1 - f[:, 2]]), axis=0)
        assert gap.min() > d * 0.5
    sharp = scan("apartment", 5, bridging=False)
    assert sharp.truth["bevel_m"] == 0.0 and not np.any(sharp.face_kinds == KIND["bevel"])
    assert sharp.truth["walls"] == s.truth["walls"]


def test_missing_strips_and_holes():
    for seed in range(4):
        s = scan("apartment", seed)
        t = s.truth
        assert 1 <= len(t["missing"]) <= 3 and t["holes"]
        m = back(s)
        for miss in t["missing"]:
            w = t["walls"][miss["wall"]]
            length = np.linalg.norm(np.subtract(w["end"], w["start"]))
            width = miss["to"] - miss["from"]
            assert 0.5 - 1e-6 <= width <= min(1.5, length / 3) + 1e-6
            assert 0 < miss["from"] < miss["to"] < length
            sel = s.face_walls == miss["wall"]
            d = np.subtract(w["end"], w["start"]) / length
            u = (m.face_centroids[sel][:, [0, 2]] - w["start"]) @ d
            inner = (u > miss["from"] + 0.3) & (u < miss["to"] - 0.3)
            assert not inner.any()
        for h in t["holes"]:
            assert all(0.1 <= r <= 0.6 for r in h["radii"]) and h["surface"] in ("floor", "ceiling", "wall")
    clean = scan("apartment", 0, holes=False)
    assert clean.truth["missing"] == [] and clean.truth["holes"] == []


# --------------------------------------------------------------------------------------------
# Furniture and stairs


def test_furniture():
    tilted = 0
    for preset in PRESETS:
        s = scan(preset, 12)
        t = s.truth
        m = back(s)
        rooms = {(r["story"], r["label"]): r for r in t["rooms"]}
        floors = [st["floor"] for st in t["stories"]]
        for it in t["furniture"]:
            assert it["height"] <= 2.0 + 1e-9
            room = rooms[(it["story"], it["room"])]
            assert all(inside(room["polygon"], *p) for p in it["footprint"])
            tilted += it["tilted"]
            g = s.group_names.index(it["name"])
            y = m.face_centroids[s.face_groups == g, 1] - floors[it["story"]]
            assert y.min() > -0.05 and y.max() < 2.0 + 0.05
        assert any(it["tilted"] for it in t["furniture"])
        sel = s.face_kinds == KIND["furniture"]
        assert sel.any()
        # no furniture face points down (no bottoms scanned)
        assert np.mean(m.face_normals[sel, 1] < -0.9) < 0.01
    assert tilted >= len(PRESETS)


@pytest.mark.parametrize("stories", [2, 3])
def test_multistory_stairs_and_slabs(stories):
    s = scan("multistory", 1, stories=stories)
    t = s.truth
    st = t["stories"]
    assert len(st) == stories and len(t["stairs"]) == stories - 1
    for a, b in zip(st[:-1], st[1:]):
        assert 0.2 <= b["floor"] - a["ceiling"] <= 0.35
        assert 2.5 <= a["ceiling"] - a["floor"] <= 2.8
    m = back(s)
    c = m.face_centroids
    for stair in t["stairs"]:
        assert 0.16 <= stair["rise"] <= 0.2 and 0.26 <= stair["going"] <= 0.29
        o = np.array(stair["opening"])
        (x0, z0), (x1, z1) = o.min(axis=0), o.max(axis=0)
        over = (c[:, 0] > x0 + 0.05) & (c[:, 0] < x1 - 0.05) & (c[:, 2] > z0 + 0.05) & (c[:, 2] < z1 - 0.05)
        lower, upper = st[stair["story"]], st[stair["story"] + 1]
        # no ceiling below the opening, no floor above it
        ceil = (s.face_kinds == KIND["ceiling"]) & (np.abs(c[:, 1] - lower["ceiling"]) < 0.1)
        flr = (s.face_kinds == KIND["floor"]) & (np.abs(c[:, 1] - upper["floor"]) < 0.1)
        assert not (over & ceil).any() and not (over & flr).any()
        steps = over & (s.face_kinds == KIND["stair"]) & (np.abs(m.face_normals[:, 1]) > 0.9)
        heights = c[steps, 1]
        assert heights.min() < lower["floor"] + 0.3 and heights.max() > upper["floor"] - 0.4

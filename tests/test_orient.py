"""Orientation against ground truth: gravity, wall alignment, floor and ceiling heights, stories."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import REAL_SCANS, angle_deg, box_room, real_scan
from meshplan.errors import GeometryError
from meshplan.geometry import Mesh, homogeneous, is_rigid
from meshplan.io import load_mesh
from meshplan.orient import OrientParams, orient
from meshplan.synthetic import SynthParams, generate


def errors(orientation, truth) -> tuple[float, float, list[float]]:
    """Gravity error (deg), yaw error modulo 90 deg, and |height errors| of every floor/ceiling."""
    t = np.array(truth["transform"])
    p = orientation.transform @ t  # truth frame -> plan frame
    gravity = angle_deg(p[:3, :3] @ [0, 1, 0], [0, 1, 0])
    x = p[:3, :3] @ [1, 0, 0]
    yaw = np.degrees(np.arctan2(x[2], x[0])) % 90.0
    yaw = min(yaw, 90.0 - yaw)
    heights = []
    centre = np.mean(np.array(truth["rooms"][0]["polygon"]), axis=0)
    for st, ts in zip(orientation.stories, truth["stories"]):
        for plan_h, true_h in ((st.floor, ts["floor"]), (st.ceiling, ts["ceiling"])):
            heights.append(abs((p @ [centre[0], true_h, centre[1], 1.0])[1] - plan_h))
    return gravity, yaw, heights


CASES = [
    dict(preset="room", seed=1),
    dict(preset="room", seed=2, z_up=True),
    dict(preset="room", seed=4, tilt_deg=6.0, yaw_deg=44.0),
    dict(preset="apartment", seed=0),
    dict(preset="apartment", seed=1, z_up=True, tilt_deg=5.5),
    dict(preset="apartment", seed=2, winding="outward"),
    dict(preset="apartment", seed=3, winding="mixed", yaw_deg=0.0, tilt_deg=0.0),
    dict(preset="office", seed=1, tilt_deg=3.0, yaw_deg=89.0),
    dict(preset="office", seed=2, z_up=True),
    dict(preset="multistory", seed=0),
    dict(preset="multistory", seed=1, stories=3, z_up=True),
]


@pytest.mark.parametrize("case", CASES, ids=lambda c: "-".join(f"{k}={v}" for k, v in c.items()))
def test_orientation_matches_ground_truth(case):
    scan = generate(SynthParams(**case))
    o = orient(scan.mesh)
    assert is_rigid(o.transform)
    assert len(o.stories) == len(scan.truth["stories"])
    gravity, yaw, heights = errors(o, scan.truth)
    assert gravity < 0.2
    assert yaw < 0.3
    assert max(heights) < 0.02
    assert all(s.ceiling_found for s in o.stories)
    # the lowest floor is the origin of heights
    assert o.stories[0].floor == pytest.approx(0.0, abs=1e-9)


def test_bbox_method_is_available_and_rougher():
    scan = generate(SynthParams(preset="apartment", seed=0, tilt_deg=4.0))
    o = orient(scan.mesh, OrientParams(gravity_method="bbox"))
    gravity, _, _ = errors(o, scan.truth)
    # the bounding box follows the building, not gravity: rougher than Method 2's 0.05 degrees
    # (it measures 0.1-0.2 here), but far below the 4 degrees a method that did nothing would keep
    assert gravity < 0.5


def test_explicit_up_axis():
    scan = generate(SynthParams(preset="room", seed=3, z_up=True))
    o = orient(scan.mesh, OrientParams(up="+z"))
    assert errors(o, scan.truth)[0] < 0.2


def test_no_ceiling_uses_default_height():
    v, f = box_room(5.0, 4.0, 2.7, cell=0.1)
    m = Mesh(v, f)
    keep = ~((np.abs(m.face_normals[:, 1]) > 0.9) & (m.face_centroids[:, 1] > 2.0))
    o = orient(m.submesh(keep), OrientParams(up="+y", default_ceiling_height_m=2.4))
    assert len(o.stories) == 1 and not o.stories[0].ceiling_found
    assert o.stories[0].height == pytest.approx(2.4)
    assert "no ceiling" in o.warnings[0]


def test_implausible_units_are_reported():
    v, f = box_room(5.0, 4.0, 2.7, cell=0.2)
    with pytest.raises(GeometryError, match="--units mm"):
        orient(Mesh(v * 1000.0, f))


def test_single_wall_is_not_a_building():
    v = np.array([[0, 0, 0], [4, 0, 0], [4, 2.5, 0], [0, 2.5, 0]], float)
    with pytest.raises(GeometryError):
        orient(Mesh(v, [[0, 1, 2], [0, 2, 3]]))


def test_rigid_motion_of_the_input_moves_the_transform():
    scan = generate(SynthParams(preset="apartment", seed=5))
    rng = np.random.default_rng(0)
    from test_core import random_rotation

    move = homogeneous(random_rotation(rng), rng.normal(size=3) * 5)
    a = orient(scan.mesh)
    b = orient(scan.mesh.transformed(move))
    # the same building: plan frames differ at most by a quarter turn about y and a shift
    rel = b.transform @ move @ np.linalg.inv(a.transform)
    assert angle_deg(rel[:3, :3] @ [0, 1, 0], [0, 1, 0]) < 0.05
    x = rel[:3, :3] @ [1, 0, 0]
    yaw = np.degrees(np.arctan2(x[2], x[0])) % 90.0
    assert min(yaw, 90 - yaw) < 0.05
    assert [round(s.height, 3) for s in a.stories] == [round(s.height, 3) for s in b.stories]


@pytest.mark.parametrize("name", sorted(REAL_SCANS))
def test_real_scans(name):
    spec = REAL_SCANS[name]
    mesh = load_mesh(real_scan(name)).mesh
    o = orient(mesh)
    up_truth = np.asarray(spec["up"], float)
    up_found = o.transform[1, :3]  # row 1 of the rotation: up in input coordinates
    assert angle_deg(up_found, up_truth) < 2.0
    assert len(o.stories) == len(spec["stories"])
    offset = o.transform[1, 3]  # plan height = input height along up + offset
    for st, (floor, ceiling) in zip(o.stories, spec["stories"]):
        assert abs(st.floor - offset - floor) < 0.05
        if ceiling is None:
            assert not st.ceiling_found
        else:
            assert abs(st.ceiling - offset - ceiling) < 0.05


@pytest.mark.parametrize("preset, seed, kw", [("apartment", 1, {}), ("room", 2, {"z_up": True}), ("office", 0, {"yaw_deg": 30.0})])
def test_empty_buildings_are_put_the_right_way_up_by_their_doors(computed, preset, seed, kw):
    """Without furniture a scan says little about up and down (and its door heads point the
    wrong way); doors reach down to the floor, so the way up that shows them is up."""
    scan, result = computed(preset, seed, furniture=False, **kw)
    gravity, yaw, heights = errors(result.orientation, scan.truth)
    assert gravity < 0.2 and yaw < 0.3 and max(heights) < 0.02
    assert result.orientation.gravity.sign_by == "doors"


def test_a_declared_up_decides_only_where_the_geometry_cannot():
    """A file format's up (glTF: +y) is a prior among candidates within FORMAT_PRIOR_SHARE of
    the best score. A cubic room (2.5 m every way) looks the same along every axis: the declared
    axis is up, whichever it is. A wide room with a ceiling is decided by its geometry, whatever
    is declared."""
    v, f = box_room(2.5, 2.5, 2.5, cell=0.1)
    cube = Mesh(v, f)
    for axis in ([0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]):
        assert angle_deg(orient(cube, declared_up=np.array(axis)).transform[1, :3], axis) < 0.5
    v, f = box_room(6.0, 5.0, 2.5, cell=0.1)
    wide = Mesh(v, f)  # a wrong declaration
    assert angle_deg(orient(wide, declared_up=np.array([1.0, 0.0, 0.0])).transform[1, :3], [0, 1, 0]) < 0.5


def _fragment() -> Mesh:
    """A scan fragment as a HoloLens saves one at a desk: a 3 x 2.5 m wall, a patch of floor
    (0.7 m2), a desk top 0.7 m above it and the desk's front; far more wall than floor."""

    def grid(origin, du, dv, nu, nv):
        o, du, dv = (np.asarray(a, float) for a in (origin, du, dv))
        i, j = np.meshgrid(np.arange(nu + 1), np.arange(nv + 1), indexing="ij")
        p = (o + i[..., None] * du / nu + j[..., None] * dv / nv).reshape(-1, 3)
        idx = (i * (nv + 1) + j)[:-1, :-1].reshape(-1)
        return p, np.r_[np.c_[idx, idx + nv + 1, idx + nv + 2], np.c_[idx, idx + nv + 2, idx + 1]]

    parts = [
        grid([0, 0, 0], [3, 0, 0], [0, 2.5, 0], 30, 25),
        grid([0, 0, 0.05], [0, 0, 0.6], [1.2, 0, 0], 6, 12),
        grid([1.5, 0.7, 0.05], [0, 0, 0.6], [1.2, 0, 0], 6, 12),
        grid([1.5, 0, 0.65], [1.2, 0, 0], [0, 0.7, 0], 12, 7),
    ]
    offsets = np.cumsum([0] + [len(p) for p, _ in parts[:-1]])
    return Mesh(np.concatenate([p for p, _ in parts]), np.concatenate([q + k for (_, q), k in zip(parts, offsets)]))


def test_a_device_frame_decides_where_a_format_convention_would_not():
    """The geometry of a fragment puts up along the wall's normal (its score is four times the
    floor's): a file format's convention (a prior within FORMAT_PRIOR_SHARE) does not change
    that, the gravity-aligned frame of the device that scanned it does, sign included."""
    mesh = _fragment()
    y = np.array([0.0, 1.0, 0.0])
    by_format = orient(mesh, declared_up=y, declared_by="format")
    assert angle_deg(by_format.transform[1, :3], y) > 80  # the geometry alone: the wall's axis
    by_device = orient(mesh, declared_up=y, declared_by="device")
    assert angle_deg(by_device.transform[1, :3], y) < 0.5
    assert by_device.gravity.sign_by == "device frame"
    # upside down, the device frame still says which way is up
    flipped = orient(Mesh(mesh.vertices * [1.0, -1.0, 1.0], mesh.faces[:, ::-1]), declared_up=-y, declared_by="device")
    assert angle_deg(flipped.transform[1, :3], -y) < 0.5


_PORTAL_OBJ = "\n\no Object.1\nv 0.1 0.2 0.3\nv 1.1 0.2 0.3\nv 0.1 0.2 1.3\nvn 0 1 0\nvn 0 1 0\nvn 0 1 0\nf 1//1 3//3 2//2\n\n\no Object.2\nv 0.1 1.2 0.3\nv 1.1 1.2 0.3\nv 0.1 1.2 1.3\nvn 0 -1 0\nvn 0 -1 0\nvn 0 -1 0\nf 4//4 5//5 6//6\n"


@pytest.mark.parametrize(
    "text, device",
    [
        (_PORTAL_OBJ, True),
        (_PORTAL_OBJ.replace("\n", "\r\n"), True),  # Windows line ends
        ("# Blender 4.2\n" + _PORTAL_OBJ, False),  # another writer's header
        (_PORTAL_OBJ.replace("o Object.1\n", "o Object.1\nusemtl wall\n"), False),  # materials: not the Device Portal
        (_PORTAL_OBJ.replace("Object.1", "Wall"), False),
        (_PORTAL_OBJ.replace("Object.1", "Object.7"), False),  # it numbers its surfaces from 1
        ("\n".join(_PORTAL_OBJ.splitlines()[3:6]) + "\n" + _PORTAL_OBJ, False),  # vertices before any object
    ],
)
def test_a_hololens_device_portal_obj_declares_its_gravity_aligned_frame(tmp_path, text, device):
    """A HoloLens Device Portal export is recognised by its layout and declares +y as a
    device frame; any other OBJ declares nothing."""
    path = tmp_path / "scan.obj"
    path.write_bytes(text.encode())
    stats = load_mesh(path).stats
    if device:
        assert stats.declared_by == "device" and np.allclose(stats.declared_up, [0.0, 1.0, 0.0])
    else:
        assert stats.declared_by == "format" and stats.declared_up is None


def test_a_gltf_file_declares_y_up(tmp_path):
    """The reader declares +y for glTF (by its specification) and nothing for PLY."""
    from meshplan.io import write_mesh

    v, f = box_room(3.0, 3.0, 2.5, cell=0.5)
    for ext, want in ((".glb", [0.0, 1.0, 0.0]), (".ply", None)):
        write_mesh(Mesh(v, f), tmp_path / f"room{ext}")
        up = load_mesh(tmp_path / f"room{ext}").stats.declared_up
        assert (up is None) if want is None else np.allclose(up, want)


# --- faster passes over the faces, the same numbers (issue 15) ----------------------------------


def _former_surface_samples(mesh, faces, spacing, max_samples=10_000):
    """The sampling of ``meshplan.orient.gravity`` before it kept the one-point faces' points."""
    areas = mesh.face_areas[faces]
    k = np.clip(np.ceil(areas / spacing**2), 1, max_samples).astype(np.int64)
    rep = np.repeat(faces, k)
    j = np.arange(len(rep)) - np.repeat(np.cumsum(k) - k, k)
    g = 1.32471795724474602596
    u = (0.5 + j / g) % 1.0
    v = (0.5 + j / g**2) % 1.0
    fold = u + v > 1.0
    u[fold], v[fold] = 1.0 - u[fold], 1.0 - v[fold]
    single = np.repeat(k == 1, k)
    u[single], v[single] = 1.0 / 3.0, 1.0 / 3.0
    tri = mesh.vertices[mesh.faces[rep]]
    pts = tri[:, 0] + u[:, None] * (tri[:, 1] - tri[:, 0]) + v[:, None] * (tri[:, 2] - tri[:, 0])
    return pts, mesh.face_areas[rep] / np.repeat(k, k)


def test_surface_samples_are_the_former_ones_bit_for_bit():
    from meshplan.orient.gravity import _single_samples, _surface_samples

    rng = np.random.default_rng(3)
    small = rng.normal(size=(600, 3))
    # metre-sized triangles (a parametric wall) among 5 cm ones
    big = np.array([[0, 0, 0], [3, 0, 0], [0, 2.5, 0], [3, 2.5, 0], [0, 0, 4.0]])
    vertices = np.r_[big, small * 0.05 + rng.uniform(0, 4, size=(1, 3))]
    faces = np.r_[[[0, 1, 2], [1, 3, 2], [0, 4, 1]], rng.integers(5, len(vertices), size=(400, 3))]
    mesh = Mesh(vertices, faces)
    for sel in (np.arange(mesh.n_faces), np.array([7, 0, 300, 2, 2, 11]), np.zeros(0, np.int64)):
        for single in (None, _single_samples(mesh)):
            pts, w = _surface_samples(mesh, sel, 0.1, single)
            old_pts, old_w = _former_surface_samples(mesh, sel, 0.1)
            np.testing.assert_array_equal(pts, old_pts)
            np.testing.assert_array_equal(w, old_w)


def test_face_components_number_pieces_as_scipy_does():
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from meshplan.orient.facing import face_components

    rng = np.random.default_rng(7)
    for _ in range(30):
        n_vertices = int(rng.integers(3, 300))
        faces = rng.integers(0, n_vertices, size=(int(rng.integers(1, 150)), 3))
        rows, cols = np.r_[faces[:, 0], faces[:, 1]], np.r_[faces[:, 1], faces[:, 2]]
        graph = coo_matrix((np.ones(len(rows), dtype=np.int8), (rows, cols)), shape=(n_vertices, n_vertices))
        expected = connected_components(graph, directed=False)[1][faces[:, 0]]
        np.testing.assert_array_equal(face_components(faces, n_vertices), expected)
    assert face_components(np.zeros((0, 3), np.int64), 5).shape == (0,)


def test_thin_products_with_one_blas_thread_are_the_same_bits():
    from threadpoolctl import threadpool_limits

    from meshplan.geometry import thin_product, transform_points

    rng = np.random.default_rng(11)
    points = rng.normal(size=(60_000, 3)) * 10.0
    m = homogeneous(np.linalg.qr(rng.normal(size=(3, 3)))[0], [1.0, -2.0, 3.0])
    with threadpool_limits(limits=2, user_api="blas"):
        expected = points @ m[:3, :3].T
    np.testing.assert_array_equal(thin_product(points, m[:3, :3].T), expected)
    np.testing.assert_array_equal(transform_points(m, points), expected + m[:3, 3])


def test_a_very_large_mesh_is_estimated_on_an_even_sample(monkeypatch):
    """Above ``ESTIMATE_MAX_FACES`` the up direction, the levels and the wall directions come
    from every k-th face, each standing for k faces' area: the same orientation as from every
    face (gravity within 0.02 degree, floors and ceilings within 5 mm, the same yaw), the
    stories and facing of every face all the same."""
    from meshplan.orient import orientation

    scan = generate(SynthParams(preset="apartment", seed=2))
    full = orient(scan.mesh)
    sample = orientation.estimation_sample(scan.mesh, scan.mesh.n_faces // 7)
    assert sample is not scan.mesh and 7 <= scan.mesh.n_faces / sample.n_faces <= 9
    assert sample.area == pytest.approx(scan.mesh.area, rel=0.03)  # each face stands for k
    assert orientation.estimation_sample(scan.mesh, scan.mesh.n_faces) is scan.mesh
    monkeypatch.setattr(orientation, "ESTIMATE_MAX_FACES", scan.mesh.n_faces // 7)
    estimated_on = []
    estimate = orientation.estimate_gravity
    monkeypatch.setattr(orientation, "estimate_gravity", lambda m, *a, **k: estimated_on.append(m.n_faces) or estimate(m, *a, **k))
    part = orient(scan.mesh)
    assert estimated_on == [sample.n_faces]  # the limit read when orienting, not when defined
    assert angle_deg(part.gravity.up, full.gravity.up) < 0.02
    assert angle_deg(part.rotation @ [1.0, 0.0, 0.0], full.rotation @ [1.0, 0.0, 0.0]) < 0.05
    for a, b in zip(part.stories, full.stories, strict=True):
        assert abs(a.floor - b.floor) < 0.005 and abs(a.ceiling - b.ceiling) < 0.005
    assert len(part.face_story) == scan.mesh.n_faces and np.mean(part.face_story == full.face_story) > 0.999
    assert len(part.flipped) == scan.mesh.n_faces


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_parametric_apartment_without_ceiling_stands_on_its_floor(seed):
    """The hard-parametric preset (RoomPlan-like boxes, no ceiling): the rooms' walls, each a
    box with two faces, outweigh the floor along their normals; that they share one height
    along the true up only (:func:`meshplan.orient.gravity.common_wall_span`) decides. Up was
    taken along a wall (90 degrees off) on every seed before."""
    from meshplan.orient.gravity import common_wall_span

    scan = generate(SynthParams(preset="hard-parametric", seed=seed))
    o = orient(scan.mesh)
    gravity, yaw, _ = errors(o, scan.truth)
    assert gravity < 0.5 and yaw < 0.5
    up = o.gravity.up
    wrong = [c.axis for c in o.gravity.candidates if abs(c.axis @ up) < 0.5]
    assert wrong and all(common_wall_span(scan.mesh, a, OrientParams()) < 0.5 * common_wall_span(scan.mesh, up, OrientParams()) for a in wrong)
    # a scanned mesh's faces span centimetres: the test says nothing there
    assert common_wall_span(generate(SynthParams(preset="room", seed=seed)).mesh, up, OrientParams()) == 0.0


def test_walls_standing_below_the_floor_turn_a_weak_sign_over():
    """A story without a ceiling whose walls stop below it, its furniture giving the sign of
    up no lead at all (hard preset, seed 2, no open doors: evidence 0.08): up was taken
    downward, the tops of the walls read as the floor, and the run stopped with "no floor
    found". Walls stand on the floor: turned over, they do."""
    scan = generate(SynthParams(preset="hard", seed=2, open_doors=False))
    o = orient(scan.mesh)
    gravity, _, _ = errors(o, scan.truth)
    assert gravity < 0.5
    assert o.gravity.sign_by == "walls on the floor"
    with pytest.raises(GeometryError, match="no floor found"):  # the user's up is not overruled
        orient(scan.mesh, OrientParams(), up_hint=-o.gravity.up)


def test_a_model_of_big_boxes_in_metres_is_no_unit_mistake():
    """A room modelled with triangles 2 m across (a RoomPlan or CAD export without furniture:
    two triangles a wall) is a building in metres. Its median triangle exceeds what scans make,
    which the scale check took for a unit mistake on its own (a clustered RoomPlan room, 1.1 m
    triangles: "no unit makes it a plausible building"); its size says metres."""
    from conftest import box_room
    from meshplan.geometry import Mesh

    v, f = box_room(5.0, 4.0, 2.6, cell=2.0)
    mesh = Mesh(v, f)
    assert np.sqrt(2.0 * np.median(mesh.face_areas)) > 1.0
    o = orient(mesh)
    assert o.transform[1, :3] @ np.array([0.0, 1.0, 0.0]) > np.cos(np.radians(1.0))
    assert o.stories[0].height == pytest.approx(2.6, abs=0.1)  # (2.55: the levels of 32 faces)
    # the same model in centimetres is still refused (2.6 m tall in no direction)
    with pytest.raises(GeometryError, match="implausible scale.*--units"):
        orient(Mesh(v * 100.0, f))


def test_slab_faces_are_the_horizontal_faces_near_a_floor_or_a_ceiling():
    """slab_faces tests the heights of the horizontal faces alone: the same faces as the test
    of every face (horizontal and near a slab), floors and ceilings each on or off."""
    from meshplan.orient import Story
    from meshplan.orient.stories import SLAB_HORIZONTAL_DEG, slab_faces

    rng = np.random.default_rng(5)
    heights = rng.uniform(-0.5, 6.0, 50_000)
    ny = rng.uniform(-1.0, 1.0, 50_000)
    ny[:100] = np.nan  # degenerate faces' normals
    stories = (Story(0, 0.0, 2.6, True, -1.0, 2.8), Story(1, 2.9, 5.5, False, 2.8, 7.0))
    for floors in (True, False):
        for ceilings in (True, False):
            near = np.zeros(len(heights), dtype=bool)
            for s in stories:
                if floors:
                    near |= np.abs(heights - s.floor) < 0.1
                if ceilings and s.ceiling_found:
                    near |= np.abs(heights - s.ceiling) < 0.1
            want = (np.abs(ny) >= np.cos(np.radians(SLAB_HORIZONTAL_DEG))) & near
            got = slab_faces(heights, ny, stories, 0.1, floors=floors, ceilings=ceilings)
            np.testing.assert_array_equal(got, want)
            assert got.dtype == bool and (want.any() or not (floors or ceilings))

"""Point clouds in (issue 14): E57, LAS/LAZ, PLY and text point files, through splats, against the
synthetic scans' ground truth."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from scipy.spatial import cKDTree

import meshplan
from meshplan.batch.discover import find_scans
from meshplan.cli import main
from meshplan.errors import InputError
from meshplan.evaluate import evaluate
from meshplan.export import plan_document
from meshplan.io import load_mesh
from meshplan.io.points import VOXEL_M, read_points
from meshplan.synthetic import SynthParams, generate

pye57 = pytest.importorskip("pye57")
laspy = pytest.importorskip("laspy")

#: Phone LiDAR (about 400 points/m2, 1 cm noise) and terrestrial laser (10,000 points/m2, 2 mm).
PHONE = (400.0, 0.01)
LASER = (10_000.0, 0.002)


def sample_cloud(mesh, density, noise, seed=0):
    """Points on the mesh's faces (``density`` per m2, Gaussian ``noise`` m), with colours and
    intensities."""
    rng = np.random.default_rng(seed)
    n = rng.poisson(mesh.face_areas * density)
    f = np.repeat(np.arange(mesh.n_faces), n)
    s, r = np.sqrt(rng.random(len(f))), rng.random(len(f))
    t = mesh.triangles[f]
    p = (1 - s)[:, None] * t[:, 0] + (s * (1 - r))[:, None] * t[:, 1] + (s * r)[:, None] * t[:, 2]
    p += rng.normal(0.0, noise, p.shape)
    colors = rng.integers(0, 256, (len(p), 3)).astype(np.uint8)
    intensity = rng.random(len(p)).astype(np.float32)
    return p, colors, intensity


def _quat(yaw_deg):
    a = np.radians(yaw_deg) / 2
    return np.array([np.cos(a), 0.0, 0.0, np.sin(a)])  # w x y z: a turn about z


def _rot(yaw_deg):
    a = np.radians(yaw_deg)
    return np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])


def write_e57(path, points, colors=None, intensity=None, scans=2):
    """An E57 file of ``scans`` scans, each stored in its own frame with a pose (turned and
    moved) that puts it back where it was."""
    e57 = pye57.E57(str(path), mode="w")
    for i, part in enumerate(np.array_split(np.arange(len(points)), scans)):
        yaw, t = 30.0 * (i + 1), np.array([1.5 * i, -2.0, 0.25 * i])
        local = (points[part] - t) @ _rot(yaw)  # R^T (p - t), as rows
        data = {"cartesianX": local[:, 0], "cartesianY": local[:, 1], "cartesianZ": local[:, 2]}
        if colors is not None:
            data.update(colorRed=colors[part, 0], colorGreen=colors[part, 1], colorBlue=colors[part, 2])
        if intensity is not None:
            data["intensity"] = intensity[part].astype(np.float64)
        e57.write_scan_raw(data, rotation=_quat(yaw), translation=t)
    e57.close()


def write_las(path, points, colors=None, intensity=None):
    """LAS 1.2, point format 3 (RGB), 0.1 mm resolution; LAZ when ``path`` ends in .laz."""
    header = laspy.LasHeader(point_format=3, version="1.2")
    header.scales = np.array([1e-4, 1e-4, 1e-4])
    header.offsets = points.min(axis=0)
    las = laspy.LasData(header)
    las.x, las.y, las.z = points[:, 0], points[:, 1], points[:, 2]
    if colors is not None:
        las.red, las.green, las.blue = (colors.astype(np.uint16) * 257).T
    if intensity is not None:
        las.intensity = (intensity * 65535).astype(np.uint16)
    las.write(str(path))


def write_ply(path, points, colors=None, binary=True):
    """A PLY point cloud (vertices only), with colour when given."""
    props = [("x", "<f8"), ("y", "<f8"), ("z", "<f8")] + ([("red", "u1"), ("green", "u1"), ("blue", "u1")] if colors is not None else [])
    rec = np.zeros(len(points), dtype=props)
    rec["x"], rec["y"], rec["z"] = points.T
    if colors is not None:
        rec["red"], rec["green"], rec["blue"] = colors.T
    names = {"<f8": "double", "u1": "uchar"}
    head = f"ply\nformat {'binary_little_endian' if binary else 'ascii'} 1.0\nelement vertex {len(points)}\n"
    head += "".join(f"property {names[t]} {n}\n" for n, t in props) + "end_header\n"
    if binary:
        path.write_bytes(head.encode() + rec.tobytes())
    else:
        cols = [rec[n] for n, _ in props]
        body = "".join(" ".join(repr(c[i].item()) for c in cols) + "\n" for i in range(len(points)))
        path.write_text(head + body)


@pytest.fixture(scope="module")
def apartment():
    return generate(SynthParams(preset="apartment", seed=1))


def _scores(result, truth):
    report = evaluate(plan_document(result), truth)
    heights = [h["error_m"] for h in report["heights"] if h["error_m"] is not None]
    rooms = report["rooms"]
    errors = [abs(r["error_pct"]) for r in rooms["rows"] if r["error_pct"] is not None]
    return report, heights, rooms, errors


def _check(result, truth):
    report, heights, rooms, errors = _scores(result, truth)
    assert report["gravity_error_deg"] <= 0.2, report["gravity_error_deg"]
    assert len(heights) == 2 * len(truth["stories"]) and max(heights) <= 0.02, heights
    assert report["walls"]["f1"] >= 0.9, report["walls"]
    assert rooms["found"] == rooms["true_rooms"], rooms
    assert np.median(errors) <= 1.0, errors


# ----------------------------------------------------------------------------------------------
# readers


def test_every_reader_gives_the_same_points_colours_and_intensities(tmp_path):
    rng = np.random.default_rng(3)
    p = rng.random((500, 3)) * [4.0, 3.0, 2.5] + [100.0, -20.0, 5.0]
    colors = rng.integers(0, 256, (500, 3)).astype(np.uint8)
    intensity = rng.random(500).astype(np.float32)
    write_e57(tmp_path / "a.e57", p, colors, intensity, scans=3)
    write_las(tmp_path / "a.las", p, colors, intensity)
    write_las(tmp_path / "a.laz", p, colors, intensity)
    write_ply(tmp_path / "a.ply", p, colors)
    write_ply(tmp_path / "b.ply", p, colors, binary=False)
    pl, cl, il = p.tolist(), colors.tolist(), intensity.tolist()
    (tmp_path / "a.xyz").write_text("".join(f"{x!r} {y!r} {z!r} {r} {g} {b}\n" for (x, y, z), (r, g, b) in zip(pl, cl)))
    (tmp_path / "a.pts").write_text(f"{len(p)}\n" + "".join(f"{x!r} {y!r} {z!r} {i!r} {r} {g} {b}\n" for (x, y, z), i, (r, g, b) in zip(pl, il, cl)))
    (tmp_path / "a.txt").write_text("X,Y,Z\n" + "".join(f"{x!r},{y!r},{z!r}\n" for x, y, z in pl))
    (tmp_path / "a.obj").write_text("# points\n" + "".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in pl))
    for name, tol, has_rgb, has_i in [
        ("a.e57", 1e-4, True, True), ("a.las", 1e-4, True, True), ("a.laz", 1e-4, True, True), ("a.ply", 0, True, False),
        ("b.ply", 1e-9, True, False), ("a.xyz", 0, True, False), ("a.pts", 0, True, True), ("a.txt", 0, False, False), ("a.obj", 0, False, False),
    ]:
        cloud = read_points(tmp_path / name)
        assert len(cloud) == len(p), name
        # matched by position: E57 scans come back one after another (pye57 writes float32), LAS
        # rounds to its 0.1 mm scale
        dist, order = cKDTree(cloud.points).query(p)
        ref = np.arange(len(p))
        assert dist.max() <= tol + 1e-12 and len(set(order)) == len(p), name
        assert (cloud.colors is not None) == has_rgb, name
        if has_rgb:
            assert np.array_equal(cloud.colors[order], colors[ref]), name
        assert (cloud.intensity is not None) == has_i, name
        if name == "a.e57":
            assert cloud.scans == 3
            assert np.allclose(cloud.intensity[order], intensity[ref], atol=1e-6)


@pytest.mark.slow
def test_a_ply_with_points_and_no_faces_is_read_as_a_cloud(tmp_path, apartment):
    p, colors, _ = sample_cloud(apartment.mesh, *PHONE)
    write_ply(tmp_path / "cloud.ply", p, colors)
    loaded = load_mesh(tmp_path / "cloud.ply")
    st = loaded.stats
    assert st.points_read == len(p) and 0 < st.points <= len(p) and st.faces == loaded.mesh.n_faces
    assert loaded.cloud.colors is not None and len(loaded.cloud) == st.points
    assert st.to_dict()["points_read"] == len(p)
    # the splats stand for the surface: their area is within 15 % of the mesh's
    assert abs(loaded.mesh.area - apartment.mesh.area) / apartment.mesh.area < 0.15


def test_too_few_points_are_refused(tmp_path):
    path = tmp_path / "three.ply"
    path.write_bytes(b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n")
    with pytest.raises(InputError, match="holds points but no triangles.*mesh the point cloud first"):
        load_mesh(path)


@pytest.mark.slow
def test_voxel_size_and_max_faces(tmp_path, apartment):
    p, _, _ = sample_cloud(apartment.mesh, 2000.0, 0.002)
    write_ply(tmp_path / "dense.ply", p)
    fine = load_mesh(tmp_path / "dense.ply", point_voxel_m=0.02).stats.points
    coarse = load_mesh(tmp_path / "dense.ply").stats.points
    assert fine > 1.3 * coarse  # a finer grid keeps more of the 2,000 points/m2 (all of them at 2.25 times the cell count)
    with pytest.raises(InputError, match="more than --max-faces 1,000"):
        load_mesh(tmp_path / "dense.ply", max_faces=1000)


@pytest.mark.parametrize("module, ext, words", [("pye57", "e57", "reading E57 needs pye57"), ("laspy", "las", "reading LAS needs laspy")])
def test_a_missing_extra_is_one_line_before_any_work(tmp_path, monkeypatch, capsys, module, ext, words):
    path = tmp_path / f"scan.{ext}"
    path.write_bytes(b"not read")
    monkeypatch.setitem(sys.modules, module, None)  # import fails
    out = tmp_path / "out"
    code = main(["run", str(path), "-o", str(out)])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err == f"error: {words}; pip install 'meshplan[points]'", err
    assert not out.exists()


def test_batch_finds_point_clouds_and_usd(tmp_path):
    for name in ("a.e57", "b.las", "c.laz", "d.xyz", "e.pts", "f.usdz", "g.usda", "h.ply"):
        (tmp_path / name).write_bytes(b"x")
    (tmp_path / "points.txt").write_text("// x y z\n1.0 2.0 3.0\n")
    (tmp_path / "notes.txt").write_text("scanned on Monday\n")
    found = {p.name for p in find_scans(tmp_path)}
    assert found == {"a.e57", "b.las", "c.laz", "d.xyz", "e.pts", "f.usdz", "g.usda", "h.ply", "points.txt"}


# ----------------------------------------------------------------------------------------------
# the pipeline on clouds, against the truth


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["e57", "las", "ply"])
def test_phone_cloud_of_the_apartment(tmp_path, apartment, fmt):
    p, colors, intensity = sample_cloud(apartment.mesh, *PHONE)
    path = tmp_path / f"apartment.{fmt}"
    {"e57": write_e57, "las": write_las, "ply": write_ply}[fmt](path, p, colors, *([intensity] if fmt != "ply" else []))
    result = meshplan.run(path, annotations=None)
    assert result.input.format == fmt and result.input.points_read == len(p)
    _check(result, apartment.truth)


@pytest.mark.slow
def test_laser_cloud_of_a_room(tmp_path):
    """10,000 points/m2 (a room, to keep the test fast: 0.8 million points) subsampled to the
    3 cm grid."""
    scan = generate(SynthParams(preset="room", seed=1))
    p, colors, intensity = sample_cloud(scan.mesh, *LASER)
    path = tmp_path / "room.e57"
    write_e57(path, p, colors, intensity, scans=3)
    result = meshplan.run(path)
    assert result.input.points < len(p) / 5  # the grid keeps about one point in seven
    _check(result, scan.truth)


@pytest.mark.slow
def test_pen_and_ink_plan_of_a_cloud_is_the_slices_of_its_splats(tmp_path, apartment):
    p, _, _ = sample_cloud(apartment.mesh, *PHONE)
    write_ply(tmp_path / "apartment.ply", p)
    out = tmp_path / "out"
    result = meshplan.run(tmp_path / "apartment.ply", output=out, slices=20)
    assert (out / "pen-and-ink-0.png").stat().st_size > 10_000
    segments = np.asarray(result.stories[0].pen_and_ink.slices.segments).reshape(-1, 2, 2)
    assert len(segments) > 10_000
    # the cut of a splat is no longer than its side (a few cm), not a metre-wide stray line
    assert np.percentile(np.linalg.norm(segments[:, 1] - segments[:, 0], axis=1), 99) < 4 * VOXEL_M


# ----------------------------------------------------------------------------------------------
# LAS units from the CRS; what plan.json says of a cloud

#: The US survey foot, metres (1200/3937, exact by definition).
US_FOOT_M = 1200.0 / 3937.0

#: WKT1 of a state plane CRS in US survey feet (EPSG 2227), and a compound one with metre heights.
WKT_US_FEET = (
    'PROJCS["NAD83 / California zone 3 (ftUS)",GEOGCS["NAD83",DATUM["North_American_Datum_1983",'
    'SPHEROID["GRS 1980",6378137,298.257222101]],PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433]],'
    'PROJECTION["Lambert_Conformal_Conic_2SP"],PARAMETER["false_easting",6561666.667],'
    'UNIT["US survey foot",0.3048006096012192,AUTHORITY["EPSG","9003"]],AXIS["Easting",EAST],AXIS["Northing",NORTH],'
    'AUTHORITY["EPSG","2227"]]'
)
WKT_US_FEET_METRE_HEIGHTS = (
    f'COMPD_CS["NAD83 / California zone 3 (ftUS) + NAVD88 height",{WKT_US_FEET},'
    'VERT_CS["NAVD88 height",VERT_DATUM["North American Vertical Datum 1988",2005],UNIT["metre",1,AUTHORITY["EPSG","9001"]],'
    'AXIS["Gravity-related height",UP]]]'
)

#: y up (the synthetic scans) to LAS's z up: (x, y, z) -> (x, -z, y), a rotation.
Y_UP_TO_Z_UP = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


def geo_keys_vlr(keys):
    """A GeoKeyDirectoryTag record holding ``keys`` ``{key id: value}`` (all stored inline)."""
    from laspy.vlrs.known import GeoKeyDirectoryVlr, GeoKeyEntryStruct

    vlr = GeoKeyDirectoryVlr()
    entries = [GeoKeyEntryStruct(id=k, tiff_tag_location=0, count=1, value_offset=v) for k, v in keys.items()]
    vlr.geo_keys = entries
    vlr.geo_keys_header.number_of_keys = len(entries)
    return vlr


def write_las_crs(path, points_m, horizontal_m, vertical_m, *, wkt=None, geo_keys=None):
    """``points_m`` (z up, metres) written in the CRS's units, with its WKT or GeoTIFF keys."""
    from laspy.vlrs.known import WktCoordinateSystemVlr

    stored = points_m / np.array([horizontal_m, horizontal_m, vertical_m])
    header = laspy.LasHeader(point_format=3, version="1.2")
    header.scales = np.array([1e-4, 1e-4, 1e-4])
    header.offsets = stored.min(axis=0)
    if wkt is not None:
        header.vlrs.append(WktCoordinateSystemVlr(wkt))
    if geo_keys is not None:
        header.vlrs.append(geo_keys_vlr(geo_keys))
    las = laspy.LasData(header)
    las.x, las.y, las.z = stored.T
    las.write(str(path))


@pytest.fixture(scope="module")
def room_z_up():
    """The synthetic room, sampled at phone density, z up (as LAS is); its truth turned along."""
    scan = generate(SynthParams(preset="room", seed=1))
    p, _, _ = sample_cloud(scan.mesh, *PHONE, seed=3)
    points = p @ Y_UP_TO_Z_UP[:3, :3].T
    truth = dict(scan.truth, transform=(Y_UP_TO_Z_UP @ np.asarray(scan.truth["transform"], float)).tolist())
    return points, truth


@pytest.mark.slow
@pytest.mark.parametrize(
    "crs, horizontal_m, vertical_m, named",
    [
        ({"wkt": WKT_US_FEET}, US_FOOT_M, US_FOOT_M, "ft"),
        ({"wkt": WKT_US_FEET_METRE_HEIGHTS}, US_FOOT_M, 1.0, "ft"),
        ({"geo_keys": {1024: 1, 3072: 2227, 3076: 9003, 4099: 9001}}, US_FOOT_M, 1.0, "ft"),
        ({"geo_keys": {1024: 1, 3072: 32633, 3076: 9002}}, 0.3048, 0.3048, "ft"),
        ({"geo_keys": {1024: 1, 3072: 32633, 3076: 9001}}, 1.0, 1.0, "m"),
    ],
    ids=["wkt-us-feet", "wkt-compound-us-feet-metre-heights", "geotiff-us-feet-metre-heights", "geotiff-feet", "geotiff-metres"],
)
def test_las_units_come_from_its_crs(tmp_path, room_z_up, crs, horizontal_m, vertical_m, named):
    points, truth = room_z_up
    path = tmp_path / "room.las"
    write_las_crs(path, points, horizontal_m, vertical_m, **crs)
    cloud = read_points(path)
    assert cloud.crs_units.horizontal_m == pytest.approx(horizontal_m, rel=1e-12)
    assert cloud.crs_units.vertical_m == pytest.approx(vertical_m, rel=1e-12)
    result = meshplan.run(path)
    assert result.input.units == named and result.input.scale_to_m == pytest.approx(horizontal_m, rel=1e-12)
    _check(result, truth)  # heights within 2 cm, walls and rooms: the cloud was read in metres
    doc = plan_document(result)
    assert doc["input"]["scale_to_m"] == pytest.approx(horizontal_m, rel=1e-10) and doc["input"]["units"] == named


@pytest.mark.slow
def test_units_given_override_the_las_crs(tmp_path, room_z_up, caplog):
    points, _ = room_z_up
    path = tmp_path / "room.las"
    # metres in the file, a CRS that wrongly says US feet: --units cm is what the user says
    write_las_crs(path, points * 100.0, 1.0, 1.0, wkt=WKT_US_FEET)
    loaded = load_mesh(path, units="cm")
    assert loaded.stats.units == "cm" and loaded.stats.scale_to_m == 0.01
    assert np.allclose(np.ptp(loaded.mesh.vertices, axis=0), np.ptp(points, axis=0), atol=0.05)
    assert "read in --units cm as asked" in caplog.text
    # without --units the CRS's feet are applied
    feet = load_mesh(path)
    assert feet.stats.units == "ft" and np.allclose(np.ptp(feet.mesh.vertices, axis=0), 100.0 * US_FOOT_M * np.ptp(points, axis=0), rtol=0.01)
    # --units m named on purpose overrides the CRS too (the default m does not)
    write_las_crs(path, points, 1.0, 1.0, wkt=WKT_US_FEET)
    metres = load_mesh(path, units="m", units_explicit=True)
    assert metres.stats.units == "m" and metres.stats.scale_to_m == 1.0
    assert np.allclose(np.ptp(metres.mesh.vertices, axis=0), np.ptp(points, axis=0), atol=0.05)
    assert load_mesh(path, units="m").stats.units == "ft"
    import meshplan

    assert meshplan.run(path, units="m").input.units == "m"  # as `meshplan run --units m` passes it


@pytest.mark.slow
def test_a_las_without_crs_or_with_degrees_is_read_in_units(tmp_path, room_z_up):
    points, _ = room_z_up
    write_las(tmp_path / "plain.las", points)
    assert read_points(tmp_path / "plain.las").crs_units is None
    geographic = 'GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433]]'
    write_las_crs(tmp_path / "degrees.las", points, 1.0, 1.0, wkt=geographic, geo_keys={1024: 2, 2048: 4326})
    assert read_points(tmp_path / "degrees.las").crs_units is None
    stats = load_mesh(tmp_path / "degrees.las", units="ft").stats
    assert stats.units == "ft" and stats.scale_to_m == pytest.approx(0.3048)


@pytest.mark.slow
def test_plan_json_says_how_a_cloud_was_subsampled(tmp_path, room_z_up):
    import jsonschema

    from meshplan.export.planjson import plan_schema

    points, _ = room_z_up
    path = tmp_path / "room.ply"
    nan = np.full((7, 3), np.nan)
    write_ply(path, np.concatenate([points, nan]))
    result = meshplan.run(path, point_voxel_m=0.04)
    doc = plan_document(result)
    jsonschema.validate(doc, plan_schema())
    inp = doc["input"]
    assert inp["points_read"] == len(points) + 7 and inp["dropped_nonfinite_points"] == 7
    assert inp["voxel_m"] == 0.04 and doc["parameters"]["input"]["point_voxel_m"] == 0.04
    # one point per occupied 4 cm voxel: as many as the cells the (finite) points fall into
    cells = len(np.unique(np.floor(points / 0.04).astype(np.int64), axis=0))
    assert inp["points"] == result.input.points and abs(inp["points"] - cells) <= 0.01 * cells
    assert inp["points"] < inp["points_read"] and "parametric" not in inp
    # a mesh says nothing of points
    from meshplan.io import write_mesh

    write_mesh(generate(SynthParams(preset="room", seed=1)).mesh, tmp_path / "mesh.ply")
    mesh_doc = plan_document(meshplan.run(tmp_path / "mesh.ply"))
    assert "points_read" not in mesh_doc["input"] and "voxel_m" not in mesh_doc["input"]

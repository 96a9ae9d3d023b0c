"""Geometry kernels: rigid transforms, spherical k-means, box DBSCAN, slicing."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.cluster import DBSCAN

from conftest import angle_deg
from meshplan.errors import ParameterError
from meshplan.geometry import Annotations, Mesh, homogeneous, is_rigid, rotation_about_y, rotation_between
from meshplan.orient.params import PAPER_TRIM_SCHEDULE_DEG
from meshplan.slicing import plane_heights, slice_mesh
from meshplan.sphere import axial_peaks, to_spherical, trimmed_spherical_kmeans
from meshplan.walls import BoxDBSCAN, box_dbscan


def random_rotation(rng) -> np.ndarray:
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def test_rotation_between_maps_and_is_rigid():
    rng = np.random.default_rng(0)
    for _ in range(50):
        a, b = rng.normal(size=3), rng.normal(size=3)
        r = rotation_between(a, b)
        assert np.allclose(r @ (a / np.linalg.norm(a)), b / np.linalg.norm(b))
        assert is_rigid(homogeneous(r))
    assert np.allclose(rotation_between([0, 1, 0], [0, -1, 0]) @ [0, 1, 0], [0, -1, 0])
    assert np.allclose(rotation_about_y(np.pi / 2) @ [1, 0, 0], [0, 0, -1])


def test_mesh_transform_keeps_normals_and_areas():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 0, 1.0]])
    m = Mesh(v, [[0, 2, 1]])
    assert np.allclose(m.face_normals, [[0, 1, 0]])
    rng = np.random.default_rng(1)
    r = random_rotation(rng)
    t = m.transformed(homogeneous(r, [1, 2, 3]))
    assert np.allclose(t.face_normals, (r @ [0, 1, 0])[None])
    assert t.area == pytest.approx(m.area)
    # a mirror keeps normals on the same side of the surface
    mirror = np.diag([-1.0, 1, 1, 1])
    assert np.allclose(m.transformed(mirror).face_normals, [[0, 1, 0]])


@pytest.mark.parametrize(
    "matrix",
    [
        [[0, -1, 0, 1], [1, 0, 0, 2], [0, 0, 1, 3], [0, 0, 0, 1]],  # a rotation and a shift
        [[1, 0, 0, 0], [0, -1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]],  # a reflection
        [[2, 0.3, 0, 0], [0, 3, 0, 0], [0.1, 0, 0.5, 0], [0, 0, 0, 1]],  # not rigid
    ],
)
def test_transformed_and_flipped_meshes_carry_their_corners_and_normals_over(matrix):
    """The corners and cross products a mesh computed are mapped into the transformed (and
    flipped) mesh instead of computed again: they equal those computed from its vertices."""
    rng = np.random.default_rng(3)
    v = rng.normal(size=(300, 3))
    f = np.array([t for t in rng.integers(0, 300, size=(1500, 3)) if len(set(t)) == 3])
    m = Mesh(v, f)
    _ = m.face_normals  # computed and cached
    flip = rng.random(len(f)) < 0.4
    a = m.transformed(np.array(matrix, dtype=float)).with_flipped(flip)
    assert "triangles" in a.__dict__ and "_cross" in a.__dict__  # carried over
    b = Mesh(a.vertices, a.faces)  # computed from scratch
    np.testing.assert_allclose(a.triangles, b.triangles, atol=1e-12)
    np.testing.assert_allclose(a.face_normals, b.face_normals, atol=1e-12)
    np.testing.assert_allclose(a.face_areas, b.face_areas, rtol=1e-12, atol=1e-12)
    # the same in one pass (the plan mesh's way), with or without the cache
    for mesh in (m, Mesh(v, f)):
        c = mesh.transformed(np.array(matrix, dtype=float), flip)
        np.testing.assert_array_equal(c.faces, a.faces)
        np.testing.assert_allclose(c.vertices, a.vertices, atol=1e-12)
        np.testing.assert_allclose(c.face_normals, b.face_normals, atol=1e-12)
        assert not c.faces.flags.writeable and not c.vertices.flags.writeable


def test_a_mesh_computes_its_released_arrays_again():
    """``release_derived`` forgets the cached corners and normals (the pipeline frees the input
    mesh's once the plan mesh exists); asked for again, they are the same."""
    rng = np.random.default_rng(4)
    m = Mesh(rng.normal(size=(50, 3)), np.array([t for t in rng.integers(0, 50, size=(80, 3)) if len(set(t)) == 3]))
    before = (m.triangles.copy(), m.face_normals.copy(), m.face_centroids.copy(), m.face_areas.copy())
    m.release_derived()
    assert not {"triangles", "_cross", "face_normals", "face_centroids", "face_areas"} & set(m.__dict__)
    for a, b in zip(before, (m.triangles, m.face_normals, m.face_centroids, m.face_areas)):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("matrix", [homogeneous(rotation_about_y(0.7), [1, 2, 3]), np.diag([-1.0, 1, 1, 1])])
def test_a_transformed_mesh_reuses_the_arrays_its_source_gives_up_and_no_others(matrix):
    """``transformed(..., reuse=True)`` writes the mapped corners and cross products over the
    source's (the plan mesh's way: 0.29 GB of fresh memory at 3M faces), the same numbers as
    into fresh arrays; the source forgets them and computes them again if asked; an array
    something else still refers to (a view of it) is never written over, nor where a mirror
    reorders the corners."""
    rng = np.random.default_rng(5)
    v = rng.normal(size=(400, 3))
    f = np.array([t for t in rng.integers(0, 400, size=(2000, 3)) if len(set(t)) == 3])
    flip = rng.random(len(f)) < 0.3
    expected = Mesh(v, f)
    _ = expected.face_normals
    expected = expected.transformed(matrix, flip)  # into fresh arrays
    mirror = np.linalg.det(matrix[:3, :3]) < 0

    src = Mesh(v, f)
    _ = src.face_normals
    before = src.triangles.copy()
    address = src.triangles.ctypes.data, src._cross.ctypes.data
    out = src.transformed(matrix, flip, reuse=True)
    np.testing.assert_array_equal(out.triangles, expected.triangles)
    np.testing.assert_array_equal(out._cross, expected._cross)
    np.testing.assert_array_equal(out.face_normals, expected.face_normals)
    reused = (out.triangles.ctypes.data, out._cross.ctypes.data) == address
    assert reused is (not mirror)
    assert not out.triangles.flags.writeable and not out._cross.flags.writeable
    if reused:  # the memory's owner is read-only again as well
        assert not out.triangles.base.flags.writeable
    assert not {"triangles", "_cross"} & set(src.__dict__)
    np.testing.assert_array_equal(src.triangles, before)  # computed again from its vertices

    held = Mesh(v, f)
    _ = held.face_normals
    column = held.triangles[:, 0]  # a view: someone still reads the source's corners
    kept = column.copy()
    out = held.transformed(matrix, flip, reuse=True)
    np.testing.assert_array_equal(column, kept)
    np.testing.assert_array_equal(out.triangles, expected.triangles)
    assert not np.shares_memory(out.triangles, column)


def test_annotations_transform():
    ann = Annotations(("S1",), ("sensor",), [[1, 0, 0]], [[0, 0, 1]])
    m = homogeneous(rotation_about_y(np.pi / 2), [0, 5, 0])
    out = ann.transformed(m)
    assert np.allclose(out.positions, [[0, 5, -1]])
    assert np.allclose(out.directions, [[1, 0, 0]])
    with pytest.raises(ValueError):
        Annotations(("S1",), ("lamp",), [[0, 0, 0]], [[np.nan] * 3])


def test_spherical_coordinates_match_the_paper():
    theta, phi = to_spherical(np.array([[1, 0, 0], [0, 0, 1], [0, 1, 0], [0, -1, 0]]))
    assert np.allclose(theta[:2], [0, 90])
    assert np.allclose(phi, [90, 90, 180, 0])


def _noisy_directions(rng, centres, n, sigma_deg, outliers):
    pts = []
    for c in centres:
        d = c + rng.normal(scale=np.radians(sigma_deg), size=(n, 3))
        pts.append(d / np.linalg.norm(d, axis=1, keepdims=True))
    o = rng.normal(size=(outliers, 3))
    pts.append(o / np.linalg.norm(o, axis=1, keepdims=True))
    return np.concatenate(pts)


def test_trimmed_kmeans_recovers_wall_directions_despite_outliers():
    rng = np.random.default_rng(2)
    yaw = np.radians(17.0)
    centres = np.array([[np.cos(yaw + k * np.pi / 2), 0, np.sin(yaw + k * np.pi / 2)] for k in range(4)])
    x = _noisy_directions(rng, centres, 20000, 6.0, 40000)  # half the data is clutter
    init = np.array([[np.cos(k * np.pi / 2), 0, np.sin(k * np.pi / 2)] for k in range(4)])
    res = trimmed_spherical_kmeans(x, None, init, PAPER_TRIM_SCHEDULE_DEG)
    for c in centres:
        assert min(angle_deg(c, r) for r in res.centers) < 0.3
    # without trimming, the clutter drags the centres away
    plain = trimmed_spherical_kmeans(x, None, init, schedule_deg=())
    assert max(min(angle_deg(c, r) for r in plain.centers) for c in centres) > 0.3
    assert (res.labels >= 0).sum() < len(x) / 2


def test_axial_peaks_ignore_the_sign():
    rng = np.random.default_rng(3)
    up = np.array([0.3, 0.9, 0.2])
    up /= np.linalg.norm(up)
    x = _noisy_directions(rng, [up, -up], 3000, 3.0, 1000)
    peaks = axial_peaks(x, np.ones(len(x)))
    assert angle_deg(peaks[0].axis, up) < 1.0 or angle_deg(peaks[0].axis, -up) < 1.0


def test_axial_peaks_sit_on_exact_directions_however_they_are_turned():
    """A parametric model's normals: a few exact directions (floor and ceiling up, four walls).
    Turned at random, each peak lies on its direction. Before sphere._cap_mode, in 133 of 200
    turns a peak stayed on a histogram bin 8.0-9.8 degrees off its direction (the cap around
    the bin's centre held none of the directions the bin counted)."""
    from scipy.spatial.transform import Rotation

    dirs = np.array([[0, 1, 0], [0, -1, 0], [1, 0, 0], [-1, 0, 0], [0, 0, 1], [0, 0, -1]], float)
    w = np.array([28.5, 20.0, 25.0, 25.0, 21.0, 21.0])
    worst = 0.0
    for seed in range(200):
        turn = Rotation.random(random_state=seed).as_matrix()
        peaks = axial_peaks(dirs @ turn.T, w)
        for axis in (turn @ dirs[0], turn @ dirs[2], turn @ dirs[4]):
            worst = max(worst, min(min(angle_deg(p.axis, axis), angle_deg(p.axis, -axis)) for p in peaks))
    assert worst < 1e-6


# --------------------------------------------------------------------------------------------
# box DBSCAN


@pytest.mark.parametrize("seed", range(12))
def test_box_dbscan_equals_textbook_dbscan_with_chebyshev(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(30, 1200))
    pts = np.c_[rng.uniform(0, 4, n), rng.normal(0, 0.04, n) + rng.integers(0, 3, n) * 0.25, rng.uniform(0, 2.6, n)]
    if seed % 3 == 0:
        pts = np.round(pts * 20) / 20  # many points exactly on box boundaries
    half = np.array([0.2286, 0.0508, 1.3])
    m = int(rng.integers(1, 12))
    labels, core = box_dbscan(pts, half, m)
    ref = DBSCAN(eps=1.0, min_samples=m, metric="chebyshev").fit(pts / half)
    ref_core = np.zeros(n, bool)
    ref_core[ref.core_sample_indices_] = True
    assert np.array_equal(core, ref_core)
    assert np.array_equal(labels == -1, ref.labels_ == -1)
    # the core points are partitioned identically
    pairs = set(zip(labels[core], ref.labels_[core]))
    assert len(pairs) == len(set(labels[core])) == len(set(ref.labels_[core]))
    mapping = dict(pairs)
    # a border point belongs to the cluster of one of its core neighbours
    scaled = pts / half
    for i in np.flatnonzero(~core & (labels >= 0)):
        near = core & (np.abs(scaled - scaled[i]).max(axis=1) <= 1.0)
        assert mapping.get(labels[i], labels[i]) in set(ref.labels_[near])


def test_box_dbscan_estimator_and_errors():
    pts = np.array([[0, 0, 0], [0.2, 0, 0], [0.4, 0, 0], [5, 0, 0]])
    assert BoxDBSCAN((0.25, 0.05, 1.0), 2).fit_predict(pts).tolist() == [0, 0, 0, -1]
    with pytest.raises(ParameterError):
        box_dbscan(pts, (0, 1, 1), 2)
    with pytest.raises(ParameterError):
        box_dbscan(pts, (1, 1, 1), 0)
    assert len(box_dbscan(np.zeros((0, 3)), (1, 1, 1), 3)[0]) == 0


# --------------------------------------------------------------------------------------------
# slicing


def test_slicing_a_box_reproduces_its_walls():
    from conftest import box_room

    v, f = box_room(5.0, 4.0, 2.6, cell=0.1)
    m = Mesh(v, f)
    s = slice_mesh(m.triangles, plane_heights(0.0, 2.6, 100))
    assert set(np.unique(s.level)) == set(range(1, 101))  # the floor plane touches only the floor
    for i in (10, 50, 99):
        seg = s.at(i)
        length = np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1).sum()
        assert length == pytest.approx(2 * (5.0 + 4.0), rel=1e-9)
        pts = seg.reshape(-1, 2)
        on_wall = np.minimum.reduce([np.abs(pts[:, 0]), np.abs(pts[:, 0] - 5), np.abs(pts[:, 1]), np.abs(pts[:, 1] - 4)])
        assert on_wall.max() < 1e-9


def test_slicing_is_exact_on_a_tilted_triangle():
    """The cut points are the plane's intersections with the two edges it crosses, worked out
    by hand (an edge midpoint or a wrong interpolation weight lands elsewhere)."""
    tri = np.array([[[0, 0, 0], [2, 1, 0], [0, 2, 2]]], float)
    s = slice_mesh(tri, [0.5, 1.0, 1.5])
    assert len(s) == 3 and s.level.tolist() == [0, 1, 2] and s.face.tolist() == [0, 0, 0]
    expected = {
        0: {(1.0, 0.0), (0.0, 0.5)},  # y = 0.5: halfway along A-B, a quarter along A-C
        1: {(2.0, 0.0), (0.0, 1.0)},  # y = 1.0: through B itself, halfway along A-C
        2: {(0.0, 1.5), (1.0, 1.0)},  # y = 1.5: three quarters along A-C, halfway along B-C
    }
    for seg, level in zip(s.segments, s.level):
        got = {tuple(np.round(p, 12)) for p in seg}
        assert got == expected[int(level)], (level, seg)
    with pytest.raises(ParameterError):
        plane_heights(0, 1, 0)


def _former_slice_mesh(tri, h):
    """``slice_mesh`` before it read the corners by flat index (issue 15): the reference."""
    y = tri[:, :, 1]
    first = np.searchsorted(h, y.min(axis=1), side="right")
    count = np.searchsorted(h, y.max(axis=1), side="right") - first
    faces = np.repeat(np.arange(len(tri)), count)
    level = np.repeat(first, count) + np.arange(len(faces)) - np.repeat(np.cumsum(count) - count, count)
    d = y[faces] - h[level][:, None]
    above = d >= 0
    n_above = above.sum(axis=1)
    cut = (n_above == 1) | (n_above == 2)
    faces, level, d, above, n_above = faces[cut], level[cut], d[cut], above[cut], n_above[cut]
    odd = np.where(n_above == 1, np.argmax(above, axis=1), np.argmin(above, axis=1))
    rows = np.arange(len(faces))
    t = tri[faces]
    p0, d0 = t[rows, odd][:, [0, 2]], d[rows, odd]
    seg = np.stack([p0 + (t[rows, u][:, [0, 2]] - p0) * (d0 / (d0 - d[rows, u]))[:, None] for u in ((odd + 1) % 3, (odd + 2) % 3)], axis=1)
    real = np.any(seg[:, 0] != seg[:, 1], axis=1)
    return seg[real], level[real], faces[real]


@pytest.mark.parametrize("kind", ["grid", "noise"])
def test_slicing_gives_the_former_segments_bit_for_bit(kind):
    """Vertices on a grid of the plane spacing (corners exactly on planes, edges in them) and
    random triangles: the same segments, levels and faces as the former implementation."""
    rng = np.random.default_rng(0)
    if kind == "grid":
        tri, h = rng.integers(0, 6, size=(20_000, 3, 3)) * 0.5, np.arange(0.0, 3.01, 0.5)
    else:
        tri, h = rng.normal(size=(20_000, 3, 3)), np.linspace(-1.0, 1.0, 9)
    s = slice_mesh(tri, h)
    seg, level, face = _former_slice_mesh(tri, h)
    np.testing.assert_array_equal(s.segments, seg)
    np.testing.assert_array_equal(s.level, level)
    np.testing.assert_array_equal(s.face, face)


@pytest.mark.parametrize("kind", ["grid", "noise"])
def test_slicing_selected_faces_in_place_gives_the_slice_of_their_copy(kind):
    """slice_mesh(select=) reads the selected faces in place (their heights, and the corners of
    those a plane cuts): the same segments, in the same order, faces and levels, as slicing a
    copy of them, corners exactly on the plane included (the grid), one plane or many."""
    rng = np.random.default_rng(1)
    tri = rng.integers(0, 6, size=(20_000, 3, 3)) * 0.5 if kind == "grid" else rng.normal(size=(20_000, 3, 3))
    faces = np.sort(rng.choice(len(tri), size=12_000, replace=False))
    for h in ([0.5], [1.0], [0.25], [-3.0], np.arange(-1.0, 2.51, 0.25)):
        whole, s = slice_mesh(tri[faces], h), slice_mesh(tri, h, faces)
        assert len(s.segments) == len(whole.segments) and (h[0] == -3.0 or len(s.segments) > 100)
        for a, b in ((s.segments, whole.segments), (s.face, whole.face), (s.level, whole.level)):
            np.testing.assert_array_equal(a, b)
    assert not len(slice_mesh(tri, [0.5], np.zeros(0, np.int64)).segments)


def test_slicing_an_edge_on_a_plane_gives_it_once_from_the_triangle_below():
    """The module's rule: a vertex exactly on a plane counts as above it, so an edge lying in a
    plane comes once, from the triangle below it, and a vertex touching it gives nothing."""
    below = [[0, 0, 0], [2, 1, 0], [0, 1, 2]]  # its edge B-C lies in y = 1
    above = [[2, 1, 0], [0, 1, 2], [2, 2, 2]]  # shares that edge, rises above it
    touch = [[5, 0, 5], [6, 0, 5], [5, 1, 6]]  # touches y = 1 with one vertex
    s = slice_mesh(np.array([below, above, touch], float), [1.0])
    assert s.face.tolist() == [0]
    assert {tuple(p) for p in s.segments[0]} == {(2.0, 0.0), (0.0, 2.0)}


@pytest.mark.parametrize("longest_m", [0.3, 0.05])
def test_compiled_face_sampling_gives_the_numpy_reference_points(longest_m):
    # faces from 1 cm to 2 m: some kept whole, some split a few times, and at 5 cm some into
    # thousands of pieces, which grows the kernel's piece and stack buffers many times over
    from meshplan._kernels import sample_faces
    from meshplan.plan.doors import _subdivide
    from meshplan.plan.rooms import sample_triangles

    rng = np.random.default_rng(3)
    tri = rng.random((400, 3, 3)) * rng.uniform(0.01, 2.0, (400, 1, 1))
    got = sample_faces(tri, longest_m, 0.05)
    want = sample_triangles(_subdivide(tri, longest_m), 0.05)
    assert got.shape == want.shape and len(got) > 10 * len(tri)
    # the same points in another order, to rounding (a loop and numpy's matmul add in their own
    # orders): sorted by their coordinates rounded to a nanometre
    order = lambda p: p[np.lexsort(np.round(p, 9).T[::-1])]  # noqa: E731
    np.testing.assert_allclose(order(got), order(want), rtol=0, atol=1e-12)


@pytest.mark.parametrize("n", [0, 1, 7, 3000, 200_000])
def test_radix_argsort_is_numpys_stable_order(n):
    """The compiled radix sort gives ``np.argsort(kind="stable")`` exactly: ties in input order,
    -0.0 as 0.0, infinities in place, NaN of either sign last; on spread values, on many ties
    and on values sharing their upper bits (passes skipped)."""
    from meshplan._kernels import stable_argsort_f64

    rng = np.random.default_rng(n)
    special = np.array([0.0, -0.0, np.inf, -np.inf, np.nan, -np.nan, 5e-324, -5e-324, 1.0, -1.0])
    spread = rng.normal(size=n) * 10.0 ** rng.integers(-5, 5, n)
    ties = np.round(rng.normal(size=n))
    ties[rng.integers(0, n, n // 5) if n else []] = rng.choice(special, n // 5)
    near = 1.0 + rng.integers(0, 50, n) * 2.0**-40  # only the low bits differ
    for x in (spread, ties, near):
        assert np.array_equal(stable_argsort_f64(x), np.argsort(x, kind="stable"))


def test_compiled_span_bins_and_third_points_are_numpys():
    """Gravity's compiled helpers give numpy's numbers to the bit: the corners' lowest and
    highest height bins (ties of round half to even, -0.0, equal heights) and the one-point
    samples of the faces."""
    from meshplan._kernels import span_bins, third_points

    rng = np.random.default_rng(3)
    h = np.r_[rng.normal(size=500), np.arange(-10, 10) * 0.025, 0.0, -0.0]  # exact half-bins of 0.05
    faces = rng.integers(0, len(h), size=(2000, 3))
    sel = np.flatnonzero(rng.random(2000) < 0.7)
    lo, hi = span_bins(h, faces, sel, 0.05)
    c = h[faces[sel]]
    assert np.array_equal(lo, np.round(np.minimum(np.minimum(c[:, 0], c[:, 1]), c[:, 2]) / 0.05))
    assert np.array_equal(hi, np.round(np.maximum(np.maximum(c[:, 0], c[:, 1]), c[:, 2]) / 0.05))
    tri = rng.normal(size=(3000, 3, 3)) * 10.0 ** rng.integers(-3, 3, (3000, 1, 1))
    third = 1.0 / 3.0
    assert np.array_equal(third_points(tri), tri[:, 0] + third * (tri[:, 1] - tri[:, 0]) + third * (tri[:, 2] - tri[:, 0]))

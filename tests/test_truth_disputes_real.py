"""Where meshplan and the hand-digitized truth of the real scans disagree, measured in the
scans so that the disagreement can be checked (skipped without ``../shared``).

* hl2_su_apartment's "corridor" (issue 9: the story's 1.18 m of furniture wall, and the sure
  door at its north end that issue 16's door recall misses) is the closed space under a dogleg
  stair's second flight.
* Three openings meshplan finds where the truth lists none (issue 16: real door precision 10/12,
  window precision 4/5). Each is a rectangle of an opening's size in a wall, its surface set
  back behind the wall's face on both sides of it: a closed door leaf or a pane in its frame.
  The truth lists such a recess as a door where it saw one (hl2_su_apartment's west wall: "a
  0.9 m rectangle recessed 5.5 cm from 0.1 to 2.3 m: a closed door"), but not these three.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import shapely

from conftest import SHARED
from meshplan.io import load_mesh

TRUTH = SHARED / "truth"

#: (scan stem, centre (x, z) in the truth frame, width, bottom, top) of each opening found
#: where the truth has none, and what it is.
UNLISTED = {
    "hemkinator north door": ("hl1_hemkinator_large_hall", (2.443, 0.386), 0.94, 0.0, 2.14),
    "hemkinator east high window": ("hl1_hemkinator_large_hall", (15.216, 5.837), 1.25, 1.65, 2.85),
    "apartment bedroom closet door": ("hl2_su_apartment_two_story", (6.139, 2.688), 0.75, 0.0, 2.06),
}

#: The frame's margin (m) left out inside the rectangle, and the width of the bands (m) beside
#: its jambs where the wall's own face is measured.
MARGIN_M, BAND_M = 0.12, 0.3


def _in_truth_frame(stem: str) -> tuple[dict, np.ndarray, np.ndarray, np.ndarray]:
    """The truth of a scan and its faces' centroids, normals and areas in the truth's own frame
    (``input_to_truth`` levels the scan and puts its floor at y = 0)."""
    path = TRUTH / f"{stem}.truth.json"
    if not path.is_file():
        pytest.skip("truth not available (../shared/truth)")
    truth = json.loads(path.read_text(encoding="utf-8"))
    scan = SHARED / "scans" / truth["scan"]
    if not scan.is_file():
        pytest.skip("real scan not available (../shared/scans)")
    mesh = load_mesh(scan, "m", None).mesh
    m = np.asarray(truth["input_to_truth"], dtype=np.float64)
    return truth, mesh.face_centroids @ m[:3, :3].T + m[:3, 3], mesh.face_normals @ m[:3, :3].T, mesh.face_areas


@pytest.mark.realscan
def test_the_apartment_corridor_that_the_truth_reads_as_open_is_closed_in_the_scan() -> None:
    """Inside the truth's corridor R2 no floor was scanned and its only horizontal faces are a
    stair's, 1.9 m up and more (the truth's "doorway at its north end, a header above 2.05 m" is
    that stair's landing, seen from above), while its mouth on the hall is a surface facing the
    hall: test_walls_real.BOUND_MISSED."""
    truth, c, n, a = _in_truth_frame("hl2_su_apartment_two_story")
    corridor = next(r for r in truth["rooms"] if r["type"] == "corridor" and r["story"] == 0)
    poly = shapely.Polygon(corridor["polygon"])
    inside = shapely.contains_xy(poly.buffer(-0.1), c[:, 0], c[:, 2])
    horizontal = np.abs(n[:, 1]) > 0.9  # either winding: HoloLens meshes mix it
    assert poly.area > 3.5
    assert a[inside & horizontal & (np.abs(c[:, 1]) < 0.1)].sum() < 0.01  # no floor over 3.9 m2
    stair = inside & horizontal & (c[:, 1] > 1.9) & (c[:, 1] < 2.9)
    assert a[stair].sum() > 0.3 * poly.area  # the second flight and the landing, from above
    assert a[inside & horizontal & (c[:, 1] >= 0.1) & (c[:, 1] <= 1.9)].sum() < 0.05
    # the mouth: the polygon's edge on the hall, where the truth draws the room open
    hall = next(r for r in truth["rooms"] if r["story"] == 0 and r["type"] != "corridor" and r["area"] > 20)
    mouth = poly.boundary.intersection(shapely.Polygon(hall["polygon"]).buffer(0.02))
    assert 0.9 < mouth.length < 1.5  # its 1.1 m and a few cm of either side
    near = shapely.dwithin(mouth, shapely.points(c[:, 0], c[:, 2]), 0.12)
    vertical = np.abs(n[:, 1]) < 0.3
    band = (c[:, 1] > 1.0) & (c[:, 1] < 2.3)
    # covered from 1.0 to 2.3 m over the mouth's width (area / (width x 1.3 m))
    assert a[near & vertical & band].sum() > 0.8 * mouth.length * 1.3


def _depths(stem: str, centre, width: float, bottom: float, top: float) -> tuple[float, float, float, float]:
    """Depth (m) of the surface inside the rectangle behind the wall's face on its left and right
    (area-weighted medians along the wall's normal, toward the wall), and the share of the
    rectangle covered, in the truth frame; the wall is the truth wall nearest the centre."""
    truth, c, n, a = _in_truth_frame(stem)
    p = np.asarray(centre, dtype=np.float64)
    walls = [w for w in truth["walls"] if w["story"] == 0]
    seg = np.array([[w["start"], w["end"]] for w in walls], dtype=np.float64)
    d = seg[:, 1] - seg[:, 0]
    t = np.clip(np.einsum("ij,ij->i", p - seg[:, 0], d) / np.einsum("ij,ij->i", d, d), 0.0, 1.0)
    k = int(np.argmin(np.linalg.norm(seg[:, 0] + t[:, None] * d - p, axis=1)))
    along = d[k] / np.linalg.norm(d[k])
    normal = np.array([-along[1], along[0]])
    u = (c[:, [0, 2]] - p) @ along
    v = (c[:, [0, 2]] - p) @ normal
    facing = np.abs(n[:, [0, 2]] @ normal) > 0.9
    near = facing & (np.abs(v) < 0.3) & (c[:, 1] > bottom + MARGIN_M) & (c[:, 1] < top - MARGIN_M)
    half = width / 2

    def median(sel: np.ndarray) -> float:
        order = np.argsort(v[sel])
        w = np.cumsum(a[sel][order])
        return float(v[sel][order][np.searchsorted(w, w[-1] / 2)])

    inside = near & (np.abs(u) < half - MARGIN_M)
    left = near & (u < -half - 0.05) & (u > -half - 0.05 - BAND_M)
    right = near & (u > half + 0.05) & (u < half + 0.05 + BAND_M)
    face = 0.5 * (median(left) + median(right))
    # the wall's face toward the room: the side the faces look to
    toward = np.sign(np.average(n[left | right][:, [0, 2]] @ normal, weights=a[left | right]))
    covered = a[inside].sum() / ((width - 2 * MARGIN_M) * (top - bottom - 2 * MARGIN_M))
    return toward * (face - median(inside)), toward * (face - median(left)), toward * (face - median(right)), covered


@pytest.mark.realscan
@pytest.mark.parametrize("name", sorted(UNLISTED))
def test_an_opening_the_truth_does_not_list_is_a_recess_of_an_openings_shape(name: str) -> None:
    stem, centre, width, bottom, top = UNLISTED[name]
    inside, left, right, covered = _depths(stem, centre, width, bottom, top)
    assert 0.04 <= inside <= 0.15, (name, inside)  # set back 4-15 cm: a leaf or a pane in its frame
    assert abs(left - right) <= 0.04  # the wall's face continues on both sides
    assert covered >= 0.5  # a surface, not a hole


@pytest.mark.realscan
def test_a_flat_stretch_of_wall_is_not_a_recess() -> None:
    """The same measure where the truth's wall is plain (the hemkinator north wall 1.5 m east of
    the door): no set-back."""
    inside, _, _, covered = _depths("hl1_hemkinator_large_hall", (4.5, 0.36), 0.94, 0.0, 2.14)
    assert abs(inside) < 0.03 and covered >= 0.5


@pytest.mark.realscan
def test_the_truth_lists_the_same_recess_as_a_door_elsewhere() -> None:
    """The truth's own door on hl2_su_apartment's west wall (unsure: "a closed (exterior?) door")
    measures as the three above do."""
    path = TRUTH / "hl2_su_apartment_two_story.truth.json"
    if not path.is_file():
        pytest.skip("truth not available (../shared/truth)")
    door = next(d for d in json.loads(path.read_text(encoding="utf-8"))["doors"] if "recessed" in d["note"])
    inside, left, right, covered = _depths("hl2_su_apartment_two_story", door["center"], door["width"], door["bottom"], door["top"])
    assert 0.04 <= inside <= 0.15 and abs(left - right) <= 0.04 and covered >= 0.5

"""Double-height voids (issue 16 item 4): the hole in an upper floor over a room two stories
high is found, marked in plan.json and drawn on the upper story's plan; an upper story that
nobody scanned is no void."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import real_scan
from meshplan.orient import OrientParams, orient
from meshplan.plan.voids import MIN_AREA_M2, double_height_voids
from test_walls_real import _Builder

W, D = 6.0, 4.0  # the building, x by z
SLAB = 2.8  # the upper floor (its underside, the lower ceiling, at 2.6)


def _building(slab_to_x: float, hall_scanned_above: bool = True):
    """A two-story box: the lower floor everywhere; the slab between the stories (both faces)
    from x 0 to ``slab_to_x``, with the outer walls and a roof (5.6 m) over it; beyond it (the
    hall) the outer walls up to the roof too, or, without ``hall_scanned_above``, only up to the
    lower ceiling and no roof (nobody scanned the upper story there)."""
    b = _Builder()
    b.quad([0, 0, 0], [0, 0, D], [W, 0, 0])  # lower floor, +y
    b.quad([0, SLAB - 0.2, 0], [slab_to_x, 0, 0], [0, 0, D])  # lower ceiling, -y
    b.quad([0, SLAB, 0], [0, 0, D], [slab_to_x, 0, 0])  # upper floor, +y
    roof_to = W if hall_scanned_above else slab_to_x
    b.quad([0, 5.6, 0], [roof_to, 0, 0], [0, 0, D])  # roof, -y
    for x0, x1, h in ((0.0, slab_to_x, 5.6), (slab_to_x, W, 5.6 if hall_scanned_above else SLAB - 0.2)):
        if x1 - x0 <= 0:
            continue
        b.quad([x0, 0, 0], [x1 - x0, 0, 0], [0, h, 0])  # z = 0, +z
        b.quad([x0, 0, D], [0, h, 0], [x1 - x0, 0, 0])  # z = D, -z
    b.quad([0, 0, 0], [0, 5.6, 0], [0, 0, D])  # x = 0, +x
    h = 5.6 if hall_scanned_above or slab_to_x >= W else SLAB - 0.2
    b.quad([W, 0, 0], [0, 0, D], [0, h, 0])  # x = W, -x
    return b.mesh()


def _voids(mesh):
    o = orient(mesh, OrientParams(), up_hint=np.array([0.0, 1.0, 0.0]))
    m = mesh.transformed(o.transform).with_flipped(o.flipped)
    return o, double_height_voids(m, o)


def test_a_room_two_stories_high_is_a_void_in_the_upper_floor() -> None:
    o, voids = _voids(_building(slab_to_x=2.5))
    assert len(o.stories) == 2
    (v,) = voids
    assert v.story == 1 and v.kind == "double-height"
    # the 3.5 x 4 m hall beside the slab (14 m2), less the 0.1 m cells the walls stand in
    assert v.polygon.area == pytest.approx((W - 2.5) * D, rel=0.15)
    x0, z0, x1, z1 = v.polygon.bounds
    # in the plan frame (turned): its extent across, 3.5 and 4 m in either order
    assert sorted([x1 - x0, z1 - z0]) == pytest.approx([W - 2.5, D], abs=0.3)


def test_no_void_where_the_slab_is_whole_or_the_upper_story_was_not_scanned() -> None:
    # the slab over the whole building: no hole
    _, voids = _voids(_building(slab_to_x=W))
    assert voids == ()
    # the same slab missing over the hall, but nothing seen above it there (its walls stop at
    # the lower ceiling, no roof): the upper story was not scanned there, no hole
    o, voids = _voids(_building(slab_to_x=2.5, hall_scanned_above=False))
    assert len(o.stories) == 2 and voids == ()
    # a gap in the slab smaller than a room is a hole in the scan
    _, voids = _voids(_building(slab_to_x=W - 0.4))
    assert voids == () and (0.4 * D) < MIN_AREA_M2


@pytest.mark.slow
def test_the_real_apartments_double_height_living_room(tmp_path) -> None:
    """hl2_su_apartment's living room is open to the roof over its east part: no slab between
    the stories there, the walls rising past the upper floor, the roof seen at 5.8 m. The upper
    plan marks the hole (it was drawn as floor nobody scanned before), in plan.json and the DXF."""
    import ezdxf

    from meshplan.cli import main

    out = tmp_path / "out"
    assert main(["run", str(real_scan("hl2_su_apartment_two_story.ply")), "-o", str(out), "--quiet"]) == 0
    plan = json.loads((out / "plan.json").read_text(encoding="utf-8"))
    (v,) = [v for v in plan["voids"] if v["kind"] == "double-height"]
    assert v["story"] == 1 and 18.0 <= v["area"] <= 26.0
    xs, zs = np.array(v["polygon"])[:, 0], np.array(v["polygon"])[:, 1]
    assert xs.min() > 7.4 and xs.max() < 12.4 and zs.min() > -0.1 and zs.max() < 6.0
    doc = ezdxf.readfile(out / "drafting-1.dxf")
    assert len(doc.modelspace().query('LWPOLYLINE[layer=="VOIDS"]')) == 1
    assert not len(ezdxf.readfile(out / "drafting-0.dxf").modelspace().query('*[layer=="VOIDS"]'))

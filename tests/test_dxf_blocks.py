"""DXF doors and windows as blocks (issue 12): a DOOR and a WINDOW block definition, inserted once
per opening on DOORS / WINDOWS, scaled and turned, with WIDTH, HEIGHT, SILL and MARK attributes;
the inserted geometry is exactly the drawing's (the same symbols model); the file stays
byte-reproducible."""

from __future__ import annotations

import io

import numpy as np
import pytest

pytestmark = pytest.mark.slow  # whole computations of synthetic scans


def _dxf(result, story: int):
    from meshplan.export.dxf import drafting_dxf
    from meshplan.plan.symbols import plan_symbols

    sp = result.stories[story]
    symbols = plan_symbols(story, result.walls, result.openings, result.rooms, result.physical_walls, stairs=result.stairs)
    rooms = [r for r in result.rooms if r.story == story]
    return symbols, drafting_dxf(sp.drafting.slices.segments, sp.reference, sp.annotations, "t", symbols, rooms)


def _mirror(seg) -> np.ndarray:
    """Plan segment(s) [x, z] -> DXF [x, -z]."""
    a = np.array(seg, dtype=np.float64)
    a[..., 1] *= -1
    return a


def _nearest(seg: np.ndarray, segs: np.ndarray) -> float:
    """Largest coordinate error between ``seg`` and the closest of ``segs`` (either way round)."""
    fwd = np.abs(segs - seg).reshape(len(segs), -1).max(axis=1)
    back = np.abs(segs - seg[::-1]).reshape(len(segs), -1).max(axis=1)
    return float(min(fwd.min(), back.min()))


@pytest.mark.parametrize(("preset", "seed"), [("apartment", 1), ("multistory", 1)])
def test_doors_and_windows_are_block_inserts(computed, preset, seed):
    import ezdxf

    _, result = computed(preset, seed)
    symbols, data = _dxf(result, 0)
    assert data == _dxf(result, 0)[1]  # byte-reproducible
    doc = ezdxf.read(io.StringIO(data.decode()))
    assert {"DOOR", "WINDOW"} <= {b.name for b in doc.blocks}
    for name in ("DOOR", "WINDOW"):
        tags = [a.dxf.tag for a in doc.blocks[name].query("ATTDEF")]
        assert tags == ["WIDTH", "HEIGHT", "SILL", "MARK"]
    msp = doc.modelspace()
    doors = msp.query('INSERT[name=="DOOR"]')
    windows = msp.query('INSERT[name=="WINDOW"]')
    recs = symbols.openings
    assert len(doors) == sum(r.kind == "door" for r in recs) == len(symbols.door_leaves) > 0
    assert len(windows) == sum(r.kind == "window" for r in recs) == len(symbols.windows) // 3 > 0
    assert {e.dxf.layer for e in doors} == {"DOORS"} and {e.dxf.layer for e in windows} == {"WINDOWS"}
    # no loose door or window lines are left: what is on those layers is the inserts
    assert not msp.query('LINE[layer=="DOORS" | layer=="WINDOWS"]') and not msp.query("ARC")
    marks = []
    leaves, sashes = _mirror(symbols.door_leaves), _mirror(np.concatenate([symbols.windows, symbols.jambs]))
    for e, rec in zip([*doors, *windows], [r for r in recs if r.kind == "door"] + [r for r in recs if r.kind == "window"]):
        att = {a.dxf.tag: a.dxf.text for a in e.attribs}
        assert float(att["WIDTH"]) == pytest.approx(rec.width, abs=1e-3) and float(att["HEIGHT"]) == pytest.approx(rec.height, abs=1e-3)
        assert 0.0 <= float(att["SILL"]) < 1.5 and (float(att["SILL"]) == 0.0) == (rec.kind == "door")
        marks.append(att["MARK"])
        # the texts upright and unmirrored however the insert is turned or mirrored
        assert all(a.dxf.rotation == 0.0 and a.dxf.text_generation_flag == 0 for a in e.attribs)
        assert [a.is_invisible for a in e.attribs] == [True, True, True, False]  # MARK shown
        assert abs(e.dxf.xscale) == pytest.approx(rec.width)
        # the block, inserted, draws exactly the drawing's leaf and swing, or frame lines
        for v in e.virtual_entities():
            if v.dxftype() == "LINE":
                seg = np.array([tuple(v.dxf.start)[:2], tuple(v.dxf.end)[:2]])
                assert _nearest(seg, leaves if rec.kind == "door" else sashes) < 1e-6
            elif v.dxftype() == "ARC":
                arc = min(symbols.door_arcs, key=lambda a: np.hypot(a.center[0] - v.dxf.center.x, -a.center[1] - v.dxf.center.y))
                assert np.allclose([arc.center[0], -arc.center[1], arc.radius], [v.dxf.center.x, v.dxf.center.y, v.dxf.radius], atol=1e-6)
                # mirrored drawing: plan angles a..b are DXF angles -b..-a
                assert (round(v.dxf.start_angle) - round(-arc.end_deg)) % 360 == 0
                assert (round(v.dxf.end_angle) - round(-arc.start_deg)) % 360 == 0
    n_doors = len(doors)
    assert marks == [f"D{k + 1}" for k in range(n_doors)] + [f"W{k + 1}" for k in range(len(windows))]
    assert doc.audit().has_errors is False

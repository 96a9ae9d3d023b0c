"""The ground truth of a synthetic scan as a JSON-ready dict (see :func:`meshplan.synthetic.generate`)."""

from __future__ import annotations

from typing import Any, cast

import numpy as np

from ..geometry import Annotations, FloatArray, Mesh
from .defects import Hole, Missing
from .furniture import Item
from .layout import Building
from .polygons import signed_area

#: ``truth["format"]``.
TRUTH_FORMAT = "meshplan-synthetic-truth/1"


def _r(x) -> object:
    """Floats rounded to 6 decimals, arrays as lists."""
    if isinstance(x, (float, np.floating)):
        return round(float(x), 6)
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, np.ndarray):
        return _r(x.tolist())
    if isinstance(x, (list, tuple)):
        return [_r(v) for v in x]
    if isinstance(x, dict):
        return {k: _r(v) for k, v in x.items()}
    return x


def _rect_polygon(rect: tuple[float, float, float, float]) -> list[list[float]]:
    """``(x0, x1, z0, z1)`` as a polygon, counter-clockwise seen from above."""
    x0, x1, z0, z1 = rect
    return [[x0, z0], [x0, z1], [x1, z1], [x1, z0]]


def build_truth(
    params,
    b: Building,
    items: list[Item],
    missing: list[Missing],
    holes: list[Hole],
    ann: Annotations,
    transform: FloatArray,
    yaw: float,
    tilt: float,
    axis: FloatArray,
    noise_amp: float,
    bevel: float,
    cells: FloatArray,
    mesh: Mesh,
) -> dict:
    """The truth dict: plain lists, floats rounded to 6 decimals (the transform at full precision)."""
    walls = b.walls
    rooms = []
    for r in b.rooms:
        w, d = r.extent
        rooms.append(
            {"story": r.story, "label": r.label, "kind": r.kind, "polygon": r.polygon, "area": r.area, "width": w, "depth": d}
        )
    wall_list = [
        {
            "story": w.story, "room": b.rooms[w.room].label, "start": w.start, "end": w.end, "normal": w.normal,
            "bottom": w.bottom, "top": w.top,
        }
        for w in walls
    ]
    openings = [
        {
            "story": o.story, "kind": o.kind, "wall": o.wall, "center": walls[o.wall].point(o.u_m), "width": o.width_m,
            "bottom": o.bottom, "top": o.top, "label": o.label, "exterior": o.exterior,
        }
        for o in b.openings
    ]
    stairs = [
        {
            "story": s.story, "room": b.rooms[s.room].label,
            "opening": _rect_polygon(s.opening),
            "risers": s.risers, "rise": s.rise_m, "going": s.going_m, "width": s.width_m,
        }
        for s in b.stairs
    ]
    furniture = [
        {
            "story": it.story, "room": b.rooms[it.room].label, "name": it.name, "kind": it.kind,
            "footprint": it.footprint, "height": it.height_m, "tilted": it.tilted,
        }
        for it in items
    ]
    up = transform[:3, :3] @ np.array([0.0, 1.0, 0.0])
    truth = {
        "format": TRUTH_FORMAT,
        "preset": params.preset,
        "seed": params.seed,
        "parameters": params.to_dict(),
        "transform": transform,
        "up": up,
        "yaw_deg": yaw,
        "tilt_deg": tilt,
        "tilt_axis": axis,
        "z_up": params.z_up,
        "winding": params.winding,
        "noise_m": noise_amp if params.noise_m[1] > 0 else 0.0,
        "triangle_size_m": [float(np.min(cells)), float(np.max(cells))],
        "bevel_m": bevel,
        "stories": [{"index": i, "floor": f, "ceiling": c} for i, (f, c) in enumerate(b.stories)],
        "footprint": b.footprint,
        "rooms": rooms,
        "walls": wall_list,
        "openings": openings,
        "missing": [{"story": m.story, "wall": m.wall, "from": m.from_m, "to": m.to_m} for m in missing],
        "holes": [
            {
                "story": h.story, "surface": h.surface, "index": h.index, "center": list(h.center), "radii": list(h.radii),
                "angle_deg": float(np.degrees(h.angle_rad)),
            }
            for h in holes
        ],
        "stairs": stairs,
        "furniture": furniture,
        "annotations": ann.to_list(),
        "faces": mesh.n_faces,
        "vertices": mesh.n_vertices,
    }
    assert all(signed_area(r.polygon) < 0 for r in b.rooms)
    out = cast(dict[str, Any], _r(truth))  # _r maps a dict to a dict
    out["transform"] = transform.tolist()  # full precision: mapping the scan back must be exact
    return out

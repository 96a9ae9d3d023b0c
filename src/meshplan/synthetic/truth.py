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


#: The slab opening over a synthetic stair is its outline grown by this much on every side
#: (:func:`meshplan.synthetic.layout._stair`), so the stair's footprint is the opening less it.
STAIR_OPENING_MARGIN_M = 0.03


def stair_footprint(stair: dict) -> list[list[float]]:
    """The plan footprint of a truth stair (``truth["stairs"][i]``, truth frame): its own
    ``footprint`` where given, else its slab ``opening`` less :data:`STAIR_OPENING_MARGIN_M` (the
    truth files keep their bytes: the footprint is derived, not stored)."""
    if "footprint" in stair:
        return [list(map(float, p)) for p in stair["footprint"]]
    xz = np.asarray(stair["opening"], dtype=np.float64)
    (x0, z0), (x1, z1) = xz.min(axis=0) + STAIR_OPENING_MARGIN_M, xz.max(axis=0) - STAIR_OPENING_MARGIN_M
    return [[float(v) for v in p] for p in _rect_polygon((x0, x1, z0, z1))]


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


def add_options_truth(truth: dict, params, b: Building, items: list[Item], leaves: list, wall_tops: FloatArray | None) -> None:
    """Add to ``truth`` what the options beyond the original generator change (in place).

    * ``stories[i]["ceiling_scanned"]``: False when the ceiling is not in the scan (its height is
      still the true one: where the walls end in a parametric model);
    * ``walls[i]["scanned_top"]``: the height up to which the wall face is scanned;
    * ``openings[i]["clear_width"]`` and ``["leaf"]`` for doors with a leaf: the clear width
      (the opening less the leaf standing in it when open at 90 degrees) and the leaf's hinge
      (``[x, z]``), opening angle (degrees, 0 closed), swing (``inside``: into the room of the
      door's primary wall face, the one with the lower index of the two faces), room (or None
      outside the building), width and thickness;
    * ``furniture[i]["built_in"]`` and ``["bottom"]`` for fixtures (kitchen units, wall
      cabinets, islands, wardrobes, desks). Truth walls are only the real walls: fixtures are
      never among them, whatever their height.
    """
    if params.drop_ceiling or params.parametric:
        for st in truth["stories"]:
            st["ceiling_scanned"] = False
    if wall_tops is not None:
        for wt, w in zip(truth["walls"], b.walls):
            wt["scanned_top"] = _r(min(float(wall_tops[w.room]), w.top))
    by_label = {lf.label: lf for lf in leaves}
    for o in truth["openings"]:
        lf = by_label.get(o["label"])
        if lf is None or o["kind"] != "door":
            continue
        o["clear_width"] = _r(lf.width_m - lf.thickness_m)
        o["leaf"] = _r(
            {
                "hinge": lf.hinge, "angle_deg": lf.angle_deg, "swing": lf.swing,
                "room": b.rooms[lf.room].label if lf.room >= 0 else None, "width": lf.width_m, "thickness": lf.thickness_m,
            }
        )
    for f, it in zip(truth["furniture"], items):
        if it.built_in:
            f["built_in"] = True
            f["bottom"] = _r(it.bottom_m)
    if params.parametric:
        truth["parametric"] = {"openings": params.parametric_openings, "wall_thickness": _r(params.parametric_wall_m)}

"""plan.json: the results file every later stage, test and user reads.

Its JSON Schema ships with the package (``meshplan/schema/plan.schema.json``). Everything in it
is in the plan frame (metres, +y up, dominant walls along x and z) except ``transform``, which
maps input coordinates to that frame, and ``input``, which describes the file. Floats are
rounded (to 0.1 mm for coordinates) so that the same input and options give byte-identical
files; only the ``timings`` block changes from run to run.
"""

from __future__ import annotations

import json
from importlib import resources
from typing import TYPE_CHECKING, Any

import numpy as np

from .._version import __version__
from .gbxml import envelope_summary

if TYPE_CHECKING:  # pragma: no cover
    from ..result import Result

SCHEMA_ID = "https://meshplan.org/schema/plan/1"
_ND = 6  # digits kept for directions
#: Digits kept for ``transform``: its rotation multiplies the input's coordinates, which a
#: georeferenced scan gives in millions of metres (UTM: 4,123,456 m north), so that six digits
#: (an error of 5e-7) moved its plan by up to 2 m; twelve keep micrometres there.
_TRANSFORM_ND = 12
_NC = 4  # digits kept for coordinates (0.1 mm)


def _r(a: Any, nd: int = _NC) -> Any:
    out = np.round(np.asarray(a, dtype=np.float64), nd)
    out = out + 0.0  # no negative zeros
    return out.tolist()


def plan_document(result: Result) -> dict[str, Any]:
    """The content of plan.json for a result (see the JSON Schema for every field)."""
    o = result.orientation
    st = result.input
    doc: dict[str, Any] = {
        "$schema": SCHEMA_ID,
        "meshplan_version": __version__,
        "frame": {
            "units": "m",
            "up": "+y",
            "plan": "seen from above: x to the right, z down the page",
            "origin": "lowest floor, at the low-x, low-z corner of the scan",
        },
        "transform": _r(o.transform, _TRANSFORM_ND),
        "stories": [s.to_dict(_NC) for s in o.stories],
        "wall_directions": [
            {
                "normal": _r(d.normal[[0, 2]], _ND),
                "angle_deg": round(float(np.degrees(np.arctan2(d.normal[2], d.normal[0])) % 360.0), 3) % 360.0,
                "area": round(float(d.weight), 3),
                "principal": bool(d.principal),
            }
            for d in o.alignment.directions
        ],
        "walls": [dict(w, physical_wall=int(k)) if k >= 0 else w for w, k in zip(result.walls.to_list(_NC), _carriers(result))],
        "physical_walls": [_physical_wall(w, result) for w in result.physical_walls],
        "rooms": [r.to_dict(_NC, imperial=result.options.render.imperial) for r in result.rooms],
        "openings": [
            dict(o, **(result.opening_elements[i].to_dict(_NC) if i < len(result.opening_elements) else {}), source=_opening_source(result, i))
            for i, o in enumerate(result.openings.to_list(result.walls, _NC))
        ],
        "stairs": [s.to_dict(_NC) for s in result.stairs],
        "voids": _voids(result),
        "annotations": [
            dict(item, story=int(result.annotation_story[i]))
            for i, item in enumerate(result.annotations.to_list(_NC))
        ],
        "envelope": envelope_summary(result, _NC),
        "levels": {
            "bucket_m": round(float(result.options.orient.level_bucket_m), _ND),
            "spikes": [{"height": round(s.height, _NC), "area": round(s.weight, 3)} for s in o.levels.spikes],
        },
        "gravity": {
            "method": o.gravity.method,
            "sign_evidence": round(float(o.gravity.sign_evidence), 3),
            "sign_by": o.gravity.sign_by,
            "faces_used": int(o.gravity.faces_used),
        },
        "input": {
            "path": st.path,
            "format": st.format,
            "units": st.units,
            "objects": st.objects,
            "vertices_read": st.vertices_read,
            "faces_read": st.faces_read,
            "vertices": st.vertices,
            "faces": st.faces,
            "dropped_faces": st.dropped_faces,
            "dropped_nonfinite": st.dropped_nonfinite,
            "dropped_degenerate": st.dropped_degenerate,
            "dropped_duplicate": st.dropped_duplicate,
            "faces_flipped": int(np.count_nonzero(o.flipped)),
            **_input_extras(result),
        },
        "warnings": list(result.warnings),
        "parameters": result.options.to_dict(),
        "timings": {k: round(float(v), 4) for k, v in result.timings.items()},
    }
    return doc


def _opening_source(result: Result, i: int) -> str:
    """Where opening ``i`` came from: ``parametric`` (a door, window or opening box of a
    parametric model, :mod:`meshplan.plan.parametric`) or ``detected`` (found in the geometry)."""
    source = result.openings.source
    return str(source[i]) if i < len(source) else "detected"


def _input_extras(result: Result) -> dict[str, Any]:
    """What ``input`` says besides the counts every scan has: a point cloud's points read before
    and kept after the voxel subsampling and the voxel size; a parametric model's elements by
    kind; and always the scale to metres (the unit's, times a USD stage's ``metersPerUnit``; a
    LAS file's CRS unit, e.g. the US survey foot, exactly)."""
    st = result.input
    out: dict[str, Any] = {"scale_to_m": round(float(st.scale_to_m), 12)}
    if st.points_read:
        out.update(
            points_read=int(st.points_read),
            points=int(st.points),
            dropped_nonfinite_points=int(st.dropped_nonfinite_points),
            voxel_m=round(float(result.options.input.point_voxel_m), _ND),
        )
    if st.parametric is not None:
        out["parametric"] = {"kind": "roomplan", "elements": st.parametric.counts()}
    return out


def _voids(result: Result) -> list[dict[str, Any]]:
    """The holes in the floors: over each stair, in the floor of the story it arrives at, and
    over each double-height space (:class:`meshplan.plan.voids.Void`)."""
    out = []
    for k, s in enumerate(result.stairs):
        if s.void is None or s.to_story is None:
            continue
        xy = np.asarray(s.void.exterior.coords)[:-1]
        out.append(
            {"story": s.to_story, "kind": "stair", "stair": k, "polygon": _r(xy), "area": round(float(s.void.area), _NC), "source": s.void_source}
        )
    for v in result.voids:
        xy = np.asarray(v.polygon.exterior.coords)[:-1]
        out.append({"story": v.story, "kind": v.kind, "polygon": _r(xy), "area": round(float(v.polygon.area), _NC), "source": v.source})
    return out


def _carriers(result: Result) -> list[int]:
    """The physical wall of every flat wall face (-1 for none)."""
    from ..walls.physical import wall_of_face

    return [int(k) for k in wall_of_face(result.physical_walls, len(result.walls))]


def _physical_wall(w: Any, result: Result) -> dict[str, Any]:
    """One physical wall (:class:`meshplan.walls.PhysicalWall`) as plan.json lists it."""
    story = result.orientation.stories[w.story]
    d: dict[str, Any] = {
        "story": int(w.story),
        "start": _r(w.start),
        "end": _r(w.end),
        "normal": _r(w.normal, _ND),
        "length": round(float(w.length), _NC),
        "thickness": round(float(w.thickness), _NC),
        "thickness_measured": bool(w.paired or w.revealed),
        "height": round(float(story.height), _NC),
        "scanned_bottom": round(float(w.bottom), _NC),
        "scanned_top": round(float(w.top), _NC),
        "faces": [int(f) for f in w.faces],
        "joined": _r(w.joined),
        "exterior": w.exterior,
        "rooms": [list(w.rooms[0]), list(w.rooms[1])],
    }
    if w.confidence:
        d["confidence"] = {"level": w.confidence, "reason": w.confidence_reason}
    return d


def dumps(doc: dict[str, Any]) -> str:
    """Serialize deterministically (stable key order, no NaN)."""
    return json.dumps(doc, indent=2, allow_nan=False) + "\n"


def plan_schema() -> dict[str, Any]:
    """The JSON Schema of plan.json."""
    text = resources.files("meshplan").joinpath("schema/plan.schema.json").read_text(encoding="utf-8")
    return json.loads(text)

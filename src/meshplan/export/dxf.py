"""DXF drawings (ezdxf) for CAD: real metres, named layers, seen from above.

DXF's y axis points up the page while the plan's z points down, so plan point (x, z) is drawn
at DXF (x, -z): the drawing looks exactly like the PNG/SVG/PDF plans.
"""

from __future__ import annotations

import io

import numpy as np

from ..geometry import ANNOTATION_PROBE_M, Annotations
from ..slicing import chain_segments
from ..validation import plain_text

LAYERS = {
    "WALLS": 7,  # white/black
    "SLICES": 8,  # grey
    "ANNOTATIONS": 1,  # red
    "TEXT": 7,
    "ROOMS": 3,  # green
    "DIMENSIONS": 8,
    "DOORS": 30,  # orange
    "WINDOWS": 5,  # blue
    "LOW_CONFIDENCE": 1,  # red, dashed: rooms meshplan is unsure of (closed by the floor)
}


def _p(xz) -> tuple[float, float]:
    return (float(xz[0]), float(-xz[1]))


def drafting_dxf(
    wall_segments: np.ndarray,
    slice_segments: np.ndarray,
    annotations: Annotations,
    title: str = "",
    symbols=None,
    rooms=(),
) -> bytes:
    """The drafting plan as DXF: ``wall_segments`` (the flat walls cut once) on WALLS,
    ``slice_segments`` (the scan cut at the same height, for reference) on SLICES, annotations
    as circles and probe lines on ANNOTATIONS and their labels on TEXT; with ``symbols``
    (:class:`meshplan.plan.symbols.PlanSymbols`) and ``rooms``, room outlines and labels on
    ROOMS (low-confidence rooms dashed on LOW_CONFIDENCE), DIMENSION entities on DIMENSIONS, door leaves and swings on DOORS and window sashes
    on WINDOWS, and the walls as solids (outlines and a solid HATCH, openings cut out) on WALLS.

    Segments are ``(S, 2, 2)`` arrays of plan points [x, z] in metres.
    """
    import ezdxf
    from ezdxf import units

    doc = ezdxf.new("R2010", setup=True)
    doc.units = units.M
    doc.header["$MEASUREMENT"] = 1
    doc.header["$INSUNITS"] = units.M
    for name, color in LAYERS.items():
        doc.layers.add(name, color=color, linetype="DASHED" if name == "LOW_CONFIDENCE" else "Continuous")
    msp = doc.modelspace()
    for seg in np.asarray(wall_segments).reshape(-1, 2, 2):
        msp.add_line(_p(seg[0]), _p(seg[1]), dxfattribs={"layer": "WALLS", "lineweight": 50})
    # the scan's cut, one polyline per chain of segments rather than one line per triangle
    for chain in chain_segments(slice_segments):
        msp.add_lwpolyline([_p(q) for q in chain], dxfattribs={"layer": "SLICES"})
    for i, (label, kind) in enumerate(zip(annotations.labels, annotations.kinds)):
        pos = annotations.positions[i]
        c = (float(pos[0]), float(-pos[2]))
        msp.add_circle(c, radius=0.08, dxfattribs={"layer": "ANNOTATIONS"})
        d = annotations.directions[i]
        if np.all(np.isfinite(d)) and np.hypot(d[0], d[2]) > 1e-6:
            n = np.hypot(d[0], d[2])
            msp.add_line(c, (c[0] + ANNOTATION_PROBE_M * d[0] / n, c[1] - ANNOTATION_PROBE_M * d[2] / n), dxfattribs={"layer": "ANNOTATIONS"})
        msp.add_text(_literal_text(f"{label} ({kind})"), height=0.12, dxfattribs={"layer": "TEXT"}).set_placement((c[0] + 0.1, c[1] + 0.1))
    for room in rooms:
        outline = [_p(c) for c in list(room.polygon.exterior.coords)[:-1]]
        # a low-confidence room (a wall missing: closed by the scanned floor) on its own dashed layer
        low = getattr(room, "confidence", "") == "low"
        msp.add_lwpolyline(outline, close=True, dxfattribs={"layer": "LOW_CONFIDENCE" if low else "ROOMS", "linetype": "DASHED" if low else "BYLAYER"})
    if symbols is not None:
        _wall_solids(msp, getattr(symbols, "wall_solids", ()))
        for seg in symbols.door_leaves:
            msp.add_line(_p(seg[0]), _p(seg[1]), dxfattribs={"layer": "DOORS"})
        for a in symbols.door_arcs:
            # mirrored drawing: plan angle t becomes -t, and the arc runs the other way
            msp.add_arc(_p(a.center), a.radius, -a.end_deg, -a.start_deg, dxfattribs={"layer": "DOORS"})
        for seg in symbols.jambs:
            msp.add_line(_p(seg[0]), _p(seg[1]), dxfattribs={"layer": "WALLS"})
        for seg in symbols.windows:
            msp.add_line(_p(seg[0]), _p(seg[1]), dxfattribs={"layer": "WINDOWS"})
        for d in symbols.dimensions:
            p1, p2 = np.asarray(_p(d.p1)), np.asarray(_p(d.p2))
            # "left of p1 -> p2" in the plan is right of it in the mirrored drawing
            style = {"dimtxt": 0.1, "dimasz": 0.06, "dimlfac": 1.0, "dimdec": 2, "dimexo": 0.05, "dimexe": 0.05}
            dim = msp.add_aligned_dim(
                p1=tuple(p1), p2=tuple(p2), distance=-d.offset, dimstyle="EZDXF", override=style, dxfattribs={"layer": "DIMENSIONS"}
            )
            dim.render()
        for lab in symbols.room_labels:
            msp.add_mtext(lab.text.replace("\n", "\\P"), dxfattribs={"layer": "ROOMS", "char_height": 0.18}).set_location(_p(lab.position), attachment_point=5)
    if title:
        pts = np.concatenate([np.asarray(wall_segments).reshape(-1, 2), np.asarray(slice_segments).reshape(-1, 2), np.zeros((1, 2))])
        msp.add_text(title, height=0.25, dxfattribs={"layer": "TEXT"}).set_placement((float(pts[:, 0].min()), float(-pts[:, 1].min()) + 0.5))
    return _reproducible_bytes(doc)


def _wall_solids(msp, solids) -> None:
    """The cut walls as solids on WALLS: each wall's outline (openings cut out) as closed
    polylines and a solid HATCH (poche), exterior walls with a heavier outline; walls of low
    confidence outlined on LOW_CONFIDENCE, not filled."""
    for w in solids:
        layer = "LOW_CONFIDENCE" if w.low else "WALLS"
        weight = 50 if w.exterior else 25
        polys = [g for g in getattr(w.polygon, "geoms", [w.polygon]) if g.geom_type == "Polygon" and not g.is_empty]
        for poly in polys:
            rings = [poly.exterior, *poly.interiors]
            for ring in rings:
                msp.add_lwpolyline([_p(c) for c in list(ring.coords)[:-1]], close=True, dxfattribs={"layer": layer, "lineweight": weight})
            if w.low:
                continue
            hatch = msp.add_hatch(color=250 if w.exterior else 8, dxfattribs={"layer": "WALLS"})
            hatch.paths.add_polyline_path([_p(c) for c in list(poly.exterior.coords)[:-1]], is_closed=True, flags=1)
            for ring in poly.interiors:
                hatch.paths.add_polyline_path([_p(c) for c in list(ring.coords)[:-1]], is_closed=True, flags=0)


def _literal_text(text: str) -> str:
    """A user's text as the content of a DXF TEXT entity that CAD programs show as it is.

    Control characters are removed (a line break would end the DXF group value); ``^`` is
    written ``^ `` (DXF's caret notation reads ``^J`` as a control character and ``^ `` as a
    caret) and ``%`` as ``%%%`` (TEXT reads ``%%c``, ``%%d``, ``%%p`` as symbols, ``%%%`` as a
    percent sign). At most 200 characters of label, tripled, stay within R2010's 2049.
    """
    return plain_text(text).replace("^", "^ ").replace("%", "%%%")


def _required_class_names(dxfversion: str) -> set[str]:
    """The CLASS names ezdxf always writes for ``dxfversion`` (in its own, fixed order)."""
    from ezdxf.sections.classes import REQ_R2004, REQUIRED_CLASSES

    return set(REQUIRED_CLASSES.get(dxfversion, REQ_R2004))


def _reproducible_bytes(doc) -> bytes:
    """The DXF text without the dates and random GUIDs ezdxf writes, so that the same plan gives
    the same file."""
    import ezdxf
    from ezdxf.document import CREATED_BY_EZDXF, WRITTEN_BY_EZDXF

    meta = doc.ezdxf_metadata()
    meta[CREATED_BY_EZDXF] = f"ezdxf {ezdxf.__version__} for meshplan"
    meta[WRITTEN_BY_EZDXF] = f"ezdxf {ezdxf.__version__} for meshplan"
    doc._update_ezdxf_metadata = lambda: None  # it would stamp the current time
    # ezdxf adds a CLASS for each entity type in use while writing, iterating over a set: its
    # order changes with the hash seed. Add them now, in a fixed order (writing adds no more).
    classes = doc.classes
    classes.add_required_classes(doc.dxfversion)
    fixed = [key for key in classes.classes if key[0] in _required_class_names(doc.dxfversion)]
    classes.classes = {key: classes.classes[key] for key in fixed + sorted(set(classes.classes) - set(fixed))}
    saved = ezdxf.options.write_fixed_meta_data_for_testing
    ezdxf.options.write_fixed_meta_data_for_testing = True
    try:
        buf = io.StringIO()
        doc.write(buf)
    finally:
        ezdxf.options.write_fixed_meta_data_for_testing = saved
    return buf.getvalue().encode("utf-8")

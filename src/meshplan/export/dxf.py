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
    "STAIRS": 4,  # cyan: treads, walking line and arrow, the cut, the void over a stair
    "VOIDS": 4,  # cyan: the holes in the floor over double-height spaces, dash-dotted and crossed
}

#: Block names of the door and window symbols, inserted once per opening.
DOOR_BLOCK, WINDOW_BLOCK = "DOOR", "WINDOW"
#: Their attributes, in this order (metres; MARK the opening's mark, D1, W1 ...).
OPENING_ATTRIBUTES = ("WIDTH", "HEIGHT", "SILL", "MARK")
#: Attribute text height (m of model): readable at 1:50 (2.4 mm) ...
ATTRIBUTE_HEIGHT_M = 0.12
#: ... centred this far (m) into the room off the middle of the opening, clear of the wall.
ATTRIBUTE_OFFSET_M = 0.2
#: The arrow head at the top of a stair's walking line (m of model): 0.2 m long, 0.13 m wide,
#: 2-4 mm of paper at 1:50-1:100.
STAIR_ARROW_M = (0.2, 0.13)
#: Linetype scales of the stairs' DASHED (a 1.27 m dash) and DASHDOT (2.54 m) lines: 10 cm and
#: 25 cm dashes, so that a 30 cm riser shows as dashed.
STAIR_DASH_LTSCALE = 0.08
VOID_DASH_LTSCALE = 0.1


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
        records = getattr(symbols, "openings", ())
        if records:
            _opening_blocks(doc)
            for rec in records:
                _insert_opening(msp, rec)
            # door jambs: the ends of the wall's cut (a window's are in its block)
            for rec in records:
                if rec.kind == "door":
                    o, t, n = (np.asarray(v) for v in (rec.origin, rec.tangent, rec.normal))
                    for q in (o, o + t * rec.width):
                        msp.add_line(_p(q), _p(q - n * rec.depth), dxfattribs={"layer": "WALLS"})
        else:  # symbols made without opening records: the loose lines
            for seg in symbols.door_leaves:
                msp.add_line(_p(seg[0]), _p(seg[1]), dxfattribs={"layer": "DOORS"})
            for a in symbols.door_arcs:
                # mirrored drawing: plan angle t becomes -t, and the arc runs the other way
                msp.add_arc(_p(a.center), a.radius, -a.end_deg, -a.start_deg, dxfattribs={"layer": "DOORS"})
            for seg in symbols.jambs:
                msp.add_line(_p(seg[0]), _p(seg[1]), dxfattribs={"layer": "WALLS"})
            for seg in symbols.windows:
                msp.add_line(_p(seg[0]), _p(seg[1]), dxfattribs={"layer": "WINDOWS"})
        _stairs(msp, getattr(symbols, "stairs", ()))
        for ring in getattr(symbols, "voids", ()):
            _void(msp, ring, "VOIDS")
        for seg in getattr(symbols, "void_crosses", ()):
            msp.add_line(_p(seg[0]), _p(seg[1]), dxfattribs={"layer": "VOIDS"})
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


def _opening_blocks(doc) -> None:
    """The DOOR and WINDOW block definitions, in units of the opening (inserted scaled and
    turned; local x along the wall from one jamb to the other, local y out of the face the
    opening was found on, into the room a door swings into).

    DOOR (scaled by the width both ways, so that its swing stays a circle): the leaf standing
    open from the jamb at the origin, ``(0, 0)-(0, 1)``, and its swing, a quarter circle of
    radius 1 from the leaf to the other jamb. WINDOW (scaled by the width along x and the wall's
    depth along y): the frame lines across the wall's thickness (both faces and the middle,
    ``y`` = 0, -0.5, -1) and the jambs. Both carry the attributes
    :data:`OPENING_ATTRIBUTES` (MARK shown beside the opening, the others hidden)."""
    door = doc.blocks.new(name=DOOR_BLOCK)
    door.add_line((0, 0), (0, 1))
    door.add_arc((0, 0), 1.0, 0.0, 90.0)
    window = doc.blocks.new(name=WINDOW_BLOCK)
    for y in (0.0, -0.5, -1.0):
        window.add_line((0, y), (1, y))
    for x in (0.0, 1.0):
        window.add_line((x, 0), (x, -1))
    for block in (door, window):
        for k, tag in enumerate(OPENING_ATTRIBUTES):
            flags = 0 if tag == "MARK" else 1  # 1: invisible
            block.add_attdef(tag, (0.5, 0.15 + 0.2 * k), dxfattribs={"height": ATTRIBUTE_HEIGHT_M, "flags": flags})


def _insert_opening(msp, rec) -> None:
    """One door or window (:class:`meshplan.plan.symbols.OpeningSymbol`) as an INSERT of its
    block on DOORS or WINDOWS, with its width, height, sill and mark as attributes."""
    from ezdxf.enums import TextEntityAlignment

    t = np.array(_p(rec.tangent))
    n = np.array(_p(rec.normal))
    rotation = float(np.degrees(np.arctan2(t[1], t[0])))
    # the block's +y is the face's normal, or its mirror image (the plan's z is flipped)
    side = 1.0 if t[0] * n[1] - t[1] * n[0] > 0 else -1.0
    door = rec.kind == "door"
    xscale = rec.width
    yscale = side * (rec.width if door else rec.depth)
    ref = msp.add_blockref(
        DOOR_BLOCK if door else WINDOW_BLOCK,
        _p(rec.origin),
        dxfattribs={"layer": "DOORS" if door else "WINDOWS", "xscale": xscale, "yscale": yscale, "rotation": rotation},
    )
    values = {"WIDTH": f"{rec.width:.3f}", "HEIGHT": f"{rec.height:.3f}", "SILL": f"{rec.sill:.3f}", "MARK": _literal_text(rec.mark)}
    ref.add_auto_attribs(values)
    # the texts upright, unmirrored and at their height whatever the insert's scale and turn,
    # centred a little into the room off the middle of the opening
    o, t, n = (np.asarray(v, dtype=np.float64) for v in (rec.origin, rec.tangent, rec.normal))
    at = _p(o + t * 0.5 * rec.width + n * ATTRIBUTE_OFFSET_M)
    for attrib in ref.attribs:
        attrib.dxf.height = ATTRIBUTE_HEIGHT_M
        attrib.dxf.width = 1.0
        attrib.dxf.rotation = 0.0
        attrib.dxf.oblique = 0.0
        attrib.dxf.text_generation_flag = 0
        attrib.set_placement(at, align=TextEntityAlignment.MIDDLE_CENTER)


def _void(msp, ring, layer: str) -> None:
    """The outline of a hole in the floor (a closed ring), dash-dotted (DASHDOT) on ``layer``."""
    msp.add_lwpolyline([_p(q) for q in ring[:-1]], close=True, dxfattribs={"layer": layer, "linetype": "DASHDOT", "ltscale": VOID_DASH_LTSCALE})


def _stairs(msp, stairs) -> None:
    """The stair symbols (:class:`meshplan.plan.symbols.StairSymbol`) on STAIRS: treads and
    stringers, the part above the cut DASHED, the break line, the walking line with a filled
    arrow head at its top, the void dash-dotted (DASHDOT) with its cross, and the risers' text."""
    from ezdxf.enums import TextEntityAlignment

    for st in stairs:
        for seg in st.lines:
            msp.add_line(_p(seg[0]), _p(seg[1]), dxfattribs={"layer": "STAIRS"})
        for seg in st.hidden:
            msp.add_line(_p(seg[0]), _p(seg[1]), dxfattribs={"layer": "STAIRS", "linetype": "DASHED", "ltscale": STAIR_DASH_LTSCALE})
        for seg in st.cross:
            msp.add_line(_p(seg[0]), _p(seg[1]), dxfattribs={"layer": "STAIRS"})
        if len(st.cut) >= 2:
            msp.add_lwpolyline([_p(q) for q in st.cut], dxfattribs={"layer": "STAIRS"})
        if len(st.walk) >= 2:
            msp.add_lwpolyline([_p(q) for q in st.walk], dxfattribs={"layer": "STAIRS"})
        if len(st.walk_hidden) >= 2:
            msp.add_lwpolyline([_p(q) for q in st.walk_hidden], dxfattribs={"layer": "STAIRS", "linetype": "DASHED", "ltscale": STAIR_DASH_LTSCALE})
        if len(st.void) >= 4:
            _void(msp, st.void, "STAIRS")
        ends = [w for w in (st.walk_hidden, st.walk) if len(w) >= 2]
        if ends:
            tip, d = np.asarray(ends[0][-1]), np.asarray(st.arrow)
            across = np.array([-d[1], d[0]])
            length, width = STAIR_ARROW_M
            a, b = tip - d * length + across * 0.5 * width, tip - d * length - across * 0.5 * width
            hatch = msp.add_hatch(dxfattribs={"layer": "STAIRS"})
            hatch.paths.add_polyline_path([_p(tip), _p(a), _p(b)], is_closed=True)
        if st.role == "lower" and len(st.walk) >= 2:
            foot = np.asarray(st.walk[0])
            msp.add_circle(_p(foot), 0.04, dxfattribs={"layer": "STAIRS"})
            d = np.asarray(st.walk[1]) - foot
            d = d / (np.linalg.norm(d) or 1.0)
            text = msp.add_text(_literal_text(st.text), height=0.1, dxfattribs={"layer": "STAIRS"})
            # along the flight, reading upright, running away from the stair from just before its foot
            angle = float(np.degrees(np.arctan2(-d[1], d[0])))
            rotation = angle + 180.0 if abs(angle) > 90.0 else angle
            reads = np.array([np.cos(np.radians(rotation)), np.sin(np.radians(rotation))])
            away = float(reads @ np.array([-d[0], d[1]])) > 0  # reading away from the stair
            align = TextEntityAlignment.MIDDLE_LEFT if away else TextEntityAlignment.MIDDLE_RIGHT
            text.set_placement(_p(foot - d * 0.12), align=align)
            text.dxf.rotation = rotation


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

"""The plan drawings: pen-and-ink, drafting and DBSCAN wall segments.

Why one long module: the three plan drawings (pen-and-ink, drafting, wall segments) share the
sheet set-up, the text placer and the painters of the plan symbols.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..geometry import Annotations
from ..plan import DraftingPlan, PenAndInkPlan
from ..plan.elements import MarkedDrafting
from ..plan.symbols import PlanSymbols, format_area, format_length
from ..validation import PLAIN_TEXT_KW, plain_text
from ..walls import FlatWalls
from .params import RenderParams
from .placement import Placer, Spot, arc_line, tag, with_halo
from .sheet import (
    Sheet,
    annotation_obstacles,
    draw_annotations,
    draw_legend,
    draw_north_arrow,
    draw_scale_bar,
    draw_title_block,
    format_feet_inches,
    grow_max,
    ink_rgba,
    new_figure,
    place_raster,
    rasterize_segments,
)

WALL_COLOR = "#111111"
#: The cut walls (poche): exterior walls black, interior walls dark grey.
POCHE_EXTERIOR = "#1a1a1a"
POCHE_INTERIOR = "#5c5c5c"
WINDOW_COLOR = "#1a1a1a"
DIM_COLOR = "#3d3d3d"
#: Dimension text in points of paper (about 2 mm high whatever the scale), and where the
#: chains run outside the building (millimetres of paper from its outermost face).
DIM_TEXT_PT = 5.5
DIM_FIRST_MM = 8.0
DIM_STEP_MM = 6.0
#: Ticks of a dimension chain closer than this on paper (mm) are one: a 2 mm piece is a wall
#: corner seen twice (a face and its neighbour's end 4-9 cm apart at 1:50), too short for its
#: own text (5.5 pt figures are 4 mm wide) and no measure a builder sets out.
DIM_TICK_MERGE_MM = 2.0
#: Room labels from this size down to the last, the largest that fits the room.
ROOM_LABEL_SIZES = (7.5, 6.5, 5.5, 4.5)
ROOM_TINT = "#f3f1ec"
ROOM_EDGE = "#b9b2a4"
#: Light tints of the room types (:attr:`meshplan.plan.rooms.Room.type`).
ROOM_TINTS = {"room": "#f5f2ea", "corridor": "#e9ecef", "stair": "#e3ecf5", "closet": "#efe6d6", "open": "#e8f1e4"}
#: Low-confidence walls, rooms and openings (``plan.elements.MarkedDrafting``) are drawn dashed
#: in this colour, as RoomPlan draws what it is unsure of, so that a reader checks them.
LOW_CONFIDENCE_COLOR = "#c0392b"
LOW_CONFIDENCE_DASH = (0, (4, 2.5))
#: Saturated colours for wall segments (no greys: grey marks the segments that were dropped).
#: Stairs: tread lines a little lighter than the walls; the walking line's arrow head and the
#: dot at its foot in paper millimetres (the same size whatever the scale).
STAIR_COLOR = "#262626"
STAIR_ARROW_MM = (2.6, 1.7)  # length, width
STAIR_DOT_MM = 1.3
STAIR_HIDDEN_DASH = (0, (3, 2))
VOID_DASH = (0, (6, 2, 1, 2))  # dash-dot: the edge of a hole in the floor
STAIR_TEXT_PT = 5.0
#: Saturated colours for wall segments (no greys: grey marks the segments that were dropped).
SEGMENT_COLORS = (
    "#e6194b", "#3cb44b", "#4363d8", "#f58231", "#911eb4", "#42d4f4", "#f032e6", "#9a6324",
    "#800000", "#469990", "#000075", "#bfef45", "#e6b800", "#fabed4", "#808000", "#dcbeff",
)


def _story_title(kind: str, story_index: int, n_stories: int, floor: float, ceiling: float, imperial: bool) -> str:
    unit, name = (0.3048, "ft") if imperial else (1.0, "m")
    where = f"story {story_index}" if n_stories > 1 else "plan"
    return f"{kind} {where}  (floor {floor / unit:.2f} {name}, ceiling {ceiling / unit:.2f} {name})"


def pen_and_ink_raster(plan: PenAndInkPlan, sheet: Sheet, params: RenderParams) -> np.ndarray:
    """The RGBA ink image of a pen-and-ink plan, pixel for pixel on the sheet."""
    counts = rasterize_segments(plan.slices.segments, plan.slices.level, sheet)
    return ink_rgba(counts, params.opacity)


def _story_name(story, n_stories: int, imperial: bool) -> str:
    f = format_feet_inches if imperial else (lambda v: f"{v:.2f} m")
    where = f"{story.index} of {n_stories}" if n_stories > 1 else "the only one"
    return f"{where} (floor {f(story.floor)}, ceiling {f(story.ceiling)})"


def pen_and_ink_figure(
    plan: PenAndInkPlan, annotations: Annotations, sheet: Sheet, params: RenderParams, n_stories: int = 1, *, scan: str = "", north_deg: float = 0.0
):
    """All slices overlaid in translucent ink (:func:`pen_and_ink_raster`); what stands at many
    heights is dark. The annotations are drawn above the ink, their labels on a white halo.
    One figure serves every format it is saved in."""
    s = plan.story
    n = len(plan.slices.heights) - 1
    title = _story_title(f"Pen-and-ink ({n} slices, opacity {params.opacity:g})", s.index, n_stories, s.floor, s.ceiling, params.imperial)
    fig, ax = new_figure(sheet, title, params)
    ax.patch.set_alpha(0.0)  # the ink sits under the axes
    place_raster(fig, ax, pen_and_ink_raster(plan, sheet, params))
    kinds = draw_annotations(ax, annotations.labels, annotations.kinds, annotations.positions, annotations.directions, legend=False)
    _draw_sheet(fig, sheet, params, f"Pen-and-ink plan, {n} slices", _story_name(s, n_stories, params.imperial), scan, north_deg, kinds)
    return fig


def _draw_sheet(fig, sheet: Sheet, params: RenderParams, drawing: str, story: str, scan: str, north_deg: float, legend: list) -> None:
    draw_scale_bar(fig, sheet, params)
    draw_north_arrow(fig, north_deg)
    draw_legend(fig, [h for h, _ in legend], [n for _, n in legend])
    draw_title_block(fig, sheet, params, drafting_name(drawing), story, scan)


def drafting_name(drawing: str) -> str:
    return drawing


def drafting_figure(
    plan: DraftingPlan,
    annotations: Annotations,
    sheet: Sheet,
    params: RenderParams,
    n_stories: int = 1,
    symbols: PlanSymbols | None = None,
    *,
    scan: str = "",
    north_deg: float = 0.0,
):
    """The flat-wall model cut once, drawn as an architectural sheet: the walls as solids
    (poche; exterior walls heavier) with the doors and windows cut through them, rooms tinted
    by type and labelled, dimension chains outside the building and room sizes inside where
    they fit, annotations above everything; below, the scale bar, north arrow, legend and
    title block. No text covers another text, a line or a symbol (:mod:`.placement`).

    ``scan`` (the scan's name) and ``north_deg`` (the bearing of up the page) go in the title
    block and the north arrow."""
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D

    s = plan.story
    cut = plan.height - s.floor
    cut_text = format_feet_inches(cut) if params.imperial else f"{cut:.2f} m"
    fig, ax = new_figure(sheet, _story_title(f"Drafting (cut at {cut_text})", s.index, n_stories, s.floor, s.ceiling, params.imperial), params)
    legend: list = []
    # a MarkedDrafting sets its low-confidence walls apart: drawn dashed
    solid = plan.solid if isinstance(plan, MarkedDrafting) else plan.slices.segments
    if symbols is None or not symbols.wall_solids:
        # list(): the stubs want a Sequence of segments, an (S, 2, 2) array iterates the same
        ax.add_collection(LineCollection(list(solid), colors=WALL_COLOR, linewidths=1.6, capstyle="projecting", zorder=3))
    if isinstance(plan, MarkedDrafting):
        _draw_low_confidence(ax, plan)
    lines: list = []
    stair_lines: list = []
    if symbols is not None:
        legend += _draw_rooms(ax, symbols)
        wall_lines, handles = _draw_wall_solids(ax, symbols)
        legend += handles
        lines += wall_lines
        lines += _draw_openings(ax, symbols)
        if len(symbols.door_leaves):
            legend.append((_door_handle(), "door (leaf and swing)"))
        if len(symbols.windows):
            legend.append((Line2D([], [], color=WINDOW_COLOR, lw=0.5), "window"))
        # room labels may sit over a stair's treads (on their halo), nothing else may
        stair_lines, handles = _draw_stairs(ax, symbols, sheet)
        legend += handles
        void_lines, handles = _draw_voids(ax, symbols)
        lines += void_lines
        legend += handles
    lines += annotation_obstacles(annotations.positions, annotations.directions)
    placer = None
    if symbols is not None:
        chain_texts = _chain_geometry(ax, symbols, sheet, params)
        lines += chain_texts.lines
        placer = Placer(fig, ax, lines)
        _place_room_labels(ax, symbols, params, placer)
        for g in stair_lines:
            placer.add_line(g)
        _place_stair_texts(ax, symbols, placer)
        chain_texts.place(placer)
        _place_room_dimensions(ax, symbols, sheet, params, placer)
    marks = draw_annotations(ax, annotations.labels, annotations.kinds, annotations.positions, annotations.directions, placer=placer, legend=False)
    # a user's door or window mark is told apart from the door and window drawn from the scan
    legend += [(h, f"{n} (annotation)" if n in ("door", "window") else n) for h, n in marks]
    if isinstance(plan, MarkedDrafting) and (len(plan.dashed) or plan.low_rooms or len(plan.low_openings)):
        legend.append((Line2D([], [], color=LOW_CONFIDENCE_COLOR, lw=1.0, ls=LOW_CONFIDENCE_DASH), "low confidence: check on site"))
    _draw_sheet(fig, sheet, params, f"Drafting plan, cut at {cut_text}", _story_name(s, n_stories, params.imperial), scan, north_deg, legend)
    return fig


# --- walls, openings and rooms -----------------------------------------------------------------


def _path_of(geom):
    """A matplotlib path of a shapely (multi)polygon, holes included."""
    from matplotlib.path import Path

    verts, codes = [], []
    for poly in getattr(geom, "geoms", [geom]):
        if poly.is_empty or poly.geom_type != "Polygon":
            continue
        for ring in (poly.exterior, *poly.interiors):
            c = np.asarray(ring.coords)
            verts.append(c)
            codes.append(np.r_[Path.MOVETO, np.full(len(c) - 2, Path.LINETO), Path.CLOSEPOLY])
    if not verts:
        return None
    return Path(np.concatenate(verts), np.concatenate(codes).astype(np.uint8))


def _draw_wall_solids(ax, symbols: PlanSymbols) -> tuple[list, list]:
    """The walls as solids: exterior black with a heavy outline, interior dark grey, the
    low-confidence ones hatched in red. Returns their outlines (for texts to avoid) and the
    legend entries."""
    import shapely
    from matplotlib.patches import Patch, PathPatch

    styles: dict[str, dict[str, Any]] = {
        "exterior": dict(facecolor=POCHE_EXTERIOR, edgecolor=WALL_COLOR, linewidth=0.9, zorder=4),
        "interior": dict(facecolor=POCHE_INTERIOR, edgecolor=WALL_COLOR, linewidth=0.45, zorder=3.5),
        "low": dict(facecolor="white", edgecolor=LOW_CONFIDENCE_COLOR, linewidth=0.6, hatch="////", linestyle=LOW_CONFIDENCE_DASH, zorder=4.5),
    }
    names = {"exterior": "exterior wall (cut)", "interior": "interior wall (cut)", "low": "wall of low confidence"}
    outlines, legend = [], []
    for kind, style in styles.items():
        polys = [w.polygon for w in symbols.wall_solids if (w.low if kind == "low" else not w.low and (kind == "exterior") == w.exterior)]
        if not polys:
            continue
        geom = shapely.union_all(polys)
        path = _path_of(geom)
        if path is None:
            continue
        ax.add_patch(PathPatch(path, **style))
        outlines.append(geom.boundary)
        legend.append((Patch(**{k: v for k, v in style.items() if k != "zorder"}), names[kind]))
    return outlines, legend


def _draw_openings(ax, symbols: PlanSymbols) -> list:
    """Jambs, windows (frame lines in the wall's thickness), door leaves and swings; returns
    them as lines for texts to avoid."""
    import shapely
    from matplotlib.collections import LineCollection
    from matplotlib.patches import Arc as ArcPatch

    ax.add_collection(LineCollection(list(symbols.jambs), colors=WALL_COLOR, linewidths=0.5, zorder=5))
    ax.add_collection(LineCollection(list(symbols.windows), colors=WINDOW_COLOR, linewidths=0.4, zorder=5))
    ax.add_collection(LineCollection(list(symbols.door_leaves), colors=WALL_COLOR, linewidths=1.1, zorder=5))
    out = [shapely.LineString(seg) for seg in (*symbols.jambs, *symbols.windows, *symbols.door_leaves)]
    for a in symbols.door_arcs:
        ax.add_patch(ArcPatch(a.center, 2 * a.radius, 2 * a.radius, theta1=a.start_deg, theta2=a.end_deg, color=WALL_COLOR, lw=0.35, zorder=5))
        out.append(arc_line(a.center, a.radius, a.start_deg, a.end_deg))
    return out


def _door_handle():
    from matplotlib.lines import Line2D

    return Line2D([], [], color=WALL_COLOR, lw=1.1)


def _draw_rooms(ax, symbols: PlanSymbols) -> list:
    """Rooms tinted lightly by type, with a fine dashed edge (where no wall closes a room,
    the dashes show where it was closed from the scanned floor). Returns the legend entries."""
    from matplotlib.collections import PolyCollection
    from matplotlib.patches import Patch

    types = symbols.room_types if len(symbols.room_types) == len(symbols.room_outlines) else ("room",) * len(symbols.room_outlines)
    colors = [ROOM_TINTS.get(t, ROOM_TINT) for t in types]
    ax.add_collection(PolyCollection(symbols.room_outlines, facecolors=colors, edgecolors=ROOM_EDGE, linewidths=0.3, linestyles=(0, (3, 2)), zorder=1))
    return [(Patch(facecolor=ROOM_TINTS.get(t, ROOM_TINT), edgecolor=ROOM_EDGE, linewidth=0.3), t) for t in dict.fromkeys(types)]


def _place_room_labels(ax, symbols: PlanSymbols, params: RenderParams, placer: Placer) -> None:
    """Each room's name, number and area at its pole of inaccessibility, as large as fits in
    the room (7.5 to 4.5 points), else name and number only, else the name only (never the
    number alone, which reads as a dimension), else moved within the room."""
    import shapely

    outlines = [shapely.Polygon(r) for r in symbols.room_outlines]
    for k, lab in enumerate(symbols.room_labels):
        room = outlines[k] if k < len(outlines) else None
        inside = room.buffer(-0.02) if room is not None and room.is_valid else None
        name = plain_text(lab.name or lab.text.split("\n")[0])
        area = format_area(lab.area, params.imperial) if lab.area else ""
        number = plain_text(lab.number)
        full = f"{name}\n{number + '  ' if number else ''}{area}" if area else name
        # never the number alone: "0.02" on a plan reads as a dimension
        texts = list(dict.fromkeys([full, f"{name}\n{number}" if number else name, name]))
        spots = [lab.position]
        if room is not None and inside is not None and not inside.is_empty:
            spots += _inner_points(inside, lab.position)
        candidates = [(t, size, p) for t in texts for p in spots[:1] for size in ROOM_LABEL_SIZES]
        candidates += [(t, ROOM_LABEL_SIZES[-1], p) for t in texts for p in spots[1:]]

        def make(c):
            text, size, (x, z) = c
            t = ax.text(
                x, z, text, ha="center", va="center", fontsize=size, color="#1a1a1a", zorder=12, linespacing=1.25,
                multialignment="center", **PLAIN_TEXT_KW,
            )
            return tag(with_halo(t, 2.0), "room-label")

        def spec(c):
            text, size, (x, z) = c
            return Spot(x, z, text, size, linespacing=1.25)

        if placer.place(make, candidates, inside=inside, spec=spec) is None and placer.place(make, candidates, spec=spec) is None:
            continue  # nowhere free in or near the room: left out rather than drawn over lines


def _inner_points(poly, first, n: int = 14) -> list:
    """Points well inside ``poly`` (on a grid, deepest first), for a label that does not fit at
    the room's pole."""
    import shapely

    x0, z0, x1, z1 = poly.bounds
    g = np.stack(np.meshgrid(np.linspace(x0, x1, 9)[1:-1], np.linspace(z0, z1, 9)[1:-1]), -1).reshape(-1, 2)
    pts = shapely.points(g)
    ok = shapely.contains(poly, pts)
    g, pts = g[ok], pts[ok]
    depth = shapely.distance(pts, poly.exterior)
    return [tuple(map(float, p)) for p in g[np.argsort(-depth)][:n]]


# --- stairs ------------------------------------------------------------------------------------


def _draw_stairs(ax, symbols: PlanSymbols, sheet: Sheet) -> tuple[list, list]:
    """The stairs of the story with the usual symbol (:class:`meshplan.plan.symbols.StairSymbol`):
    treads and stringers, the part above the cut dashed, the break line at the cut, the walking
    line from a dot at its foot to the arrow of ascent, and on the upper story the void outlined
    dash-dotted and crossed. Returns the lines (for texts to avoid) and the legend entries."""
    import shapely
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D
    from matplotlib.patches import Circle, Polygon

    if not symbols.stairs:
        return [], []
    mm = sheet.scale / 1000.0
    solid: list = []
    hidden: list = []
    cuts, walks, walks_hidden, voids, crosses = [], [], [], [], []
    out: list = []
    for st in symbols.stairs:
        solid += list(st.lines)
        hidden += list(st.hidden)
        if len(st.cut) >= 2:
            cuts.append(st.cut)
        if len(st.walk) >= 2:
            walks.append(st.walk)
        if len(st.walk_hidden) >= 2:
            walks_hidden.append(st.walk_hidden)
        if len(st.void) >= 4:
            voids.append(st.void)
        crosses += list(st.cross)
        # the arrow head at the top of the walking line, pointing up the stair
        ends = [w for w in (st.walk_hidden, st.walk) if len(w) >= 2]
        if ends:
            tip = np.asarray(ends[0][-1])
            d = np.asarray(st.arrow)
            across = np.array([-d[1], d[0]])
            length, width = (v * mm for v in STAIR_ARROW_MM)
            head = [tip, tip - d * length + across * 0.5 * width, tip - d * length - across * 0.5 * width]
            ax.add_patch(Polygon(head, closed=True, facecolor=STAIR_COLOR, edgecolor="none", zorder=6))
            out.append(shapely.Polygon(head))
        if len(st.walk) >= 2 and st.role == "lower":
            ax.add_patch(Circle(tuple(st.walk[0]), 0.5 * STAIR_DOT_MM * mm, facecolor="white", edgecolor=STAIR_COLOR, lw=0.5, zorder=6))
    kw: dict[str, Any] = dict(colors=STAIR_COLOR, zorder=2.8)
    if solid:
        ax.add_collection(LineCollection(solid, linewidths=0.4, **kw))
    if hidden:
        ax.add_collection(LineCollection(hidden, linewidths=0.35, linestyles=STAIR_HIDDEN_DASH, **kw))
    if cuts:
        ax.add_collection(LineCollection(cuts, linewidths=0.6, **kw))
    _draw_void_lines(ax, voids, crosses)
    if walks:
        ax.add_collection(LineCollection(walks, linewidths=0.45, zorder=5.5, colors=STAIR_COLOR))
    if walks_hidden:
        ax.add_collection(LineCollection(walks_hidden, linewidths=0.45, linestyles=STAIR_HIDDEN_DASH, zorder=5.5, colors=STAIR_COLOR))
    out += [shapely.LineString(seg) for seg in (*solid, *hidden, *crosses)]
    out += [shapely.LineString(c) for c in (*cuts, *walks, *walks_hidden, *voids)]
    legend = [(Line2D([0, 1], [0, 0], color=STAIR_COLOR, lw=0.45, marker=">", markersize=3.5, markevery=[-1]), "stair: walking line, arrow up")]
    if hidden:
        legend.append((Line2D([], [], color=STAIR_COLOR, lw=0.35, ls=STAIR_HIDDEN_DASH), "stair above the cut"))
    if voids:
        legend.append((Line2D([], [], color=STAIR_COLOR, lw=0.7, ls=VOID_DASH), "void in the floor (over a stair)"))
    return out, legend


def _draw_void_lines(ax, rings: list, crosses: list) -> None:
    """Holes in a floor: their outlines dash-dotted, their crosses thin (a stair's void and a
    double-height space's alike)."""
    from matplotlib.collections import LineCollection

    kw: dict[str, Any] = dict(colors=STAIR_COLOR, zorder=2.8)
    if rings:
        ax.add_collection(LineCollection(rings, linewidths=0.7, linestyles=VOID_DASH, **kw))
    if crosses:
        ax.add_collection(LineCollection(crosses, linewidths=0.25, **kw))


def _draw_voids(ax, symbols: PlanSymbols) -> tuple[list, list]:
    """The holes in the floor over double-height spaces, outlined dash-dotted and crossed as a
    stair's void is. Returns their lines (for texts to avoid) and the legend entry."""
    import shapely
    from matplotlib.lines import Line2D

    if not symbols.voids:
        return [], []
    _draw_void_lines(ax, list(symbols.voids), list(symbols.void_crosses))
    lines = [shapely.LineString(r) for r in symbols.voids] + [shapely.LineString(s) for s in symbols.void_crosses]
    return lines, [(Line2D([], [], color=STAIR_COLOR, lw=0.7, ls=VOID_DASH), "void in the floor (double-height space)")]


def _place_stair_texts(ax, symbols: PlanSymbols, placer: Placer) -> None:
    """Each stair's risers, rise and going beside the foot of its walking line (lower story),
    where it covers nothing; else left out."""
    for st in symbols.stairs:
        if st.role != "lower" or len(st.walk) < 2:
            continue
        foot = np.asarray(st.walk[0])
        d = np.asarray(st.walk[1]) - foot
        d = d / (np.linalg.norm(d) or 1.0)
        across = np.array([-d[1], d[0]])
        spots = [foot - d * 0.3, foot - d * 0.3 + across * 0.3, foot - d * 0.3 - across * 0.3, foot + d * 0.6]
        candidates = [(float(p[0]), float(p[1])) for p in spots]

        def make(c, text=st.text):
            t = ax.text(c[0], c[1], text, ha="center", va="center", fontsize=STAIR_TEXT_PT, color=STAIR_COLOR, zorder=12, **PLAIN_TEXT_KW)
            return tag(with_halo(t, 1.5), "stair-label")

        def spec(c, text=st.text):
            return Spot(c[0], c[1], text, STAIR_TEXT_PT)

        placer.place(make, candidates, spec=spec)


# --- dimensions --------------------------------------------------------------------------------


class _ChainTexts:
    """The chains' lines (drawn at once) and their texts (placed once the room labels are)."""

    def __init__(self) -> None:
        self.lines: list = []
        self.texts: list = []  # (make, candidates, spec)

    def place(self, placer: Placer) -> None:
        for make, candidates, spec in self.texts:
            placer.place(make, candidates, spec=spec)


def _dimension_text(ax, x, z, text, rotation, ha, va):
    t = ax.text(x, z, text, fontsize=DIM_TEXT_PT, color=DIM_COLOR, ha=ha, va=va, rotation=rotation, rotation_mode="anchor", zorder=11)
    return tag(t, "dimension")


def merge_ticks(ticks, gap: float, prefer=()) -> np.ndarray:
    """``ticks`` (sorted) with each run of ticks closer than ``gap`` to the next made one: the
    chain's first or last tick where the run holds it (the overall size stays), else a tick of
    ``prefer`` (the coarser chain's, so that the chains agree), else the run's middle tick."""
    t = np.sort(np.asarray(ticks, dtype=np.float64))
    if len(t) < 2:
        return t
    prefer = np.asarray(prefer, dtype=np.float64)
    runs = np.split(t, np.flatnonzero(np.diff(t) >= gap) + 1)
    out = []
    for run in runs:
        if run[0] == t[0]:
            out.append(t[0])
        elif run[-1] == t[-1]:
            out.append(t[-1])
        else:
            shared = [u for u in run if len(prefer) and np.min(np.abs(prefer - u)) < 1e-9]
            out.append(shared[0] if shared else run[(len(run) - 1) // 2])
    return np.asarray(out)


def _merged_chains(chains, gap: float) -> list:
    """The chains of one side, nearest the building first, each with its ticks merged
    (:func:`merge_ticks`, coarser chains first so that finer ones keep their ticks); a chain
    left measuring nothing the next coarser one does not is dropped."""
    kept: list = []
    coarser = np.zeros(0)
    for c in sorted(chains, key=lambda c: -c.tier):
        t = merge_ticks(c.ticks, gap, coarser)
        if len(t) < 2 or (len(coarser) and len(t) <= len(coarser)):
            continue
        kept.append((c, t))
        coarser = t
    return sorted(kept, key=lambda ct: ct[0].tier)


def _chain_geometry(ax, symbols: PlanSymbols, sheet: Sheet, params: RenderParams) -> _ChainTexts:
    """Draw the dimension chains outside the building: each at a fixed paper distance from the
    outermost face (8 mm, then every 6 mm), with extension lines, oblique ticks and each
    length above its line (or beside it where it does not fit)."""
    import shapely
    from matplotlib.collections import LineCollection

    mm = sheet.scale / 1000.0  # model metres per paper millimetre
    out = _ChainTexts()
    segs, ticks = [], []
    sides: dict[tuple[int, int], list] = {}
    for c in symbols.chains:
        sides.setdefault((c.axis, c.outward), []).append(c)
    for (axis, outward), chains in sorted(sides.items()):
        merged = _merged_chains(chains, DIM_TICK_MERGE_MM * mm)
        for rank, (c, t) in enumerate(merged):
            at = c.base + outward * (DIM_FIRST_MM + DIM_STEP_MM * rank) * mm

            def pt(u, v, axis=axis):
                return (u, v) if axis == 0 else (v, u)

            segs.append([pt(t[0] - 1.5 * mm, at), pt(t[-1] + 1.5 * mm, at)])
            for u in t:
                segs.append([pt(u, c.base + outward * 2.0 * mm), pt(u, at + outward * 1.5 * mm)])
                d = 1.1 * mm
                # a 45-degree slash, the same way on every side
                ticks.append([pt(u - d, at + d * (1 if axis == 0 else -1)), pt(u + d, at - d * (1 if axis == 0 else -1))])
            for u0, u1 in zip(t[:-1], t[1:]):
                text = format_length(float(u1 - u0), params.imperial)
                mid = 0.5 * (u0 + u1)
                gap = 0.7 * mm
                # horizontal chains read from below, vertical ones from the right (rotated 90)
                if axis == 0:
                    cands = [((mid, at - gap), 0, "center", "bottom"), ((mid, at + gap), 0, "center", "top")]
                    cands += [((u1 + 2.5 * mm, at - gap), 0, "left", "bottom"), ((u0 - 2.5 * mm, at - gap), 0, "right", "bottom")]
                else:
                    cands = [((at - gap, mid), 90, "center", "bottom"), ((at + gap, mid), 90, "center", "top")]
                    cands += [((at - gap, u1 + 2.5 * mm), 90, "right", "bottom"), ((at - gap, u0 - 2.5 * mm), 90, "left", "bottom")]

                def make(cand, text=text):
                    (x, z), rot, ha, va = cand
                    return _dimension_text(ax, x, z, text, rot, ha, va)

                def spec(cand, text=text):
                    (x, z), rot, ha, va = cand
                    return Spot(x, z, text, DIM_TEXT_PT, ha, va, rot)

                out.texts.append((make, cands, spec))
    ax.add_collection(LineCollection(segs, colors=DIM_COLOR, linewidths=0.3, zorder=2))
    ax.add_collection(LineCollection(ticks, colors=DIM_COLOR, linewidths=0.7, zorder=2))
    out.lines = [shapely.LineString(s) for s in segs + ticks]
    return out


def _place_room_dimensions(ax, symbols: PlanSymbols, sheet: Sheet, params: RenderParams, placer: Placer) -> None:
    """A room's clear width and depth inside it, at the first place across the room where the
    line crosses no symbol or text and its length fits between its ticks; else left out."""
    import shapely
    from matplotlib.collections import LineCollection

    mm = sheet.scale / 1000.0
    segs, ticks = [], []
    for d in symbols.room_dimensions:
        text = format_length(d.hi - d.lo, params.imperial)
        mid = 0.5 * (d.lo + d.hi)
        for v in d.across:
            pt = (lambda u, v=v: (u, v)) if d.axis == 0 else (lambda u, v=v: (v, u))
            line = shapely.LineString([pt(d.lo + 0.05), pt(d.hi - 0.05)])
            if not placer.free(line.buffer(0.3 * mm)):
                continue
            x, z = (mid, v - 0.6 * mm) if d.axis == 0 else (v - 0.6 * mm, mid)
            box = placer.spot_box(Spot(x, z, text, DIM_TEXT_PT, "center", "bottom", 90.0 * d.axis))
            if box.bounds[2 + d.axis] - box.bounds[d.axis] > 0.7 * (d.hi - d.lo) or not placer.free(box):
                continue
            _dimension_text(ax, x, z, text, 90.0 * d.axis, "center", "bottom")
            placer.keep(box)
            placer.add_line(line)
            segs.append([pt(d.lo), pt(d.hi)])
            k = 1.0 * mm
            for u in (d.lo, d.hi):
                a, b = (np.array(pt(u)) + s * np.array([k, -k if d.axis == 0 else k]) for s in (-1, 1))
                ticks.append([tuple(a), tuple(b)])
            break
    if segs:
        ax.add_collection(LineCollection(segs, colors=DIM_COLOR, linewidths=0.3, zorder=2))
        ax.add_collection(LineCollection(ticks, colors=DIM_COLOR, linewidths=0.7, zorder=2))


def _draw_low_confidence(ax, plan: MarkedDrafting) -> None:
    """The low-confidence walls, rooms and openings of a ``MarkedDrafting`` plan, dashed, with a
    note saying what the dashes mean when there are any."""
    from matplotlib.collections import LineCollection

    dashed, rooms, openings = plan.dashed, plan.low_rooms, plan.low_openings
    if len(dashed):
        ax.add_collection(LineCollection(list(dashed), colors=LOW_CONFIDENCE_COLOR, linewidths=1.6, linestyles=LOW_CONFIDENCE_DASH, zorder=3))
    if rooms:
        ax.add_collection(LineCollection(list(rooms), colors=LOW_CONFIDENCE_COLOR, linewidths=0.7, linestyles=LOW_CONFIDENCE_DASH, zorder=2))
    if len(openings):
        ax.add_collection(LineCollection(list(openings), colors=LOW_CONFIDENCE_COLOR, linewidths=1.0, linestyles=LOW_CONFIDENCE_DASH, zorder=4))
    if len(dashed) or rooms or len(openings):
        ax.text(0.01, 0.01, "dashed red: low confidence (check on site)", transform=ax.transAxes, ha="left", fontsize=5.5, color=LOW_CONFIDENCE_COLOR)


def segments_figure(centroids: np.ndarray, walls: FlatWalls, story: int, sheet: Sheet, params: RenderParams, n_stories: int = 1):
    """Each DBSCAN wall segment in its own colour, seen from above; segments that were not kept
    as walls (too small, not floor to ceiling: furniture) in grey. ``centroids`` are the
    ``(F, 3)`` face centroids of the mesh the walls were found in."""
    seg = walls.face_segment
    valid = np.flatnonzero(seg >= 0)  # faces in some segment (there may be none at all)
    sel = valid[walls.segment_story[seg[valid]] == story]
    title = f"Wall segments (box DBSCAN){'  story ' + str(story) if n_stories > 1 else ''}"
    fig, ax = new_figure(sheet, title, params)
    c = centroids[sel]
    s = seg[sel]
    kept = walls.segment_kept[s]
    from matplotlib.colors import to_rgba_array

    # colour by rank among kept segments; a strided palette so that neighbours differ
    ranks = np.unique(s[kept], return_inverse=True)[1] if kept.any() else np.zeros(0, int)
    palette = (to_rgba_array(SEGMENT_COLORS) * 255).astype(np.uint8)
    rows, cols = sheet.raster_shape
    image = np.zeros((rows, cols, 4), dtype=np.uint8)
    px = ((c[:, 0] - sheet.xmin) / sheet.pixel_m).astype(np.int64)
    pz = ((c[:, 2] - sheet.zmin) / sheet.pixel_m).astype(np.int64)
    ok = (px >= 0) & (px < cols) & (pz >= 0) & (pz < rows)
    grey = ok & ~kept
    image[pz[grey], px[grey]] = (200, 200, 200, 255)
    colored = ok & kept
    image[pz[colored], px[colored]] = palette[(ranks[colored[kept]] * 5) % len(palette)]
    # centroids are a few pixels apart: thicken each dot to 2x2 pixels
    alpha = image[..., 3]
    grown = grow_max(image, 2)
    image = np.where(alpha[..., None] > 0, image, grown)
    ax.patch.set_alpha(0.0)
    place_raster(fig, ax, image)
    n_kept = int(np.unique(s[kept]).size)
    n_all = int(np.unique(s).size)
    ax.text(0.01, 0.01, f"{n_kept} wall segments kept of {n_all}", transform=ax.transAxes, fontsize=6, color="#333333")
    draw_scale_bar(fig, sheet, params)
    return fig

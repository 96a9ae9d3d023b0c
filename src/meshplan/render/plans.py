"""The plan drawings: pen-and-ink, drafting and DBSCAN wall segments."""

from __future__ import annotations

import numpy as np

from ..geometry import Annotations
from ..plan import DraftingPlan, PenAndInkPlan
from ..plan.elements import MarkedDrafting
from ..plan.symbols import PlanSymbols
from ..validation import PLAIN_TEXT_KW, plain_text
from ..walls import FlatWalls
from .params import RenderParams
from .sheet import Sheet, draw_annotations, draw_scale_bar, ink_rgba, new_figure, place_raster, rasterize_segments

WALL_COLOR = "#111111"
DIM_COLOR = "#6a6a6a"
ROOM_TINT = "#eef3f8"
ROOM_EDGE = "#8aa0b8"
#: Low-confidence walls, rooms and openings (``plan.elements.MarkedDrafting``) are drawn dashed
#: in this colour, as RoomPlan draws what it is unsure of, so that a reader checks them.
LOW_CONFIDENCE_COLOR = "#c0392b"
LOW_CONFIDENCE_DASH = (0, (4, 2.5))
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


def pen_and_ink_figure(plan: PenAndInkPlan, annotations: Annotations, sheet: Sheet, params: RenderParams, n_stories: int = 1):
    """All slices overlaid in translucent ink (:func:`pen_and_ink_raster`); what stands at many
    heights is dark. One figure serves every format it is saved in."""
    s = plan.story
    n = len(plan.slices.heights) - 1
    title = _story_title(f"Pen-and-ink ({n} slices, opacity {params.opacity:g})", s.index, n_stories, s.floor, s.ceiling, params.imperial)
    fig, ax = new_figure(sheet, title, params)
    ax.patch.set_alpha(0.0)  # the ink sits under the axes
    place_raster(fig, ax, pen_and_ink_raster(plan, sheet, params))
    draw_annotations(ax, annotations.labels, annotations.kinds, annotations.positions, annotations.directions)
    draw_scale_bar(fig, sheet, params)
    return fig


def drafting_figure(
    plan: DraftingPlan,
    annotations: Annotations,
    sheet: Sheet,
    params: RenderParams,
    n_stories: int = 1,
    symbols: PlanSymbols | None = None,
):
    """The flat-wall model cut once, drawn as clean wall lines, with rooms, doors, windows and
    dimensions."""
    from matplotlib.collections import LineCollection
    from matplotlib.patches import Arc as ArcPatch

    s = plan.story
    cut = plan.height - s.floor
    fig, ax = new_figure(sheet, _story_title(f"Drafting (cut at {cut:.2f} m)", s.index, n_stories, s.floor, s.ceiling, params.imperial), params)
    # list(): the stubs want a Sequence of segments, an (S, 2, 2) array iterates the same
    # a MarkedDrafting sets its low-confidence walls apart: drawn dashed
    solid = plan.solid if isinstance(plan, MarkedDrafting) else plan.slices.segments
    ax.add_collection(LineCollection(list(solid), colors=WALL_COLOR, linewidths=1.6, capstyle="projecting", zorder=3))
    if isinstance(plan, MarkedDrafting):
        _draw_low_confidence(ax, plan)
    if symbols is not None:
        # rooms as a light tint with a dashed edge: where no wall closes a room (a wall the scan
        # missed), the dashes show where it was closed from the scanned floor
        from matplotlib.collections import PolyCollection

        ax.add_collection(PolyCollection(symbols.room_outlines, facecolors=ROOM_TINT, edgecolors=ROOM_EDGE, linewidths=0.4, linestyles=(0, (3, 2)), zorder=1))
        ax.add_collection(LineCollection(list(symbols.jambs), colors=WALL_COLOR, linewidths=0.5, zorder=3))
        ax.add_collection(LineCollection(list(symbols.windows), colors="#1f4e99", linewidths=0.6, zorder=3))
        ax.add_collection(LineCollection(list(symbols.door_leaves), colors=WALL_COLOR, linewidths=0.9, zorder=3))
        for a in symbols.door_arcs:
            ax.add_patch(ArcPatch(a.center, 2 * a.radius, 2 * a.radius, theta1=a.start_deg, theta2=a.end_deg, color=WALL_COLOR, lw=0.4, ls="--", zorder=3))
        _draw_dimensions(ax, symbols)
        for lab in symbols.room_labels:
            # room labels may one day carry a user's name: drawn as plain text, lines kept
            text = plain_text(lab.text, keep_newlines=True)
            ax.text(*lab.position, text, ha="center", va="center", fontsize=6.5, color="#222222", zorder=4, linespacing=1.3, **PLAIN_TEXT_KW)
    draw_annotations(ax, annotations.labels, annotations.kinds, annotations.positions, annotations.directions)
    draw_scale_bar(fig, sheet, params)
    return fig


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


def _draw_dimensions(ax, symbols: PlanSymbols) -> None:
    from matplotlib.collections import LineCollection

    lines, ticks = [], []
    for d in symbols.dimensions:
        p1, p2 = np.asarray(d.p1), np.asarray(d.p2)
        u = (p2 - p1) / np.linalg.norm(p2 - p1)
        left = np.array([-u[1], u[0]])
        a, b = p1 + left * d.offset, p2 + left * d.offset
        lines.append([a, b])
        lines.append([p1 + left * 0.05, a + left * 0.05])  # extension lines
        lines.append([p2 + left * 0.05, b + left * 0.05])
        diag = (u + left) * 0.06
        ticks.extend([[a - diag, a + diag], [b - diag, b + diag]])
        angle = np.degrees(np.arctan2(u[1], u[0]))
        # text upright on a page with z down: matplotlib measures rotation on screen
        rot = -angle
        if rot > 90 or rot < -90:
            rot += 180
        mid = 0.5 * (a + b) + left * 0.07
        angle = ((rot + 180) % 360) - 180
        ax.text(mid[0], mid[1], d.text, fontsize=4.5, color=DIM_COLOR, ha="center", va="center", rotation=angle, rotation_mode="anchor", zorder=4)
    ax.add_collection(LineCollection(lines, colors=DIM_COLOR, linewidths=0.3, zorder=2))
    ax.add_collection(LineCollection(ticks, colors=DIM_COLOR, linewidths=0.5, zorder=2))


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
    from scipy.ndimage import maximum_filter

    alpha = image[..., 3]
    grown = maximum_filter(image, size=(2, 2, 1))
    image = np.where(alpha[..., None] > 0, image, grown)
    ax.patch.set_alpha(0.0)
    place_raster(fig, ax, image)
    n_kept = int(np.unique(s[kept]).size)
    n_all = int(np.unique(s).size)
    ax.text(0.01, 0.01, f"{n_kept} wall segments kept of {n_all}", transform=ax.transAxes, fontsize=6, color="#333333")
    draw_scale_bar(fig, sheet, params)
    return fig

"""The plan drawings: pen-and-ink, drafting and DBSCAN wall segments."""

from __future__ import annotations

import numpy as np

from ..geometry import Annotations, Mesh
from ..plan import DraftingPlan, PenAndInkPlan
from ..walls import FlatWalls
from .params import RenderParams
from .sheet import Sheet, draw_annotations, draw_scale_bar, ink_rgba, new_figure, place_raster, rasterize_segments

WALL_COLOR = "#111111"
#: Saturated colours for wall segments (no greys: grey marks the segments that were dropped).
SEGMENT_COLORS = (
    "#e6194b", "#3cb44b", "#4363d8", "#f58231", "#911eb4", "#42d4f4", "#f032e6", "#9a6324",
    "#800000", "#469990", "#000075", "#bfef45", "#e6b800", "#fabed4", "#808000", "#dcbeff",
)


def _story_title(kind: str, story_index: int, n_stories: int, floor: float, ceiling: float, imperial: bool) -> str:
    unit, name = (0.3048, "ft") if imperial else (1.0, "m")
    where = f"story {story_index}" if n_stories > 1 else "plan"
    return f"{kind} {where}  (floor {floor / unit:.2f} {name}, ceiling {ceiling / unit:.2f} {name})"


def pen_and_ink_figure(plan: PenAndInkPlan, annotations: Annotations, sheet: Sheet, params: RenderParams, n_stories: int = 1):
    """All slices overlaid in translucent ink; what stands at many heights is dark."""
    s = plan.story
    n = len(plan.slices.heights) - 1
    fig, ax = new_figure(sheet, _story_title(f"Pen-and-ink ({n} slices, opacity {params.opacity:g})", s.index, n_stories, s.floor, s.ceiling, params.imperial), params)
    counts = rasterize_segments(plan.slices.segments, plan.slices.level, sheet)
    ax.patch.set_alpha(0.0)  # the ink sits under the axes
    place_raster(fig, ax, ink_rgba(counts, params.opacity))
    draw_annotations(ax, annotations.labels, annotations.kinds, annotations.positions, annotations.directions)
    draw_scale_bar(fig, sheet, params)
    return fig


def drafting_figure(plan: DraftingPlan, annotations: Annotations, sheet: Sheet, params: RenderParams, n_stories: int = 1):
    """The flat-wall model cut once, drawn as clean wall lines."""
    from matplotlib.collections import LineCollection

    s = plan.story
    cut = plan.height - s.floor
    fig, ax = new_figure(sheet, _story_title(f"Drafting (cut at {cut:.2f} m)", s.index, n_stories, s.floor, s.ceiling, params.imperial), params)
    ax.add_collection(LineCollection(plan.slices.segments, colors=WALL_COLOR, linewidths=1.6, capstyle="projecting", zorder=3))
    draw_annotations(ax, annotations.labels, annotations.kinds, annotations.positions, annotations.directions)
    draw_scale_bar(fig, sheet, params)
    return fig


def segments_figure(mesh: Mesh, walls: FlatWalls, story: int, sheet: Sheet, params: RenderParams, n_stories: int = 1):
    """Each DBSCAN wall segment in its own colour, seen from above; segments that were not kept
    as walls (too small, not floor to ceiling: furniture) in grey."""
    seg = walls.face_segment
    sel = np.flatnonzero((seg >= 0) & (walls.segment_story[np.maximum(seg, 0)] == story))
    title = f"Wall segments (box DBSCAN){'  story ' + str(story) if n_stories > 1 else ''}"
    fig, ax = new_figure(sheet, title, params)
    c = mesh.face_centroids[sel]
    s = seg[sel]
    kept = walls.segment_kept[s]
    from matplotlib.colors import to_rgba_array

    # colour by rank among kept segments; a strided palette so that neighbours differ
    ranks = np.unique(s[kept], return_inverse=True)[1] if kept.any() else np.zeros(0, int)
    palette = to_rgba_array(SEGMENT_COLORS)
    colors = palette[(ranks * 5) % len(palette)] if kept.any() else np.zeros((0, 4))
    ax.scatter(c[~kept, 0], c[~kept, 2], s=0.3, c="#c8c8c8", linewidths=0, rasterized=True, zorder=1)
    ax.scatter(c[kept, 0], c[kept, 2], s=0.8, c=colors, linewidths=0, rasterized=True, zorder=2)
    n_kept = int(np.unique(s[kept]).size)
    n_all = int(np.unique(s).size)
    ax.text(0.01, 0.01, f"{n_kept} wall segments kept of {n_all}", transform=ax.transAxes, fontsize=6, color="#333333")
    draw_scale_bar(fig, sheet, params)
    return fig

"""Drawings: plans at a stated scale and diagnostic figures, rendered to bytes (writing them is
:mod:`meshplan.export`'s job)."""

from .params import RenderParams
from .plans import drafting_figure, pen_and_ink_figure, pen_and_ink_raster, segments_figure
from .plots import levels_figure, normals_figure
from .sheet import Sheet, figure_bytes, make_sheet

__all__ = [
    "RenderParams",
    "Sheet",
    "drafting_figure",
    "figure_bytes",
    "levels_figure",
    "make_sheet",
    "normals_figure",
    "pen_and_ink_figure",
    "pen_and_ink_raster",
    "segments_figure",
]

"""Drawings: plans at a stated scale and diagnostic figures, rendered to bytes (writing them is
:mod:`meshplan.export`'s job).

The names below are loaded when first used (PEP 562): :mod:`meshplan.options` reads
:class:`RenderParams` to list the defaults of ``meshplan run --help``, and should not import the
drawing code (and with it the plan and wall stages) to do so.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_exports
from .params import RenderParams

if TYPE_CHECKING:  # pragma: no cover
    from .plans import drafting_figure, pen_and_ink_figure, pen_and_ink_raster, segments_figure
    from .plots import levels_figure, normals_figure, normals_heat_map, normals_histogram
    from .sheet import Sheet, figure_bytes, figure_files, make_sheet

#: Where each lazily loaded name lives (a submodule of this package).
_EXPORTS = {
    "drafting_figure": "plans",
    "pen_and_ink_figure": "plans",
    "pen_and_ink_raster": "plans",
    "segments_figure": "plans",
    "levels_figure": "plots",
    "normals_figure": "plots",
    "normals_heat_map": "plots",
    "normals_histogram": "plots",
    "Sheet": "sheet",
    "figure_bytes": "sheet",
    "figure_files": "sheet",
    "make_sheet": "sheet",
}

__all__ = [
    "RenderParams",
    "Sheet",
    "drafting_figure",
    "figure_bytes",
    "figure_files",
    "levels_figure",
    "make_sheet",
    "normals_figure",
    "normals_heat_map",
    "normals_histogram",
    "pen_and_ink_figure",
    "pen_and_ink_raster",
    "segments_figure",
]


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())

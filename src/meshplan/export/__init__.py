"""Writing a result: plan.json, 3D models, drawings and CAD files, all into one directory that
appears atomically (see :func:`meshplan.io.staged_directory`)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..io import staged_directory
from ..orient import without_ceiling
from ..render import (
    drafting_figure,
    figure_bytes,
    levels_figure,
    make_sheet,
    normals_figure,
    pen_and_ink_figure,
    segments_figure,
)
from ..plan.symbols import plan_symbols
from ..slicing import slice_mesh
from .dxf import drafting_dxf
from .glb import WALL_RGBA, glb_bytes
from .planjson import dumps, plan_document, plan_schema
from .report import report_html

if TYPE_CHECKING:  # pragma: no cover
    from ..pipeline import Result, _Timer

__all__ = ["dumps", "plan_document", "plan_schema", "render_files", "write_results"]


def render_files(result: Result, timer: _Timer | None = None) -> dict[str, bytes]:
    """Every output file except plan.json, as ``name -> bytes``.

    Drawing counts as the paper's slicing-and-drawing time (``slice_draw``); building the 3D
    models and CAD files as ``write``.
    """
    from contextlib import nullcontext

    stage = timer.stage if timer else (lambda name: nullcontext())
    files: dict[str, bytes] = {}
    o = result.orientation
    mesh = result.mesh
    params = result.options.render
    n = len(result.stories)
    heights = mesh.face_centroids[:, 1]
    symbols = {}
    with stage("slice_draw"):
        files["levels.png"] = figure_bytes(levels_figure(o, params), "png")
        files["normals.png"] = figure_bytes(normals_figure(mesh.face_normals, mesh.face_areas, o), "png")
        for sp in result.stories:
            i = sp.story.index
            faces = np.flatnonzero(o.face_story == i)
            sheet = make_sheet(mesh.face_centroids[faces][:, [0, 2]], params)
            pen = pen_and_ink_figure(sp.pen_and_ink, sp.annotations, sheet, params, n)
            symbols[i] = plan_symbols(i, result.walls, result.openings, result.rooms, result.physical_walls, params.imperial)
            draft = drafting_figure(sp.drafting, sp.annotations, sheet, params, n, symbols[i])
            for fmt in ("png", "svg", "pdf"):
                files[f"pen-and-ink-{i}.{fmt}"] = figure_bytes(pen, fmt)
                files[f"drafting-{i}.{fmt}"] = figure_bytes(draft, fmt)
            files[f"wall-segments-{i}.png"] = figure_bytes(segments_figure(mesh, result.walls, i, sheet, params, n), "png")
    with stage("write"):
        if result.options.export.ifc:
            from .ifc import ifc_bytes

            files["model.ifc"] = ifc_bytes(result)
        files["oriented.glb"] = glb_bytes(mesh, result.annotations, "scan")
        for sp in result.stories:
            i = sp.story.index
            keep = (o.face_story == i) & without_ceiling(heights, mesh.face_normals[:, 1], sp.story, result.options.orient.slab_tolerance_m)
            files[f"story-{i}.glb"] = glb_bytes(mesh.submesh(np.flatnonzero(keep)), sp.annotations, f"story {i}")
            files[f"flat-walls-{i}.glb"] = glb_bytes(result.walls.mesh(i, result.openings.holes()), sp.annotations, f"flat walls {i}", WALL_RGBA)
            faces = np.flatnonzero(o.face_story == i)
            reference = slice_mesh(mesh.triangles[faces], np.array([sp.drafting.height]))
            files[f"drafting-{i}.dxf"] = drafting_dxf(
                sp.drafting.slices.segments,
                reference.segments,
                sp.annotations,
                f"meshplan drafting plan, story {i}",
                symbols[i],
                [r for r in result.rooms if r.story == i],
            )
        # last: the report inlines the other files
        files["report.html"] = report_html(result, files).encode("utf-8")
    return files


def write_results(result: Result, outdir: Path, force: bool = False, timer: _Timer | None = None, started: float | None = None) -> None:
    """Render and write every output of ``result`` into ``outdir`` (atomically).

    Sets ``result.output_dir``, ``result.files`` and the ``write`` and ``total`` timings.
    """
    files = render_files(result, timer)
    t0 = time.perf_counter()
    with staged_directory(outdir, force=force) as tmp:
        for name, data in files.items():
            (tmp / name).write_bytes(data)
        if timer is not None:
            timer.timings["write"] = timer.timings.get("write", 0.0) + time.perf_counter() - t0
            result.timings = timer.timings
        if started is not None:
            result.timings["total"] = time.perf_counter() - started
        (tmp / "plan.json").write_text(dumps(plan_document(result)), encoding="utf-8")
    result.output_dir = Path(outdir)
    result.files = tuple(["plan.json", *files])

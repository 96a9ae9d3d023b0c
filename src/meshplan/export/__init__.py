"""Writing a result: plan.json, 3D models, drawings and CAD files, all into one directory that
appears atomically (see :func:`meshplan.io.staged_directory`)."""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..io import staged_directory
from ..orient import without_ceiling
from ..render import (
    drafting_figure,
    pen_and_ink_raster,
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


# The state the drawing jobs read; set before worker processes are forked, so they inherit it.
_JOBS: dict = {}


def _job(key: tuple) -> dict[str, bytes]:
    """Render one group of files (run in the main process or a forked worker)."""
    result = _JOBS["result"]
    o, mesh, params = result.orientation, result.mesh, result.options.render
    n = len(result.stories)
    kind = key[0]
    if kind == "levels":
        return {"levels.png": figure_bytes(levels_figure(o, params), "png")}
    if kind == "normals":
        return {"normals.png": figure_bytes(normals_figure(mesh.face_normals, mesh.face_areas, o), "png")}
    if kind == "oriented":
        return {"oriented.glb": glb_bytes(mesh, result.annotations, "scan")}
    if kind == "ifc":
        from .ifc import ifc_bytes

        return {"model.ifc": ifc_bytes(result)}
    i = key[1]
    sp = result.stories[i]
    sheet, symbols = _JOBS["sheets"][i], _JOBS["symbols"][i]
    if kind == "pen":
        fig = pen_and_ink_figure(sp.pen_and_ink, sp.annotations, sheet, params, n, ink=_JOBS["ink"][i])
        return {f"pen-and-ink-{i}.{key[2]}": figure_bytes(fig, key[2])}
    if kind == "drafting":
        fig = drafting_figure(sp.drafting, sp.annotations, sheet, params, n, symbols)
        return {f"drafting-{i}.{fmt}": figure_bytes(fig, fmt) for fmt in key[2:]}
    if kind == "segments":
        return {f"wall-segments-{i}.png": figure_bytes(segments_figure(mesh, result.walls, i, sheet, params, n), "png")}
    if kind == "models":
        heights = mesh.face_centroids[:, 1]
        keep = (o.face_story == i) & without_ceiling(heights, mesh.face_normals[:, 1], sp.story, result.options.orient.slab_tolerance_m)
        return {
            f"story-{i}.glb": glb_bytes(mesh.submesh(np.flatnonzero(keep)), sp.annotations, f"story {i}"),
            f"flat-walls-{i}.glb": glb_bytes(result.walls.mesh(i, result.openings.holes()), sp.annotations, f"flat walls {i}", WALL_RGBA),
        }
    if kind == "dxf":
        faces = np.flatnonzero(o.face_story == i)
        reference = slice_mesh(mesh.triangles[faces], np.array([sp.drafting.height]))
        data = drafting_dxf(
            sp.drafting.slices.segments,
            reference.segments,
            sp.annotations,
            f"meshplan drafting plan, story {i}",
            symbols,
            [r for r in result.rooms if r.story == i],
        )
        return {f"drafting-{i}.dxf": data}
    raise ValueError(key)  # pragma: no cover


def _processes(params) -> int:
    """Worker processes for the drawing jobs: forked workers share the result for free on
    Linux; elsewhere everything runs in the main process."""
    if not sys.platform.startswith("linux"):
        return 1
    n = params.processes or min(os.cpu_count() or 1, 4)
    return max(1, int(n))


def _run_jobs(keys: list[tuple], processes: int) -> dict[str, bytes]:
    out: dict[str, bytes] = {}
    if processes > 1 and len(keys) > 1:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(max_workers=min(processes, len(keys)), mp_context=multiprocessing.get_context("fork")) as pool:
            for part in pool.map(_job, keys):
                out.update(part)
    else:
        for key in keys:
            out.update(_job(key))
    return out


def render_files(result: Result, timer: _Timer | None = None) -> dict[str, bytes]:
    """Every output file except plan.json, as ``name -> bytes``, in a deterministic order.

    Drawing counts as the paper's slicing-and-drawing time (``slice_draw``); building the 3D
    models, CAD files and the report as ``write``. Both run as independent jobs spread over
    ``RenderParams.processes`` forked worker processes.
    """
    from contextlib import nullcontext

    stage = timer.stage if timer else (lambda name: nullcontext())
    o, mesh, params = result.orientation, result.mesh, result.options.render
    stories = [sp.story.index for sp in result.stories]
    _JOBS.clear()
    _JOBS["result"] = result
    _JOBS["sheets"] = {i: make_sheet(mesh.face_centroids[o.face_story == i][:, [0, 2]], params) for i in stories}
    _JOBS["symbols"] = {
        i: plan_symbols(i, result.walls, result.openings, result.rooms, result.physical_walls, params.imperial) for i in stories
    }
    processes = _processes(params)
    files: dict[str, bytes] = {}
    try:
        with stage("slice_draw"):
            # the ink raster is shared by the three formats of the pen-and-ink plan
            _JOBS["ink"] = {i: pen_and_ink_raster(result.stories[i].pen_and_ink, _JOBS["sheets"][i], params) for i in stories}
            # one job per format, the slowest first, so that the workers finish together
            keys = [("pen", i, fmt) for i in stories for fmt in ("pdf", "png", "svg")]
            keys += [("drafting", i, "png", "svg", "pdf") for i in stories] + [("segments", i) for i in stories]
            files.update(_run_jobs(keys + [("normals",), ("levels",)], processes))
        with stage("write"):
            keys = [("dxf", i) for i in stories] + [("models", i) for i in stories] + [("oriented",)]
            if result.options.export.ifc:
                keys.insert(0, ("ifc",))
            files.update(_run_jobs(keys, processes))
            # last: the report inlines the other files
            files["report.html"] = report_html(result, files).encode("utf-8")
    finally:
        _JOBS.clear()
    return dict(sorted(files.items()))


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

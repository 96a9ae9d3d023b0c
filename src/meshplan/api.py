"""The whole job, from a scan on disk to plans: :func:`run` (also exposed as ``meshplan.run``).

Read the scan, compute every stage (:func:`meshplan.pipeline.compute`) while the drawing workers
get ready (:class:`meshplan.export.RenderPool`) and draw what the orientation alone decides,
then draw and write every file at once, atomically (:func:`meshplan.export.write_results`: a
failure leaves nothing behind). The command line is a thin layer over :func:`run`; this module sits above everything it uses.
"""

from __future__ import annotations

import logging
import os
import time
from contextlib import nullcontext
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .export import RenderPool, _processes, submit_early, submit_upright, submit_walls, write_results
from .geometry import Annotations, Mesh
from .io import check_output_dir, load_annotations, load_mesh
from .options import RunOptions
from .pipeline import compute
from .plan.elements import load_room_edits
from .result import Oriented, Progress, Result, _Timer

if TYPE_CHECKING:  # pragma: no cover
    from .orient import Orientation
    from .walls import FlatWalls

log = logging.getLogger(__name__)

__all__ = ["default_output_dir", "run"]


def default_output_dir(scan: str | os.PathLike) -> Path:
    """``./meshplan-out/<scan name>``."""
    return Path("meshplan-out") / Path(scan).stem


def run(
    scan: str | os.PathLike,
    *,
    annotations: str | os.PathLike | None = None,
    rooms: str | os.PathLike | None = None,
    output: str | os.PathLike | None = None,
    force: bool = False,
    progress: Progress | None = None,
    options: RunOptions | None = None,
    **params: Any,
) -> Result:
    """Turn a scanned mesh into an oriented model and floor plans.

    Parameters
    ----------
    scan
        OBJ, PLY, GLB/glTF, STL or OFF file.
    annotations
        Optional annotation file (JSON, input coordinates).
    rooms
        Optional rooms.json (or a previous plan.json; plan frame): the numbers, names and types
        of the rooms it matches by position (:func:`meshplan.plan.elements.load_room_edits`).
    output
        Directory to write the results to; nothing is written when ``None``. It must not exist
        unless ``force``.
    force
        Replace an existing output directory (atomically).
    progress
        Called with ``(stage, "start" | "done")``; a stage may run in several parts
        (``slice_draw``: the slices computed, then the plans drawn).
    options
        All parameters at once; or give them as keywords (``units="cm"``, ``up="+z"``,
        ``slices=50``, ... the same names as the command-line options).

    Returns
    -------
    Result

    Raises
    ------
    MeshplanError
        For any problem with the input or the options, with a one-line explanation.

    Examples
    --------
    >>> import meshplan
    >>> result = meshplan.run("scan.obj", output="out", units="cm")  # doctest: +SKIP
    >>> [s.floor for s in result.orientation.stories]  # doctest: +SKIP
    [0.0]
    """
    if options is None:
        options = RunOptions.from_kwargs(**params)
    elif params:
        raise TypeError("give either options or keyword parameters, not both")
    if output is not None:
        # the scan and the annotations must survive a --force that names their directory
        check_output_dir(output, force, protect=(scan, annotations, rooms))
    edits = load_room_edits(rooms) if rooms is not None else ()  # refused before any work
    timer = _Timer(progress)
    t0 = time.perf_counter()
    # the drawing workers start now and get ready while the stages compute
    with RenderPool(_processes(options.render)) if output is not None else nullcontext() as pool:
        with timer.stage("load"):
            # with keyword parameters, an absent --units comes as None (dropped by from_kwargs)
            explicit = params.get("units") is not None if "units" in params else None
            loaded = load_mesh(scan, options.input.units, options.input.max_faces, point_voxel_m=options.input.point_voxel_m, units_explicit=explicit)
            ann = load_annotations(annotations, loaded.stats.scale_to_m) if annotations is not None else Annotations()
        # the drawings handed to the workers (if any): those of the orientation alone as soon as
        # the scan is oriented (drawn while the pen-and-ink slices are cut), then the pen-and-ink
        # plans, then the wall segments once the walls are final (drawn while the rooms are
        # found): the worker is left no idle time before the drafting plans, the last drawing
        handed: dict[str, Any] = {}  # "early": the EarlyDrawings so far; "oriented"

        def draw_upright(orientation: Orientation, mesh: Mesh) -> None:
            handed["early"] = submit_upright(pool, orientation, mesh, options.render)

        def draw_early(oriented: Oriented) -> None:
            handed["oriented"] = oriented
            handed["early"] = submit_early(pool, oriented, handed.get("early"))

        def draw_walls(walls: FlatWalls) -> None:
            if "oriented" in handed:
                handed["early"] = submit_walls(pool, handed["oriented"], walls, handed["early"])

        result = compute(
            loaded.mesh, loaded.stats, ann, options, timer, units_explicit=explicit, room_edits=edits,
            on_oriented=draw_early, on_upright=draw_upright, on_walls=draw_walls,
        )
        if loaded.warnings:  # the reader's (float32 precision) first, before the stages'
            result = replace(result, warnings=(*loaded.warnings, *result.warnings))
        if output is None:
            return replace(result, timings={**timer.timings, "total": time.perf_counter() - t0})
        written = write_results(result, Path(output), force=force, timer=timer, started=t0, pool=pool, early=handed.get("early"))
    return replace(result, output_dir=written.output_dir, files=written.files, timings=written.timings)

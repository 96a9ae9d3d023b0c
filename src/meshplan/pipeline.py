"""The whole job, from a scan on disk to plans: :func:`run` (also exposed as ``meshplan.run``).

The command line is a thin layer over :func:`run`. Stages only compute; files are written at the
very end, all at once, through :mod:`meshplan.export` (a failure leaves nothing behind).
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from .errors import GeometryError, MeshplanError
from .geometry import Annotations, Mesh
from .io import LoadStats, load_annotations, load_mesh
from .options import RunOptions
from .orient import Orientation, Story, assign_faces, orient
from .plan import DraftingPlan, Openings, PenAndInkPlan, Room, drafting, find_openings, find_rooms, pen_and_ink
from .walls import FlatWalls, PhysicalWall, find_flat_walls, physical_walls

log = logging.getLogger("meshplan")

#: Stages reported to progress callbacks, in order.
STAGES = ("load", "orient", "walls", "rooms", "slice_draw", "write")

#: The paper's Table 1 timings (seconds) for its residential building B2 (285,840 faces).
PAPER_TIMINGS_S = {"orient": 24.08, "walls": 81.5, "slice_draw": 0.9}
PAPER_FACES = 285_840

Progress = Callable[[str, str], None]  # (stage, "start" | "done")


@dataclass(frozen=True, eq=False)
class StoryPlans:
    """Everything drawn for one story."""

    story: Story
    pen_and_ink: PenAndInkPlan
    drafting: DraftingPlan
    annotations: Annotations  # the annotations on this story (plan frame)


@dataclass(eq=False)
class Result:
    """What :func:`run` found and made.

    Attributes
    ----------
    input
        What was read from the scan and what was dropped.
    options
        Every parameter used.
    orientation
        Transform, levels, wall directions and stories.
    mesh
        The scan in the plan frame, normals facing into the rooms.
    annotations
        The annotations in the plan frame.
    walls
        The flat walls of every story.
    rooms, openings
        Rooms of every story; doors and windows in the walls.
    physical_walls
        The wall faces paired into walls with a thickness.
    stories
        The plans of each story.
    timings
        Seconds per stage, with ``total``.
    output_dir
        Where the files were written (``None`` when nothing was written).
    files
        Names of the files written, in order.
    warnings
        Things the user should know.
    """

    input: LoadStats
    options: RunOptions
    orientation: Orientation
    mesh: Mesh
    annotations: Annotations
    walls: FlatWalls
    rooms: tuple[Room, ...]
    openings: Openings
    physical_walls: tuple[PhysicalWall, ...]
    stories: tuple[StoryPlans, ...]
    timings: dict[str, float] = field(default_factory=dict)
    output_dir: Path | None = None
    files: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()
    annotation_story: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    @property
    def transform(self) -> np.ndarray:
        """4x4 rigid transform from input coordinates to the plan frame."""
        return self.orientation.transform

    def summary(self) -> dict[str, Any]:
        """A short JSON-ready summary (what ``meshplan run --json`` prints)."""
        return {
            "scan": self.input.path,
            "output": str(self.output_dir) if self.output_dir else None,
            "faces": self.input.faces,
            "stories": [s.story.to_dict(3) for s in self.stories],
            "walls": len(self.walls),
            "rooms": [{"label": r.label, "story": r.story, "area": round(r.area, 2)} for r in self.rooms],
            "doors": sum(k == "door" for k in self.openings.kind),
            "windows": sum(k == "window" for k in self.openings.kind),
            "annotations": len(self.annotations),
            "warnings": list(self.warnings),
            "timings": {k: round(v, 4) for k, v in self.timings.items()},
        }


#: Share of the area-weighted normals along one direction above which a scan holds no room.
FLAT_SHARE = 0.98


def check_not_flat(mesh: Mesh) -> None:
    """Refuse a scan whose faces are all parallel: one wall, or floors and ceilings alone.

    Such a scan holds no room; orienting it would take the one surface for the floor and
    report, misleadingly, that there are no walls.

    Raises
    ------
    GeometryError
        When at least :data:`FLAT_SHARE` of the area faces one way (either sign).
    """
    areas, normals = mesh.face_areas, mesh.face_normals
    total = float(areas.sum())
    if not (np.isfinite(total) and total > 0):
        return
    tensor = np.einsum("i,ij,ik->jk", areas, normals, normals) / total
    if np.all(np.isfinite(tensor)) and np.linalg.eigvalsh(tensor)[-1] >= FLAT_SHARE:
        raise GeometryError(
            f"the scan holds no room: all its {mesh.n_faces:,} faces are parallel "
            "(a single wall or floor, or floors and ceilings without walls)",
            "scan the whole room, with its floor and its walls",
        )


class _Timer:
    def __init__(self, progress: Progress | None) -> None:
        self.timings: dict[str, float] = {}
        self.progress = progress

    @contextmanager
    def stage(self, name: str):
        if self.progress:
            self.progress(name, "start")
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self.timings[name] = self.timings.get(name, 0.0) + time.perf_counter() - t0
        log.debug("stage %s: %.3f s", name, self.timings[name])
        if self.progress:
            self.progress(name, "done")


#: Below this evidence (a log-ratio, see :func:`meshplan.orient.gravity.sign_evidence`) the
#: scan shows too little furniture to tell up from down (furnished synthetic scans give 1.2 and
#: more, real scans 0.3-2.3, empty buildings near 0, or below it from their door heads), and the
#: doors decide.
WEAK_SIGN_EVIDENCE = 1.0


def _up_in_doubt(orientation: Orientation, options: RunOptions) -> bool:
    g = orientation.gravity
    return options.orient.up == "auto" and g.method == "kmeans" and abs(g.sign_evidence) < WEAK_SIGN_EVIDENCE


def _up_by_doors(mesh: Mesh, orientation: Orientation, plan_mesh: Mesh, options: RunOptions):
    """Doors reach down to the floor: the way up that shows clearly more doors is up.

    Upside down, a door is a gap hanging from the ceiling, which no door detector takes for a
    door; every room has one, furnished or not. Returns the orientation and plan mesh kept and
    their walls and openings (computed here, so that they are not computed again).
    """
    def doors(o: Orientation, m: Mesh):
        walls = find_flat_walls(m, o, options.walls)
        openings = find_openings(m, o, walls, options.plan)
        return sum(k == "door" for k in openings.kind), (walls, openings)

    n_here, found = doors(orientation, plan_mesh)
    try:
        other = orient(mesh, options.orient, up_hint=-orientation.gravity.up)
    except MeshplanError:  # upside down there is no floor at all
        return orientation, plan_mesh, found
    other_mesh = mesh.transformed(other.transform).with_flipped(other.flipped)
    n_other, other_found = doors(other, other_mesh)
    log.debug("up in doubt (sign evidence %.2f): %d doors this way up, %d the other", orientation.gravity.sign_evidence, n_here, n_other)
    by_doors = lambda o: replace(o, gravity=replace(o.gravity, sign_by="doors"))  # noqa: E731
    if n_other > 2 * n_here:
        return by_doors(other), other_mesh, other_found
    if n_here > 2 * n_other:
        return by_doors(orientation), plan_mesh, found
    return orientation, plan_mesh, found


def compute(
    mesh: Mesh,
    stats: LoadStats,
    annotations: Annotations,
    options: RunOptions,
    timer: _Timer | None = None,
    units_explicit: bool | None = None,
) -> Result:
    """Run every computing stage on an already loaded mesh (input coordinates, metres).

    ``units_explicit`` says whether the user named the scan's units (``--units``); ``None``
    takes any unit but the default ``m`` as named. Units, up axis and the building itself are
    checked against the geometry (:func:`meshplan.plausibility.orient_plausibly`).
    """
    from .plausibility import orient_plausibly

    timer = timer or _Timer(None)
    if units_explicit is None:
        units_explicit = options.input.units != "m"
    with timer.stage("orient"):
        check_not_flat(mesh)
        orientation, plausibility_warnings = orient_plausibly(mesh, options.input.units, options.orient, units_explicit)
        plan_mesh = mesh.transformed(orientation.transform).with_flipped(orientation.flipped)
        found = None
        if _up_in_doubt(orientation, options):
            orientation, plan_mesh, found = _up_by_doors(mesh, orientation, plan_mesh, options)
        plan_annotations = annotations.transformed(orientation.transform)
    with timer.stage("walls"):
        walls = found[0] if found else find_flat_walls(plan_mesh, orientation, options.walls)
    with timer.stage("rooms"):
        openings = found[1] if found else find_openings(plan_mesh, orientation, walls, options.plan)
        rooms = find_rooms(plan_mesh, orientation, walls, options.plan, options.orient.slab_tolerance_m)
        physical = physical_walls(walls, options.walls.max_wall_thickness_m, options.walls.default_wall_thickness_m)
    with timer.stage("slice_draw"):
        ann_story = assign_faces(plan_annotations.positions[:, 1], orientation.stories) if len(plan_annotations) else np.zeros(0, np.int64)
        plans = []
        for story in orientation.stories:
            sel = np.flatnonzero(ann_story == story.index)
            story_ann = Annotations(
                tuple(plan_annotations.labels[i] for i in sel),
                tuple(plan_annotations.kinds[i] for i in sel),
                plan_annotations.positions[sel],
                plan_annotations.directions[sel],
            )
            plans.append(
                StoryPlans(
                    story=story,
                    pen_and_ink=pen_and_ink(plan_mesh, orientation, story, options.plan, options.orient.slab_tolerance_m),
                    drafting=drafting(walls, story, options.plan, openings.holes()),
                    annotations=story_ann,
                )
            )
    warnings = list(orientation.warnings) + list(plausibility_warnings)
    for s in orientation.stories:
        if not np.any(walls.story == s.index):
            warnings.append(f"story {s.index}: no flat wall found (the drafting plan is empty)")
    return Result(
        input=stats,
        options=options,
        orientation=orientation,
        mesh=plan_mesh,
        annotations=plan_annotations,
        walls=walls,
        rooms=rooms,
        openings=openings,
        physical_walls=physical,
        stories=tuple(plans),
        timings=timer.timings,
        warnings=tuple(warnings),
        annotation_story=ann_story,
    )


def default_output_dir(scan: str | os.PathLike) -> Path:
    """``./meshplan-out/<scan name>``."""
    return Path("meshplan-out") / Path(scan).stem


def run(
    scan: str | os.PathLike,
    *,
    annotations: str | os.PathLike | None = None,
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
    output
        Directory to write the results to; nothing is written when ``None``. It must not exist
        unless ``force``.
    force
        Replace an existing output directory (atomically).
    progress
        Called with ``(stage, "start" | "done")``.
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
    from contextlib import nullcontext

    from .export import RenderPool, _processes, write_results
    from .io import check_output_dir

    if options is None:
        options = RunOptions.from_kwargs(**params)
    elif params:
        raise TypeError("give either options or keyword parameters, not both")
    if output is not None:
        # the scan and the annotations must survive a --force that names their directory
        check_output_dir(output, force, protect=(scan, annotations))
    timer = _Timer(progress)
    t0 = time.perf_counter()
    # the drawing workers start now and get ready while the stages compute
    with RenderPool(_processes(options.render)) if output is not None else nullcontext() as pool:
        with timer.stage("load"):
            loaded = load_mesh(scan, options.input.units, options.input.max_faces)
            ann = load_annotations(annotations, loaded.stats.scale_to_m) if annotations is not None else Annotations()
        # with keyword parameters, an absent --units comes as None (dropped by from_kwargs)
        explicit = params.get("units") is not None if "units" in params else None
        result = compute(loaded.mesh, loaded.stats, ann, options, timer, units_explicit=explicit)
        if loaded.warnings:  # the reader's (float32 precision) first, before the stages'
            result.warnings = tuple(loaded.warnings) + tuple(result.warnings)
        if output is not None:
            write_results(result, Path(output), force=force, timer=timer, started=t0, pool=pool)
        else:
            result.timings["total"] = time.perf_counter() - t0
    return result

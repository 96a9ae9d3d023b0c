"""The computing stages, from a loaded scan to a :class:`~meshplan.result.Result`: :func:`compute`.

Stages only compute; reading the scan, drawing and writing the files are the run API's
(:func:`meshplan.api.run`, also ``meshplan.run``), which calls :func:`compute` in between.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from .errors import GeometryError
from .geometry import BLOCK_ROWS, Annotations, Mesh, few_blas_threads
from .io import LoadStats
from .options import RunOptions
from .orient import assign_faces
from .orient.stories import without_ceiling
from .plan import drafting, find_openings, find_rooms, find_stairs, pen_and_ink
from .plan.elements import ModelName, RoomEdit, mark_low_confidence, name_rooms, opening_elements, reveal_thickness, section_names, type_rooms, wall_elements
from .plan.openings import door_leaves
from .plan.parametric import apply_parametric
from .plan.stairs import attach_rooms, turned_pieces
from .plan.symbols import plan_symbols
from .plan.voids import double_height_voids
from .result import PAPER_FACES, PAPER_TIMINGS_S, STAGES, Oriented, Progress, Result, StoryPlans, _read_only, _Timer
from .slicing import slice_mesh
from .updown import WEAK_SIGN_EVIDENCE, settle_up
from .updown import up_by_doors as _up_by_doors
from .updown import up_in_doubt as _up_in_doubt
from .walls import find_flat_walls, physical_walls
from .walls.physical import JOIN_REACH_M, join_walls

if TYPE_CHECKING:  # pragma: no cover
    from .orient import Orientation
    from .walls import FlatWalls

log = logging.getLogger(__name__)

# re-exported: these lived here before meshplan.result and meshplan.updown
__all__ = [
    "FLAT_SHARE",
    "PAPER_FACES",
    "PAPER_TIMINGS_S",
    "STAGES",
    "WEAK_SIGN_EVIDENCE",
    "Progress",
    "Result",
    "StoryPlans",
    "_Timer",
    "_up_by_doors",
    "_up_in_doubt",
    "check_not_flat",
    "compute",
]


#: Share of the area-weighted normals along one direction above which a scan holds no room.
FLAT_SHARE = 0.98


def _model_names(stats: LoadStats, orientation) -> tuple[ModelName, ...]:
    """The room names a parametric model gives (RoomPlan's sections), in the plan frame."""
    p = stats.parametric
    if p is None or not len(p.section_label):
        return ()
    centers = np.asarray(p.section_center, dtype=np.float64) * stats.scale_to_m
    t = orientation.transform
    return section_names(p.section_label, centers @ t[:3, :3].T + t[:3, 3], orientation.stories)


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
    # thin products, a block of faces at a time (the three-operand einsum took 0.2 s at 3M
    # faces, one product of the whole 0.14 s, most of it the weighted normals' fresh 72 MB);
    # the sums' order only moves the last bits, and the test is a threshold
    tensor = np.zeros((3, 3))
    for i in range(0, len(areas), BLOCK_ROWS):
        n = normals[i : i + BLOCK_ROWS]
        tensor += (n * areas[i : i + BLOCK_ROWS, None]).T @ n
    tensor /= total
    if np.all(np.isfinite(tensor)) and np.linalg.eigvalsh(tensor)[-1] >= FLAT_SHARE:
        raise GeometryError(
            f"the scan holds no room: all its {mesh.n_faces:,} faces are parallel "
            "(a single wall or floor, or floors and ceilings without walls)",
            "scan the whole room, with its floor and its walls",
        )


def _oriented(stats: LoadStats, options: RunOptions, orientation, plan_mesh: Mesh, plan_annotations: Annotations) -> Oriented:
    """What the oriented scan alone decides: each story's pen-and-ink plan and annotations."""
    if len(plan_annotations):
        ann_story = assign_faces(plan_annotations.positions[:, 1], orientation.stories)
    else:
        ann_story = np.zeros(0, np.int64)
    pens, anns = [], []
    for story in orientation.stories:
        sel = np.flatnonzero(ann_story == story.index)
        anns.append(
            Annotations(
                tuple(plan_annotations.labels[i] for i in sel),
                tuple(plan_annotations.kinds[i] for i in sel),
                plan_annotations.positions[sel],
                plan_annotations.directions[sel],
            )
        )
        pens.append(pen_and_ink(plan_mesh, orientation, story, options.plan, options.orient.slab_tolerance_m))
    return Oriented(stats, options, orientation, plan_mesh, tuple(pens), tuple(anns), ann_story)


def compute(
    mesh: Mesh,
    stats: LoadStats,
    annotations: Annotations,
    options: RunOptions,
    timer: _Timer | None = None,
    units_explicit: bool | None = None,
    room_edits: tuple[RoomEdit, ...] = (),
    on_oriented: Callable[[Oriented], None] | None = None,
    on_upright: Callable[[Orientation, Mesh], None] | None = None,
    on_walls: Callable[[FlatWalls], None] | None = None,
) -> Result:
    """Run every computing stage on an already loaded mesh (input coordinates, metres).

    ``units_explicit`` says whether the user named the scan's units (``--units``); ``None``
    takes any unit but the default ``m`` as named. ``room_edits`` are the rooms of a rooms.json
    (``--rooms``, :func:`meshplan.plan.elements.load_room_edits`) whose numbers, names and types
    the matching rooms take. Units, up axis and the building itself are
    checked against the geometry (:func:`meshplan.plausibility.orient_plausibly`).
    ``on_oriented`` is called once the scan is oriented and its pen-and-ink plans are cut, with
    what the later stages do not change (:class:`~meshplan.result.Oriented`): the run API hands
    those drawings to its workers then, so that they are drawn while the walls and rooms are
    computed. ``on_upright`` is called before, as soon as the scan is oriented, with the
    orientation and the plan mesh (the run hands its workers the drawings of the orientation
    alone, the normals and levels, while the pen-and-ink slices are cut), and ``on_walls`` with
    the flat walls once they are final (the open doors' leaves taken out), before the rooms are
    found (the run has its workers draw the wall segments meanwhile).

    The stages run with :data:`meshplan.geometry.BLAS_THREADS` BLAS thread: their products are
    thin, and the drawing workers run beside them on the other cores.
    """
    with few_blas_threads():
        return _compute(mesh, stats, annotations, options, timer, units_explicit, room_edits, on_oriented, on_upright, on_walls)


def _compute(
    mesh: Mesh,
    stats: LoadStats,
    annotations: Annotations,
    options: RunOptions,
    timer: _Timer | None,
    units_explicit: bool | None,
    room_edits: tuple[RoomEdit, ...],
    on_oriented: Callable[[Oriented], None] | None,
    on_upright: Callable[[Orientation, Mesh], None] | None = None,
    on_walls: Callable[[FlatWalls], None] | None = None,
) -> Result:
    """:func:`compute` itself, under its BLAS thread limit."""
    from .plausibility import orient_plausibly

    timer = timer or _Timer(None)
    if units_explicit is None:
        units_explicit = options.input.units != "m"
    with timer.stage("orient"):
        check_not_flat(mesh)
        orientation, plausibility_warnings = orient_plausibly(
            mesh,
            options.input.units,
            options.orient,
            units_explicit,
            None if stats.declared_up is None else np.asarray(stats.declared_up),
            stats.declared_by,
        )
        upright = settle_up(mesh, orientation, options)  # the doors decide when furniture cannot
        orientation, plan_mesh = upright.orientation, upright.mesh
        plan_annotations = annotations.transformed(orientation.transform)
        # every stage from here works on the plan mesh: the input mesh's derived arrays
        # (corners, cross products, normals, centroids: 0.45 GB at 3M faces) would only add to
        # the run's peak, which the drawing stage reaches
        mesh.release_derived()
    with timer.stage("slice_draw"):  # its first part: what needs the orientation alone
        if on_upright is not None:
            on_upright(orientation, plan_mesh)
        oriented = _oriented(stats, options, orientation, plan_mesh, plan_annotations)
        if on_oriented is not None:
            on_oriented(oriented)
    with timer.stage("walls"):
        walls = upright.walls if upright.walls is not None else find_flat_walls(plan_mesh, orientation, options.walls)
    with timer.stage("rooms"):
        # the faces paired into walls first: an opening through a wall is found on both its faces
        # and reported once (with the user's wall thickness limits)
        physical = physical_walls(walls, options.walls.max_wall_thickness_m, options.walls.default_wall_thickness_m)
        if upright.openings is not None:
            openings = upright.openings
        else:
            openings = find_openings(plan_mesh, orientation, walls, options.plan, physical=physical)
        if stats.parametric is not None:  # a RoomPlan export: its own doors, windows, furniture
            p = apply_parametric(stats.parametric, stats.scale_to_m, plan_mesh, orientation, walls, physical, openings, options.walls)
            walls, physical, openings = p.walls, p.physical, p.openings
        # the leaves of open doors were found as short walls at an angle: they are no walls
        leaves = door_leaves(walls, openings, options.plan)
        if leaves.any():
            walls, renumbered = walls.without(leaves)
            openings = openings.reindexed(renumbered)
            physical = physical_walls(walls, options.walls.max_wall_thickness_m, options.walls.default_wall_thickness_m)
        if on_walls is not None:
            on_walls(walls)
        rooms = find_rooms(plan_mesh, orientation, walls, options.plan, options.orient.slab_tolerance_m)
        # building elements: walls meeting at their centre lines, rooms numbered and named,
        # what each wall and opening joins, types and confidences
        # a wall scanned from one side is as thick as the reveals of its openings show
        physical = reveal_thickness(physical, walls, openings, plan_mesh)
        physical = join_walls(physical, JOIN_REACH_M)
        rooms = name_rooms(rooms, room_edits, _model_names(stats, orientation))
        physical = wall_elements(physical, rooms, orientation.stories, options.walls.floor_reach_m, options.walls.ceiling_reach_m)
        elements = opening_elements(openings, walls, physical, rooms, orientation.stories, plan_mesh, options.plan)
        # stairs from the stepped horizontal surfaces; the rooms holding them are stairwells
        stairs = find_stairs(plan_mesh, orientation.stories, options.plan.drafting_height_m, options.orient.slab_tolerance_m)
        rooms = type_rooms(rooms, elements, openings.kind, stairs)
        stairs = attach_rooms(stairs, rooms)
        # the pieces of the mesh the winding repair turned over with a stair's upper flight,
        # turned back (for the models: everything that reads the winding has run)
        turned = turned_pieces(plan_mesh, stairs)
        if turned.any():
            plan_mesh = plan_mesh.with_flipped(turned)
        # the holes in the upper floors over spaces two stories high (a stair's is its own)
        voids = double_height_voids(plan_mesh, orientation, stairs, options.orient.slab_tolerance_m)
    with timer.stage("slice_draw"):
        plans = []
        heights, normal_y = plan_mesh.face_centroids[:, 1], plan_mesh.face_normals[:, 1]
        for story, pen, story_ann in zip(orientation.stories, oriented.pen_and_ink, oriented.story_annotations, strict=True):
            in_story = orientation.face_story == story.index
            story_faces = np.flatnonzero(in_story)
            cut = mark_low_confidence(drafting(walls, story, options.plan, openings.holes()), walls, physical, rooms, openings, elements)
            plans.append(
                StoryPlans(
                    story=story,
                    pen_and_ink=pen,
                    drafting=cut,
                    annotations=story_ann,
                    symbols=plan_symbols(story.index, walls, openings, rooms, physical, options.render.imperial, stairs=stairs, elements=elements, voids=voids),
                    reference=_read_only(slice_mesh(plan_mesh.triangles, np.array([cut.height]), story_faces).segments),
                    model_faces=_read_only(np.flatnonzero(in_story & without_ceiling(heights, normal_y, story, options.orient.slab_tolerance_m))),
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
        annotation_story=oriented.annotation_story,
        opening_elements=elements,
        stairs=stairs,
        voids=voids,
    )

"""What a run found and made (:class:`Result`), the names of its stages and the paper's figures.

A low module: the stages' records are only named here (for type checkers), so everything that
reads a result (export, the report, the terminal summary, the batch) imports it without
importing the stages, and the run API (:mod:`meshplan.api`) sits above all of them.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from .geometry import Annotations, Mesh
    from .io import LoadStats
    from .options import RunOptions
    from .orient import Orientation, Story
    from .plan import DraftingPlan, Openings, PenAndInkPlan, Room
    from .plan.elements import OpeningElement
    from .plan.stairs import StairElement
    from .plan.symbols import PlanSymbols
    from .plan.voids import Void
    from .walls import FlatWalls, PhysicalWall

#: The stage timings are logged on the package's logger ("DEBUG meshplan: stage orient: ..."
#: with ``-v``), the one line per stage users and tests look for.
_stage_log = logging.getLogger("meshplan")

#: Stages reported to progress callbacks, in order.
STAGES = ("load", "orient", "walls", "rooms", "slice_draw", "write")

#: The paper's Table 1 timings (seconds) for its residential building B2 (285,840 faces).
PAPER_TIMINGS_S = {"orient": 24.08, "walls": 81.5, "slice_draw": 0.9}
PAPER_FACES = 285_840

Progress = Callable[[str, str], None]  # (stage, "start" | "done")


@dataclass(frozen=True, eq=False)
class Oriented:
    """What the stages know once the scan is oriented, before its walls and rooms: enough for
    the drawings that need no more (each story's pen-and-ink plan, the normals and the levels),
    which the run has its workers draw while the later stages compute (see
    :func:`meshplan.pipeline.compute`'s ``on_oriented``).

    Attributes
    ----------
    input, options, orientation, mesh
        As in :class:`Result` (the same objects).
    pen_and_ink
        Each story's pen-and-ink plan, in story order.
    story_annotations
        The annotations on each story (plan frame), in story order.
    annotation_story
        The story index of each of the run's annotations (:attr:`Result.annotation_story`).
    """

    input: LoadStats
    options: RunOptions
    orientation: Orientation
    mesh: Mesh
    pen_and_ink: tuple[PenAndInkPlan, ...]
    story_annotations: tuple[Annotations, ...]
    annotation_story: np.ndarray


@dataclass(frozen=True, eq=False)
class StoryPlans:
    """Everything drawn for one story."""

    story: Story
    pen_and_ink: PenAndInkPlan
    drafting: DraftingPlan
    annotations: Annotations  # the annotations on this story (plan frame)
    #: what the drafting sheet draws besides the cut: wall solids, openings, room labels,
    #: dimension chains (:func:`meshplan.plan.symbols.plan_symbols`), in the plan stage so that
    #: every backend (PNG/SVG/PDF, DXF) draws the same model
    symbols: PlanSymbols
    #: the mesh cut at the drafting height, (n, 2, 3) plan-frame segments: the DXF's reference
    #: layer under the flat walls
    reference: np.ndarray
    #: indices of the story's faces a view from above shows (the ceiling and what lies above it
    #: removed, :func:`meshplan.orient.stories.without_ceiling`): the story's GLB and 3D view
    model_faces: np.ndarray


def _read_only(a: Any) -> np.ndarray:
    out = np.array(a, copy=True)
    out.flags.writeable = False
    return out


@dataclass(frozen=True, eq=False)
class Result:
    """What :func:`meshplan.run` found and made; immutable (a later step makes a new one with
    :func:`dataclasses.replace`).

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
        The wall faces paired into walls with a thickness, their centre lines joined at corners
        and T junctions, with the rooms on each side and a confidence.
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
    annotation_story
        The story of each annotation (read-only).
    opening_elements
        Per opening (row of ``openings``): its physical wall, clear sizes, the rooms it
        connects, its leaf and a confidence (:class:`meshplan.plan.elements.OpeningElement`).
    stairs
        The stairs found in the stepped horizontal surfaces, with the stories and rooms they
        connect and the void over each in the upper floor (:class:`meshplan.plan.stairs.StairElement`).
    voids
        The holes in the upper floors over double-height spaces (:class:`meshplan.plan.voids.Void`;
        a stair's own is its ``void``).
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
    opening_elements: tuple[OpeningElement, ...] = ()
    stairs: tuple[StairElement, ...] = ()
    voids: tuple[Void, ...] = ()

    def __post_init__(self) -> None:
        # a copy of each: the timer and the caller keep theirs
        object.__setattr__(self, "timings", dict(self.timings))
        object.__setattr__(self, "annotation_story", _read_only(self.annotation_story))
        object.__setattr__(self, "warnings", tuple(self.warnings))
        object.__setattr__(self, "files", tuple(self.files))

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
            "physical_walls": len(self.physical_walls),
            "rooms": [
                {"label": r.label, "story": r.story, "area": round(r.area, 2), **({"number": r.number, "type": r.type} if r.number else {})}
                for r in self.rooms
            ],
            # each opening once: the openings are one per physical opening (both faces merged)
            "doors": sum(k == "door" for k in self.openings.kind),
            "windows": sum(k == "window" for k in self.openings.kind),
            "annotations": len(self.annotations),
            "warnings": list(self.warnings),
            "timings": {k: round(v, 4) for k, v in self.timings.items()},
        }


class _Timer:
    """Seconds per stage (summed when a stage runs in several parts), reported to ``progress``
    as each part starts and ends."""

    def __init__(self, progress: Progress | None) -> None:
        self.timings: dict[str, float] = {}
        self.progress = progress

    @contextmanager
    def stage(self, name: str) -> Iterator[None]:
        if self.progress:
            self.progress(name, "start")
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self.timings[name] = self.timings.get(name, 0.0) + time.perf_counter() - t0
        _stage_log.debug("stage %s: %.3f s", name, self.timings[name])
        if self.progress:
            self.progress(name, "done")

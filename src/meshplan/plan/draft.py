"""The drafting floor plan: the flat-wall model sliced once (paper, Algorithm 3, line 14)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..orient import Story
from ..slicing import Slices, slice_mesh
from ..walls import FlatWalls
from .params import PlanParams


@dataclass(frozen=True, eq=False)
class DraftingPlan:
    """The flat walls of one story cut at one height."""

    story: Story
    height: float
    slices: Slices


def drafting(walls: FlatWalls, story: Story, params: PlanParams | None = None, holes: dict | None = None) -> DraftingPlan:
    """Cut the story's flat-wall rectangles, with the openings in ``holes`` cut out of them, at
    ``drafting_height_m`` above its floor (kept below the ceiling)."""
    params = params or PlanParams()
    above = params.drafting_height_m if params.drafting_height_m < story.height else 0.5 * story.height
    height = story.floor + above
    model = walls.mesh(story.index, holes)
    return DraftingPlan(story, float(height), slice_mesh(model.triangles, np.array([height])))

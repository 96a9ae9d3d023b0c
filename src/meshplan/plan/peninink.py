"""The pen-and-ink floor plan: a story sliced at many heights (paper, "Slicing the mesh to
produce a floor plan" and "Drawing the floor plan")."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import Mesh
from ..orient import Orientation, Story
from ..slicing import Slices, plane_heights, slice_mesh
from .params import PlanParams


@dataclass(frozen=True, eq=False)
class PenAndInkPlan:
    """All slices of one story, to be projected onto the floor and overlaid translucently."""

    story: Story
    slices: Slices


def pen_and_ink(mesh: Mesh, orientation: Orientation, story: Story, params: PlanParams | None = None) -> PenAndInkPlan:
    """Slice the story's part of ``mesh`` (plan frame) at ``params.slices + 1`` heights from its
    floor to its ceiling."""
    params = params or PlanParams()
    faces = np.flatnonzero(orientation.face_story == story.index)
    heights = plane_heights(story.floor, story.ceiling, params.slices)
    return PenAndInkPlan(story, slice_mesh(mesh.triangles[faces], heights))

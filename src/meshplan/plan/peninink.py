"""The pen-and-ink floor plan: a story sliced at many heights (paper, "Slicing the mesh to
produce a floor plan" and "Drawing the floor plan")."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import Mesh
from ..orient import Orientation, Story, slab_faces
from ..slicing import Slices, plane_heights, slice_mesh
from .params import PlanParams


@dataclass(frozen=True, eq=False)
class PenAndInkPlan:
    """All slices of one story, to be projected onto the floor and overlaid translucently."""

    story: Story
    slices: Slices


def pen_and_ink(
    mesh: Mesh, orientation: Orientation, story: Story, params: PlanParams | None = None, slab_tolerance_m: float = 0.1
) -> PenAndInkPlan:
    """Slice the story's part of ``mesh`` (plan frame), its floor and ceiling surfaces removed,
    at ``params.slices + 1`` heights from its floor to its ceiling.

    Without the removal, the planes at the floor and the ceiling would cut their scanning noise
    into contour lines all over the rooms.
    """
    params = params or PlanParams()
    slab = slab_faces(mesh.face_centroids[:, 1], mesh.face_normals[:, 1], (story,), slab_tolerance_m)
    faces = np.flatnonzero((orientation.face_story == story.index) & ~slab)
    heights = plane_heights(story.floor, story.ceiling, params.slices)
    return PenAndInkPlan(story, slice_mesh(mesh.triangles, heights, faces))

"""Mesh orientation (paper, "Mesh orientation"): gravity, floor and ceiling heights, wall
alignment and stories.

:func:`orient` finds the rigid transform from the input coordinates to the *plan frame*: +y up
(against gravity), the largest wall cluster facing +x (so the dominant walls run along x and z),
metres, with the origin on the lowest floor at the low-x, low-z corner of the scan (0.5 %
quantiles, so that stray triangles do not move it)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:  # pragma: no cover
    from .align import WallAlignment, WallDirection, align_walls
    from .facing import face_components, inward_flips
    from .gravity import GravityEstimate, estimate_gravity, refine_with_slabs
    from .levels import Levels, StoryLevels, find_levels
    from .orientation import Orientation, orient
    from .params import GRAVITY_METHODS, UP_CHOICES, OrientParams
    from .stories import Story, assign_faces, slab_faces, split_stories, without_ceiling

#: Where each public name lives (loaded when first used, :mod:`meshplan._lazy`).
_EXPORTS = {
    "GRAVITY_METHODS": "params",
    "GravityEstimate": "gravity",
    "Levels": "levels",
    "OrientParams": "params",
    "Orientation": "orientation",
    "Story": "stories",
    "StoryLevels": "levels",
    "UP_CHOICES": "params",
    "WallAlignment": "align",
    "WallDirection": "align",
    "align_walls": "align",
    "assign_faces": "stories",
    "estimate_gravity": "gravity",
    "face_components": "facing",
    "find_levels": "levels",
    "inward_flips": "facing",
    "orient": "orientation",
    "refine_with_slabs": "gravity",
    "slab_faces": "stories",
    "split_stories": "stories",
    "without_ceiling": "stories",
}

__all__ = [
    "GRAVITY_METHODS",
    "GravityEstimate",
    "Levels",
    "OrientParams",
    "Orientation",
    "Story",
    "StoryLevels",
    "UP_CHOICES",
    "WallAlignment",
    "WallDirection",
    "align_walls",
    "assign_faces",
    "estimate_gravity",
    "face_components",
    "find_levels",
    "inward_flips",
    "orient",
    "refine_with_slabs",
    "slab_faces",
    "split_stories",
    "without_ceiling",
]
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())

"""Stories: each floor-to-ceiling level of the building, and which faces belong to it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import FloatArray, IntArray
from .levels import Levels
from .params import SLAB_HORIZONTAL_DEG


@dataclass(frozen=True)
class Story:
    """One story of the building, heights in the plan frame (metres, +y up).

    A face belongs to the story when its centroid lies in ``[bottom, top)``: the boundaries are
    half-way through the slabs between stories, so a story keeps its floor and its ceiling.
    """

    index: int
    floor: float
    ceiling: float
    ceiling_found: bool
    bottom: float
    top: float

    @property
    def height(self) -> float:
        """Floor-to-ceiling height."""
        return self.ceiling - self.floor

    def to_dict(self, ndigits: int = 6) -> dict:
        return {
            "index": self.index,
            "floor": round(self.floor, ndigits),
            "ceiling": round(self.ceiling, ndigits),
            "height": round(self.height, ndigits),
            "ceiling_found": self.ceiling_found,
        }


def split_stories(levels: Levels) -> tuple[Story, ...]:
    """Stories from the levels, with the slab mid-planes as their boundaries."""
    out = []
    sl = levels.stories
    for i, s in enumerate(sl):
        bottom = -np.inf if i == 0 else 0.5 * (sl[i - 1].ceiling + s.floor)
        top = np.inf if i == len(sl) - 1 else 0.5 * (s.ceiling + sl[i + 1].floor)
        out.append(Story(i, s.floor, s.ceiling, s.ceiling_found, float(bottom), float(top)))
    return tuple(out)


def assign_faces(heights: FloatArray, stories: tuple[Story, ...]) -> IntArray:
    """The story index of each face, from its centroid height."""
    bounds = np.array([s.top for s in stories[:-1]])
    return np.searchsorted(bounds, heights, side="right").astype(np.int64)


def slab_faces(
    heights: FloatArray,
    normal_y: FloatArray,
    stories: tuple[Story, ...],
    tolerance_m: float,
    floors: bool = True,
    ceilings: bool = True,
) -> np.ndarray:
    """Faces that are floor or ceiling surfaces: within 30 degrees of horizontal and within
    ``tolerance_m`` of a story's floor or ceiling height (the paper's
    ``RemoveCeilingsAndFloors``)."""
    # the heights of the horizontal faces alone are tested (a pass over every face each
    # otherwise: 0.1 s of the pen-and-ink plan at 3M faces)
    flat = np.flatnonzero(np.abs(normal_y) >= np.cos(np.radians(SLAB_HORIZONTAL_DEG)))
    h = heights[flat]
    near = np.zeros(len(flat), dtype=bool)
    for s in stories:
        if floors:
            near |= np.abs(h - s.floor) < tolerance_m
        if ceilings and s.ceiling_found:
            near |= np.abs(h - s.ceiling) < tolerance_m
    out = np.zeros(len(heights), dtype=bool)
    out[flat[near]] = True
    return out


def without_ceiling(heights: FloatArray, normal_y: FloatArray, story: Story, tolerance_m: float) -> np.ndarray:
    """Faces of a story that stay when its ceiling is removed, so that a view from above shows
    the rooms: everything but the ceiling surface and what lies above it."""
    ceiling = slab_faces(heights, normal_y, (story,), tolerance_m, floors=False)
    return ~ceiling & (heights < story.ceiling + tolerance_m)

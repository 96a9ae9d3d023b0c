"""Stories: each floor-to-ceiling level of the building, and which faces belong to it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import FloatArray, IntArray
from .levels import Levels


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


def below_ceiling(heights: FloatArray, story: Story, clearance_m: float) -> np.ndarray:
    """Faces of a story that stay when its ceiling is removed (a view from above shows the rooms)."""
    return heights < story.ceiling - clearance_m

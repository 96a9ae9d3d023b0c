"""Flat walls: wall directions, the box-shaped DBSCAN and the wall rectangles (paper,
"Computing flat walls")."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:  # pragma: no cover
    from .boxdbscan import BoxDBSCAN, box_dbscan
    from .flat import FlatWalls, find_flat_walls, wall_directions
    from .params import WallParams
    from .physical import PhysicalWall, physical_walls, wall_of_face

#: Where each public name lives (loaded when first used, :mod:`meshplan._lazy`).
_EXPORTS = {
    "BoxDBSCAN": "boxdbscan",
    "FlatWalls": "flat",
    "PhysicalWall": "physical",
    "WallParams": "params",
    "box_dbscan": "boxdbscan",
    "find_flat_walls": "flat",
    "physical_walls": "physical",
    "wall_directions": "flat",
    "wall_of_face": "physical",
}

__all__ = [
    "BoxDBSCAN",
    "FlatWalls",
    "PhysicalWall",
    "WallParams",
    "box_dbscan",
    "find_flat_walls",
    "physical_walls",
    "wall_directions",
    "wall_of_face",
]
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())

"""Flat walls: wall directions, the box-shaped DBSCAN and the wall rectangles (paper,
"Computing flat walls")."""

from .boxdbscan import BoxDBSCAN, box_dbscan
from .flat import FlatWalls, find_flat_walls, wall_directions
from .params import WallParams
from .physical import PhysicalWall, physical_walls, wall_of_face

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

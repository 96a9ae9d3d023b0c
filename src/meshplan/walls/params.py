"""Parameters of the flat-wall stage (paper, "Computing flat walls"), with the paper's values."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from ..errors import ParameterError
from ..geometry import check_positive

FOOT_M = 0.3048
INCH_M = 0.0254

#: Which wall directions the DBSCAN runs on.
DIRECTION_MODES = ("auto", "principal", "all")


@dataclass(frozen=True)
class WallParams:
    """How flat walls are found.

    Attributes
    ----------
    box_length_m
        Length of the DBSCAN box along the wall: "a little less wide than a door, e.g.
        1.5 feet". Two pieces of wall farther apart than half of it are not neighbours.
    box_depth_m
        Depth of the box across the wall: "a few inches", to allow for walls that are not
        perfectly flat; it must stay below the thickness of a partition, or the two faces of
        a partition become one.
    box_height_m
        Height of the box; ``None`` uses each story's floor-to-ceiling height ("tall enough to
        reach from floor to ceiling").
    min_points
        DBSCAN's minimum number of triangle centroids in a box (the point itself included)
        for a core point.
    facing_tolerance_deg
        A triangle faces a wall direction when its normal is within this angle of it.
    wall_directions
        ``principal``: the four right-angle directions of the dominant walls (the paper's
        k = 4). ``all``: every direction the trimmed spherical k-means found. ``auto``
        (default): ``all`` when a non-principal direction was found, else ``principal``.
    min_wall_length_m
        Segments shorter than this along the wall are discarded ("too small").
    floor_reach_m, ceiling_reach_m
        A segment is kept only when it comes within this distance of the floor and of the
        ceiling ("walls ... near the floor ... near the ceiling"). Furniture rarely stands
        higher than 2 m and ceilings are at least 2.4 m high, so 0.3 m below the ceiling
        separates wardrobes from walls; the floor allowance is larger because furniture along
        a wall hides its foot.
    merge_gap_m
        Coplanar segments of one direction whose ends are closer than this along the wall are
        one wall (an opening up to a wide door does not split a wall).
    max_wall_thickness_m
        Two opposite faces closer than this are the two sides of one wall (building code:
        8 inches).
    default_wall_thickness_m
        Thickness given to walls scanned from one side only.
    """

    box_length_m: float = 1.5 * FOOT_M
    box_depth_m: float = 4 * INCH_M
    box_height_m: float | None = None
    min_points: int = 10
    facing_tolerance_deg: float = 25.0
    wall_directions: str = "auto"
    min_wall_length_m: float = 0.4
    floor_reach_m: float = 0.5
    ceiling_reach_m: float = 0.3
    merge_gap_m: float = 1.5
    max_wall_thickness_m: float = 8 * INCH_M
    default_wall_thickness_m: float = 0.15

    def __post_init__(self) -> None:
        for name in ("box_length_m", "box_depth_m", "facing_tolerance_deg", "max_wall_thickness_m", "default_wall_thickness_m"):
            check_positive(name, getattr(self, name))
        for name in ("min_wall_length_m", "floor_reach_m", "ceiling_reach_m", "merge_gap_m"):
            check_positive(name, getattr(self, name), allow_zero=True)
        if self.box_height_m is not None:
            check_positive("box_height_m", self.box_height_m)
        if not isinstance(self.min_points, int) or self.min_points < 1:
            raise ParameterError(f"min_points must be a positive integer, got {self.min_points!r}", "pass --min-points N")
        if self.wall_directions not in DIRECTION_MODES:
            raise ParameterError(
                f"unknown wall direction mode {self.wall_directions!r}", f"use one of {', '.join(DIRECTION_MODES)}"
            )
        if self.facing_tolerance_deg >= 90:
            raise ParameterError("facing_tolerance_deg must be below 90", "use e.g. 25")

    def to_dict(self) -> dict:
        return asdict(self)

"""Parameters of the flat-wall stage (paper, "Computing flat walls"), with the paper's values."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import ClassVar

from ..units import FOOT_M, INCH_M
from ..validation import (
    MAX_LENGTH_M,
    Constraint,
    Integer,
    Optional,
    Options,
    Real,
    validated,
)

#: Which wall directions the DBSCAN runs on.
DIRECTION_MODES = ("auto", "principal", "all")

#: Smallest side of the DBSCAN box in metres: below a millimetre (finer than any scanner) no two
#: centroids are neighbours, and the grid of boxes the search hashes into would overflow.
MIN_BOX_M = 0.001

#: Longest box along the wall (and height), in metres: the paper's box is 0.46 m; beyond 10 m a
#: box holds whole walls, and DBSCAN's neighbour lists grow with its volume (towards every pair of
#: faces of a wall, quadratic time and memory).
MAX_BOX_LENGTH_M = 10.0

#: Deepest box across the wall, in metres: deeper than a metre a box joins the two faces of any
#: wall and the walls of a corridor.
MAX_BOX_DEPTH_M = 1.0

#: Largest ``min_points``: a core point needs this many centroids in its box; beyond 10^6 none
#: of any scan qualifies.
MAX_MIN_POINTS = 1_000_000

_LENGTH = Real(0.0, MAX_LENGTH_M, closed="right", why="lengths beyond 1 km are a unit mistake")
_GAP = Real(0.0, MAX_LENGTH_M, why="lengths beyond 1 km are a unit mistake")
_BOX_WHY = "finer than 1 mm finds no neighbours; larger boxes make DBSCAN quadratic"


@validated
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
    max_work_surface_m
        Highest work surface above the floor (bar counters, high desks: 1.1-1.2 m; kitchen
        counters 0.9 m, desks 0.75 m, beds and seats 0.4-0.6 m). A wall rises above it wherever
        it is kept, even where the story has no scanned ceiling and its walls end where the
        scan ends.
    context_m
        How far in front of and behind a wall the scan is searched for what the wall's top must
        reach (the ceiling near it, or, without one, the top of what was scanned around it) and
        for surfaces behind it (the wall behind a counter, a desk or a wardrobe): deeper than
        kitchen counters (0.6 m) and desks (0.8 m), shallower than a room.
    snap_deg
        A wall piece whose own fitted direction is within this angle of its cluster's is drawn
        along the cluster. Walls built square are square to a fraction of a degree, and the
        direction of a few metres of scanned wall is uncertain by about as much; beyond it the
        difference is real (a wall built at an angle, or the drift of a headset bending the
        scan by 3-8 degrees), and the wall is drawn at its own angle, so that it stays on the
        mesh along its whole length.
    free_standing_m
        Largest extent of a free-standing object taken for walls: a piece of wall that, with
        the walls it connects to, spans no more than this and has the floor scanned right
        behind it is a panel, a pillar or a screen (0.3-1 m), not a wall. A room's walls span
        more; a short return or a door jamb's stub connects to them. It is also the longest
        piece of a group connected to no longer wall that is taken for a column (the ceiling
        scanned all round it) or a fragment (its top lost below door height), and the longest
        front standing out of a wall that is taken for a pilaster (``walls.flat``).
    """

    _parameter_constraints: ClassVar[dict[str, Constraint]] = {
        "box_length_m": Real(MIN_BOX_M, MAX_BOX_LENGTH_M, why=_BOX_WHY),
        "box_depth_m": Real(MIN_BOX_M, MAX_BOX_DEPTH_M, why=_BOX_WHY),
        "box_height_m": Optional(Real(MIN_BOX_M, MAX_LENGTH_M, why="finer than 1 mm finds no neighbours")),
        "min_points": Integer(1, MAX_MIN_POINTS),
        "facing_tolerance_deg": Real(0.0, 90.0, closed="neither", why="an angle from the wall direction"),
        "wall_directions": Options(DIRECTION_MODES),
        "min_wall_length_m": _GAP,
        "floor_reach_m": _GAP,
        "ceiling_reach_m": _GAP,
        "merge_gap_m": _GAP,
        "max_wall_thickness_m": _LENGTH,
        "default_wall_thickness_m": _LENGTH,
        "max_work_surface_m": _GAP,
        "context_m": _GAP,
        "snap_deg": Real(0.0, 45.0, why="an angle between two directions of walls; 45 degrees snaps every wall to the nearest cluster"),
        "free_standing_m": _GAP,
    }

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
    max_work_surface_m: float = 1.2
    context_m: float = 1.0
    snap_deg: float = 1.0
    free_standing_m: float = 1.2

    def to_dict(self) -> dict:
        return asdict(self)

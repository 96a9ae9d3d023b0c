"""Parameters of the floor plans (paper, "Floor plan computation"), with the paper's values."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import ClassVar

from ..validation import MAX_LENGTH_M, Constraint, Integer, Numbers, Real, validated

#: Most slicing intervals of the pen-and-ink plan: each slice is one pass over the story's faces
#: and one layer of ink, and at print resolution (a 5 cm slice step on a 2.5 m story at 1:100 is
#: far below a pixel of the drawing beyond 1000 slices) more add nothing visible, only time.
MAX_SLICES = 1000

#: Smallest raster cell in metres (floor and wall grids): scans are not more precise than about
#: 1 cm, and the grids have (extent / cell)^2 cells: at 1 cm a 100 m floor is 10^8 cells.
MIN_CELL_M = 0.01

#: Largest raster cell in metres: coarser than a metre, the grid cannot show a door or a room's
#: corner at all.
MAX_CELL_M = 1.0

#: Largest closing of the footprint, in metres: gaps wider than a few metres are rooms or
#: courtyards, not scan holes, and the closing's cost grows with its square in cells.
MAX_CLOSING_M = 10.0

_CELL = Real(MIN_CELL_M, MAX_CELL_M, why="finer than 1 cm no scan resolves and the grid grows as its inverse square; coarser than 1 m loses doors")
_LENGTH = Real(0.0, MAX_LENGTH_M, closed="right", why="lengths beyond 1 km are a unit mistake")
_GAP = Real(0.0, MAX_LENGTH_M, why="lengths beyond 1 km are a unit mistake")
_FRACTION = Real(0.0, 1.0)
_SPAN = Numbers(_LENGTH, 2, order="increasing", what="a range [min, max]")


@validated
@dataclass(frozen=True)
class PlanParams:
    """What the plans are made of.

    Attributes
    ----------
    slices
        Number ``n`` of slicing intervals of the pen-and-ink plan: the story is cut at the
        ``n + 1`` heights ``floor + (ceiling - floor) * i / n`` (paper: 100 balances detail and
        clutter); at most :data:`MAX_SLICES`.
    drafting_height_m
        Height above the floor at which the flat-wall model is cut for the drafting plan (the
        paper's "single intermediate altitude"; 1.2 m is the usual architectural cut plane,
        through windows and doors).
    corner_extension_m
        Wall ends are extended by at most this much to meet the walls they run into (scans
        round corners off, and miss pieces of wall near them).
    floor_margin_m
        The floor outline closes rooms where a wall is missing, grown by this much so that it
        stays outside walls that were found.
    floor_closure_margin_m
        Where a wall is missing, the room ends this far beyond the edge of its scanned floor
        (scans round off the corner between floor and wall).
    floor_cell_m
        Grid cell of the floor raster (where the floor was scanned).
    footprint_closing_m
        The story's footprint (its floor and everything standing on it) is closed over gaps up
        to this size before its outline closes the rooms that walls leave open.
    wall_gap_m
        Where a wall was not scanned, a room is closed along the walls that were: a wall end
        runs on by at most this much to the wall line it meets, and collinear pieces this far
        apart are joined (the widest door: a partition that nearly reaches a wall closes across it).
    room_mouth_m
        Widest mouth between two spaces that are still two rooms (a wide cased opening, a
        corridor's or a stair's mouth: 2.5 m, wider than double doors at 1.8 m and any stair or
        corridor of a dwelling or office): a partition scanned over a good part of its length
        (:data:`meshplan.plan.closure.PARTITION_SEEN_SHARE`) runs on by up to this much to the next
        wall or the edge of the scan; wider, the spaces are one open plan.
    collinear_wall_m
        Two parallel wall pieces whose lines are this close across are one wall (plaster, scan
        noise; less than a partition's thickness).
    wall_reach_m
        A room that the scanned floor closes is carried up to a wall (scanned, or continued
        across what the scan missed) it stops short of by at most this much: the depth of the
        furniture that stands against walls and hides the floor under it (desks 0.7-0.8 m,
        kitchen counters and wardrobes 0.6 m).
    open_room_fit_m
        A room that the scanned floor closes becomes its bounding rectangle along the walls
        when the rectangle's outline lies within this distance of the floor's, else it follows
        the floor: the depth of the furniture along a wall, which hides the floor under it (as
        ``wall_reach_m``: desks 0.7-0.8 m). At 0.3 m (before) a room whose floor a desk or a
        headset's range left ragged kept the raggedness: on the real truth the rooms of
        hl1_ashro, hl1_holosoma and hl2_su_office_chroje came out at IoU 0.95, 0.82 and 0.87
        against 0.99, 0.88 and 0.93 as rectangles.
    min_fragment_area_m2
        A piece that no wall closes and that is smaller than a closet (about 1.5 m2) is no
        room: it is merged into the room it touches, or dropped.
    min_room_area_m2, min_room_width_m
        Smaller or narrower faces of the wall arrangement are not rooms (wall interiors,
        slivers between wall lines and the floor outline).
    min_floor_fraction
        A room must have floor scanned under at least this fraction of it.
    opening_cell_m
        Grid cell of the wall rasters in which openings are looked for.
    opening_margin_m
        Bands of this height next to the floor and the ceiling are ignored when looking for
        openings (scans round the corners off there).
    opening_rectangularity
        An opening fills at least this fraction of its bounding rectangle on the wall grid
        (random holes in a scan are round or ragged).
    door_width_m, door_height_m
        Width range and smallest height of a door (a gap from the floor up).
    window_sill_m, window_width_m, window_height_m
        Smallest sill height above the floor, width range and smallest height of a window.
    window_area_m2
        Smallest clear area of a window (0.2 m2, e.g. 0.4 x 0.5 m: the smallest lavatory or
        basement windows). Smaller holes with straight edges in a scanned wall are vents,
        sockets, scan holes behind a picture or gaps between furniture in front of the wall.
    opening_slab_m
        Triangles this far in front of a wall face, or behind it by up to
        ``opening_wall_depth_m`` plus this, belong to the wall when openings are looked for
        (plaster, frame mouldings, scan noise; the other face of the wall and a piece of the
        same wall set back a little count too).
    opening_wall_depth_m
        Thickest wall body looked through behind a face (a 20 cm partition plus plaster): its
        far face closes what the near face's scan missed.
    opening_facing_deg
        Only triangles facing within this angle of the wall's normal (either way) are wall: a
        door leaf standing open further than this, a jamb or a reveal is not.
    opening_edge_straightness
        Share of an opening's rows (columns) whose left and right (bottom and top) edges lie
        within two grid cells of their median: a door or window frame is straight, a scan hole
        is ragged.
    door_corner_m
        A gap that runs to the end of a wall is a door next to a corner when a perpendicular
        wall crosses the wall's line within this distance of the gap's end (the corner is its
        jamb; 30 cm: the wall thickness and a scan's rounded corner).
    door_floor_beyond
        A gap from the floor to the ceiling (the scan missed the lintel) is a door only when the
        floor is seen beyond the wall across at least this share of its width (the floor runs
        through a doorway; behind a missing strip of an outer wall there is nothing).
    """

    _parameter_constraints: ClassVar[dict[str, Constraint]] = {
        "slices": Integer(1, MAX_SLICES, why="more slices add nothing visible at print resolution"),
        "drafting_height_m": _LENGTH,
        "corner_extension_m": _GAP,
        "floor_margin_m": _GAP,
        "floor_closure_margin_m": _GAP,
        "floor_cell_m": _CELL,
        "footprint_closing_m": Real(0.0, MAX_CLOSING_M, why="wider gaps are rooms, not scan holes"),
        "wall_gap_m": _GAP,
        "collinear_wall_m": _GAP,
        "room_mouth_m": _GAP,
        "open_room_fit_m": _GAP,
        "wall_reach_m": _GAP,
        "min_fragment_area_m2": Real(0.0, MAX_LENGTH_M**2, why="larger than any building"),
        "min_room_area_m2": Real(0.0, MAX_LENGTH_M**2, why="larger than any building"),
        "min_room_width_m": _LENGTH,
        "min_floor_fraction": _FRACTION,
        "opening_cell_m": _CELL,
        "opening_margin_m": _GAP,
        "opening_rectangularity": Real(0.0, 1.0, closed="right"),
        "door_width_m": _SPAN,
        "door_height_m": _LENGTH,
        "window_sill_m": _GAP,
        "window_width_m": _SPAN,
        "window_height_m": _LENGTH,
        "window_area_m2": Real(0.0, MAX_LENGTH_M**2, why="larger than any building"),
        "opening_slab_m": _GAP,
        "opening_wall_depth_m": _GAP,
        "opening_facing_deg": Real(0.0, 90.0, why="an angle between a triangle's normal and the wall's"),
        "opening_edge_straightness": _FRACTION,
        "door_corner_m": _GAP,
        "door_floor_beyond": _FRACTION,
    }

    slices: int = 100
    drafting_height_m: float = 1.2
    corner_extension_m: float = 0.6
    floor_margin_m: float = 0.15
    floor_closure_margin_m: float = 0.05
    floor_cell_m: float = 0.05
    footprint_closing_m: float = 0.3
    wall_gap_m: float = 1.5
    collinear_wall_m: float = 0.1
    room_mouth_m: float = 2.5
    open_room_fit_m: float = 0.8
    wall_reach_m: float = 0.8
    min_fragment_area_m2: float = 1.5
    min_room_area_m2: float = 1.0
    min_room_width_m: float = 0.5
    min_floor_fraction: float = 0.3
    opening_cell_m: float = 0.05
    opening_margin_m: float = 0.15
    opening_rectangularity: float = 0.8
    door_width_m: tuple[float, float] = (0.6, 1.5)
    door_height_m: float = 1.8
    window_sill_m: float = 0.3
    window_width_m: tuple[float, float] = (0.3, 3.0)
    window_height_m: float = 0.3
    window_area_m2: float = 0.2
    opening_slab_m: float = 0.08
    opening_wall_depth_m: float = 0.25
    opening_facing_deg: float = 30.0
    opening_edge_straightness: float = 0.75
    door_corner_m: float = 0.3
    door_floor_beyond: float = 0.5

    def to_dict(self) -> dict:
        return asdict(self)

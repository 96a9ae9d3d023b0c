"""Parameters of the floor plans (paper, "Floor plan computation"), with the paper's values."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from ..errors import ParameterError
from ..geometry import check_positive


@dataclass(frozen=True)
class PlanParams:
    """What the plans are made of.

    Attributes
    ----------
    slices
        Number ``n`` of slicing intervals of the pen-and-ink plan: the story is cut at the
        ``n + 1`` heights ``floor + (ceiling - floor) * i / n`` (paper: 100 balances detail and
        clutter).
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
    """

    slices: int = 100
    drafting_height_m: float = 1.2
    corner_extension_m: float = 0.6
    floor_margin_m: float = 0.15
    floor_closure_margin_m: float = 0.05
    floor_cell_m: float = 0.05
    footprint_closing_m: float = 0.3
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

    def __post_init__(self) -> None:
        if not isinstance(self.slices, int) or isinstance(self.slices, bool) or not 1 <= self.slices <= 10000:
            raise ParameterError(f"slices must be an integer from 1 to 10000, got {self.slices!r}", "pass --slices N")
        for name in ("door_width_m", "window_width_m"):
            lo, hi = (float(v) for v in getattr(self, name))
            if not 0 < lo <= hi:
                raise ParameterError(f"{name} must be a range 0 < min <= max, got {getattr(self, name)!r}", f"pass e.g. --set {name}=[0.6,1.5]")
            object.__setattr__(self, name, (lo, hi))
        for name in ("drafting_height_m", "floor_cell_m", "min_room_width_m", "opening_cell_m", "door_height_m", "window_height_m", "opening_rectangularity"):
            check_positive(name, getattr(self, name))
        for name in ("corner_extension_m", "floor_margin_m", "floor_closure_margin_m", "footprint_closing_m", "min_room_area_m2", "min_floor_fraction", "opening_margin_m", "window_sill_m"):
            check_positive(name, getattr(self, name), allow_zero=True)

    def to_dict(self) -> dict:
        return asdict(self)

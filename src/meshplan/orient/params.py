"""Parameters of the orientation stage, with the paper's values as defaults."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from ..errors import ParameterError
from ..geometry import check_positive
from ..sphere import PAPER_TRIM_SCHEDULE_DEG

#: Accepted values of ``up``: ``auto`` or a signed input axis.
UP_CHOICES = ("auto", "+x", "-x", "+y", "-y", "+z", "-z")

#: Gravity estimators: the paper's Method 2 (spherical k-means, default) and Method 1 (box).
GRAVITY_METHODS = ("kmeans", "bbox")

INCH_M = 0.0254


@dataclass(frozen=True)
class OrientParams:
    """How the mesh is levelled, split into levels and turned onto the axes.

    Attributes
    ----------
    up
        ``auto`` finds the up axis and its sign from the floor and ceiling structure; ``+y``,
        ``-z``, ... name the input axis that is roughly up (refined all the same).
    gravity_method
        ``kmeans``: the paper's Method 2, spherical k-means with k = 1 on the near-horizontal
        faces inside a cone that narrows along ``gravity_cones_deg``. ``bbox``: Method 1, the
        shortest edge of the minimum-volume bounding box (no refinement).
    gravity_cones_deg
        Cone half-angles of Method 2, from wide to narrow (paper: from 30 down to 3 degrees).
    gravity_plane_fit
        After Method 2, refine up as the common normal of the floors of all stories, fitted to
        the face *positions* (least squares over every floor at once). Positions average over
        metres of baseline where normals average over centimetre triangles, so this is several
        times more precise on noisy scans (median 0.05 degrees instead of 0.4 on the synthetic
        rooms). Ceilings are left out: on real scans their soffits, fixtures and drift made the
        fit worse. Not in the paper; off reproduces it.
    horizontal_tolerance_deg
        A face is horizontal (floor, ceiling, table top) when its normal is within this angle of
        the vertical ("a small angle" in the paper).
    level_bucket_m
        Bucket height of the altitude histogram (paper: 2 inches).
    min_room_height_m
        Smallest floor-to-ceiling gap of a story, separating floors from ceilings ("a gap of
        several feet"); 2.0 m is below the 2.13 m minimum ceiling height of most building codes.
    max_story_height_m
        Largest plausible floor-to-ceiling height; taller "stories" point to wrong units.
    spike_fraction
        A histogram spike smaller than this fraction of the largest one is clutter, not a
        floor or a ceiling.
    floor_group_m, ceiling_group_m
        Spikes this close to a story's main floor (ceiling) count as its sunken floors (raised
        ceilings); the highest floor and the lowest ceiling are used, as in the paper.
    default_ceiling_height_m
        Ceiling height above the floor assumed when a story has no ceiling in the scan.
    wall_trim_schedule_deg
        Outlier angles of the trimmed spherical k-means of the wall alignment (paper:
        50, 40, 30, 20, 10, 5, 3).
    wall_clusters
        Number of wall directions: 0 finds them (the four principal directions plus any other
        direction holding at least ``extra_direction_fraction`` of the wall area); 4 is the
        paper's Manhattan setting.
    keep_horizontal
        Keep floor and ceiling faces in the wall alignment (k + 2 clusters, the paper's k = 6).
    wall_exclusion_deg
        Faces whose normal is within this angle of the vertical are left out of the wall
        alignment (the paper's optional removal of floors and ceilings).
    extra_direction_fraction
        Share of the wall area that a non-principal wall direction must hold to be kept.
    slab_tolerance_m
        Near-horizontal faces within this distance of a floor or ceiling height are floor or
        ceiling surfaces: removed before the plans are sliced (paper, Algorithm 1,
        ``RemoveCeilingsAndFloors``) and, for the ceiling, from the story models.
    """

    up: str = "auto"
    gravity_method: str = "kmeans"
    gravity_cones_deg: tuple[float, ...] = (30.0, 20.0, 10.0, 5.0, 3.0)
    gravity_plane_fit: bool = True
    horizontal_tolerance_deg: float = 10.0
    level_bucket_m: float = 2 * INCH_M
    min_room_height_m: float = 2.0
    max_story_height_m: float = 10.0
    spike_fraction: float = 0.1
    floor_group_m: float = 0.3
    ceiling_group_m: float = 0.6
    default_ceiling_height_m: float = 2.5
    wall_trim_schedule_deg: tuple[float, ...] = PAPER_TRIM_SCHEDULE_DEG
    wall_clusters: int = 0
    keep_horizontal: bool = False
    wall_exclusion_deg: float = 30.0
    extra_direction_fraction: float = 0.08
    slab_tolerance_m: float = 0.1

    def __post_init__(self) -> None:
        if self.up not in UP_CHOICES:
            raise ParameterError(f"unknown up axis {self.up!r}", f"use one of {', '.join(UP_CHOICES)}")
        if self.gravity_method not in GRAVITY_METHODS:
            raise ParameterError(
                f"unknown gravity method {self.gravity_method!r}", f"use one of {', '.join(GRAVITY_METHODS)}"
            )
        for name in (
            "horizontal_tolerance_deg",
            "level_bucket_m",
            "min_room_height_m",
            "max_story_height_m",
            "default_ceiling_height_m",
            "wall_exclusion_deg",
        ):
            check_positive(name, getattr(self, name))
        for name in ("floor_group_m", "ceiling_group_m", "slab_tolerance_m", "spike_fraction", "extra_direction_fraction"):
            check_positive(name, getattr(self, name), allow_zero=True)
        if self.max_story_height_m <= self.min_room_height_m:
            raise ParameterError(
                "max_story_height_m must exceed min_room_height_m", "raise max_story_height_m"
            )
        for name in ("gravity_cones_deg", "wall_trim_schedule_deg"):
            seq = tuple(float(a) for a in getattr(self, name))
            if any(not (0 < a < 90) for a in seq) or list(seq) != sorted(seq, reverse=True):
                raise ParameterError(f"{name} must be decreasing angles between 0 and 90 degrees, got {seq}", "fix the schedule")
            object.__setattr__(self, name, seq)
        if self.wall_clusters not in (0,) and not (2 <= self.wall_clusters <= 16):
            raise ParameterError(f"wall_clusters must be 0 (automatic) or 2-16, got {self.wall_clusters}", "use 0 or 4")

    def to_dict(self) -> dict:
        return asdict(self)

"""Parameters of the orientation stage, with the paper's values as defaults."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import ClassVar

from ..errors import ParameterError
from ..units import INCH_M
from ..validation import (
    MAX_LENGTH_M,
    MAX_SCHEDULE_STEPS,
    AnyOf,
    Boolean,
    Constraint,
    Integer,
    Numbers,
    Options,
    Real,
    validated,
)

#: The paper's outlier schedule for the wall alignment, in degrees (here rather than in
#: :mod:`meshplan.sphere`, which uses it: the options read it for ``--help`` without numpy).
PAPER_TRIM_SCHEDULE_DEG = (50.0, 40.0, 30.0, 20.0, 10.0, 5.0, 3.0)

#: Accepted values of ``up``: ``auto`` or a signed input axis.
UP_CHOICES = ("auto", "+x", "-x", "+y", "-y", "+z", "-z")

#: Gravity estimators: the paper's Method 2 (spherical k-means, default) and Method 1 (box).
GRAVITY_METHODS = ("kmeans", "bbox")


#: Smallest bucket of the altitude histogram, in metres: 1 mm is finer than any scanner resolves
#: (HoloLens 2 and phone LiDAR: about 1 cm), and the histogram has (height span / bucket) bins,
#: so a bucket of 1e-300 m would ask for more bins than there are bytes.
MIN_LEVEL_BUCKET_M = 0.001

#: Largest bucket of the altitude histogram, in metres: a bucket taller than half a metre puts a
#: floor, the furniture on it and a sunken floor into one spike.
MAX_LEVEL_BUCKET_M = 0.5

#: Largest story height in metres that can be asked for: taller than any atrium; beyond it the
#: story search spans a range that only wrong units produce.
MAX_STORY_HEIGHT_LIMIT_M = 100.0

#: Most wall directions: each is one cluster of the spherical k-means; 16 already allows a wall
#: every 11 degrees around the compass, more only splits one wall direction into several.
MAX_WALL_CLUSTERS = 16

# What "horizontal" and "vertical" mean in each step of this stage, in degrees. They differ on
# purpose: each is as wide as what it must catch and no wider.

#: Faces within this angle of horizontal near a floor or ceiling vote for their patch's winding
#: (:func:`meshplan.orient.facing.inward_flips`): floors are level to a degree, but a headset
#: rounds the floor into the walls over 10-20 cm, and those faces still say which side is up;
#: steeper ones (ramps, stair nosings) could say either.
FACING_HORIZONTAL_DEG = 20.0

#: Faces within this angle of vertical vote for their patch's winding by the side their floor is
#: on: walls lean a few degrees in a coarse scan, and their rounded foot up to 30.
FACING_VERTICAL_DEG = 30.0

#: Faces within this angle of vertical start the wall alignment (the circular mean of four times
#: their azimuth): only the walls' own faces, not the bevels along floor and ceiling, whose
#: azimuths are those of the walls but whose areas would weigh in twice.
ALIGN_VERTICAL_DEG = 10.0

#: A wall normal farther than this from every wall direction found so far seeds a new direction
#: (non-Manhattan buildings): the trimmed k-means keeps walls within 3-10 degrees of their
#: cluster, so 15 degrees is clearly beyond any cluster's own scatter.
NEW_DIRECTION_DEG = 15.0

#: Faces within this angle of horizontal at a floor or ceiling height are slab faces (the paper's
#: ``RemoveCeilingsAndFloors``): as wide as the paper's up cone (30 degrees), so that the slab
#: faces removed are those the gravity step treated as floor.
SLAB_HORIZONTAL_DEG = 30.0

#: A face stands (wall, furniture side) when its normal is closer to horizontal than to vertical:
#: the occupancy cue of the up search asks only where things stand, not how steep they are.
STANDING_DEG = 45.0

_ANGLE = Real(0.0, 90.0, closed="neither", why="an angle from the vertical or from a direction")
_FRACTION = Real(0.0, 1.0)
_GAP = Real(0.0, MAX_LENGTH_M, why="lengths beyond 1 km are a unit mistake")
_HEIGHT = Real(0.0, MAX_STORY_HEIGHT_LIMIT_M, closed="right", why="no story is taller than 100 m")
_SCHEDULE = Numbers(
    Real(0.0, 90.0, closed="neither"),
    (1, MAX_SCHEDULE_STEPS),
    order="decreasing",
    what="a schedule of angles in degrees",
    why="each angle is one k-means pass over every face",
)


@validated
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
    gravity_fit_blend
        Combine the fitted floor normal with Method 2's up by inverse variance (the fit's
        measured by a block jackknife), so that a domed or sloping floor counts for less and up
        follows the normals there. Off (the default) keeps up the normal of the floor's best
        plane: the plan then has its floor level, as a draughtsman levels a survey and as the
        hand-digitized truth of the real scans is levelled; on, up is nearer gravity on a warped
        floor (a Tango room domed by 3-4 cm: 1.1 -> 0.3 degrees from the device's up, but 0.4 ->
        1.3 from its levelled floor).
    horizontal_tolerance_deg
        A face is horizontal (floor, ceiling, table top) when its normal is within this angle of
        the vertical ("a small angle" in the paper).
    level_bucket_m
        Bucket height of the altitude histogram (paper: 2 inches), from
        :data:`MIN_LEVEL_BUCKET_M` to :data:`MAX_LEVEL_BUCKET_M`.
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

    _parameter_constraints: ClassVar[dict[str, Constraint]] = {
        "up": Options(UP_CHOICES),
        "gravity_method": Options(GRAVITY_METHODS),
        "gravity_cones_deg": _SCHEDULE,
        "gravity_plane_fit": Boolean(),
        "gravity_fit_blend": Boolean(),
        "horizontal_tolerance_deg": _ANGLE,
        "level_bucket_m": Real(
            MIN_LEVEL_BUCKET_M, MAX_LEVEL_BUCKET_M, why="finer than 1 mm no scanner resolves; coarser than 0.5 m merges floors and furniture"
        ),
        "min_room_height_m": _HEIGHT,
        "max_story_height_m": _HEIGHT,
        "spike_fraction": _FRACTION,
        "floor_group_m": _GAP,
        "ceiling_group_m": _GAP,
        "default_ceiling_height_m": _HEIGHT,
        "wall_trim_schedule_deg": _SCHEDULE,
        "wall_clusters": AnyOf(
            Integer(0, 0),
            Integer(2, MAX_WALL_CLUSTERS),
            what=f"0 (automatic) or an integer from 2 to {MAX_WALL_CLUSTERS}",
        ),
        "keep_horizontal": Boolean(),
        "wall_exclusion_deg": Real(0.0, 90.0, closed="right", why="an angle from the vertical"),
        "extra_direction_fraction": _FRACTION,
        "slab_tolerance_m": _GAP,
    }

    up: str = "auto"
    gravity_method: str = "kmeans"
    gravity_cones_deg: tuple[float, ...] = (30.0, 20.0, 10.0, 5.0, 3.0)
    gravity_plane_fit: bool = True
    gravity_fit_blend: bool = False
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

    def _check_together(self) -> None:
        """Rules tying fields together (each field alone was checked by its constraint)."""
        if self.max_story_height_m <= self.min_room_height_m:
            raise ParameterError(
                f"max_story_height_m ({self.max_story_height_m:g}) must exceed min_room_height_m ({self.min_room_height_m:g})",
                "raise max_story_height_m or lower min_room_height_m",
            )

    def to_dict(self) -> dict:
        return asdict(self)

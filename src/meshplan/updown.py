"""Up or down, when furniture cannot tell: the orientation step that asks the doors.

:func:`meshplan.orient.orient` takes the sign of gravity from what stands on floors
(:func:`meshplan.orient.gravity.sign_evidence`). An empty building shows too little of that, and
then its doors decide: a door reaches down to the floor, so the way up that shows clearly more
doors is up. Counting doors needs the flat walls and the openings, which are found above
:mod:`meshplan.orient` (:mod:`meshplan.walls`, :mod:`meshplan.plan`), so this step lives here,
above them, rather than inside ``orient`` with an import running back up.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace

from .errors import MeshplanError
from .geometry import Mesh
from .options import RunOptions
from .orient import Orientation, orient
from .orient.gravity import PRIOR_SIGN_BY
from .plan import Openings, find_openings
from .walls import FlatWalls, find_flat_walls, physical_walls

log = logging.getLogger(__name__)

__all__ = ["WEAK_SIGN_EVIDENCE", "Upright", "settle_up", "up_by_doors", "up_in_doubt"]

#: Below this evidence (a log-ratio, see :func:`meshplan.orient.gravity.sign_evidence`) the
#: scan shows too little furniture to tell up from down (furnished synthetic scans give 1.2 and
#: more, real scans 0.3-2.3, empty buildings near 0, or below it from their door heads), and the
#: doors decide.
WEAK_SIGN_EVIDENCE = 1.0


@dataclass(frozen=True, eq=False)
class Upright:
    """The orientation kept, the scan in its plan frame and, when the doors were counted, the
    walls and openings found on the way (so that they are not found again).

    Attributes
    ----------
    orientation
        The orientation kept; its ``gravity.sign_by`` is ``"doors"`` when the doors decided.
    mesh
        The scan in that orientation's plan frame, normals facing into the rooms.
    walls, openings
        The flat walls and openings of ``mesh``, or ``None`` when the doors were not counted.
    """

    orientation: Orientation
    mesh: Mesh
    walls: FlatWalls | None = None
    openings: Openings | None = None


def up_in_doubt(orientation: Orientation, options: RunOptions) -> bool:
    """Whether the sign of gravity is left to the doors: ``up`` is ``auto``, gravity was found
    by k-means, not from the device's gravity-aligned frame (which measured the sign too), and
    the furniture's evidence is weaker than :data:`WEAK_SIGN_EVIDENCE`."""
    g = orientation.gravity
    return options.orient.up == "auto" and g.method == "kmeans" and g.sign_by != PRIOR_SIGN_BY["device"] and abs(g.sign_evidence) < WEAK_SIGN_EVIDENCE


def up_by_doors(mesh: Mesh, orientation: Orientation, plan_mesh: Mesh, options: RunOptions) -> Upright:
    """Doors reach down to the floor: the way up that shows clearly more doors is up.

    Upside down, a door is a gap hanging from the ceiling, which no door detector takes for a
    door; every room has one, furnished or not. Returns the orientation and plan mesh kept and
    their walls and openings (computed here, so that they are not computed again).
    """

    def doors(o: Orientation, m: Mesh) -> tuple[int, FlatWalls, Openings]:
        walls = find_flat_walls(m, o, options.walls)
        physical = physical_walls(walls, options.walls.max_wall_thickness_m, options.walls.default_wall_thickness_m)
        openings = find_openings(m, o, walls, options.plan, physical=physical)
        return sum(k == "door" for k in openings.kind), walls, openings

    n_here, walls, openings = doors(orientation, plan_mesh)
    here = Upright(orientation, plan_mesh, walls, openings)
    try:
        other = orient(mesh, options.orient, up_hint=-orientation.gravity.up)
    except MeshplanError:  # upside down there is no floor at all
        return here
    other_mesh = mesh.transformed(other.transform, other.flipped)
    n_other, other_walls, other_openings = doors(other, other_mesh)
    log.debug("up in doubt (sign evidence %.2f): %d doors this way up, %d the other", orientation.gravity.sign_evidence, n_here, n_other)

    def by_doors(o: Orientation) -> Orientation:
        return replace(o, gravity=replace(o.gravity, sign_by="doors"))

    if n_other > 2 * n_here:
        return Upright(by_doors(other), other_mesh, other_walls, other_openings)
    if n_here > 2 * n_other:
        return replace(here, orientation=by_doors(orientation))
    return here


def settle_up(mesh: Mesh, orientation: Orientation, options: RunOptions) -> Upright:
    """The orientation step after :func:`meshplan.orient.orient`: the scan turned into the plan
    frame, and turned over when the doors say so (only when :func:`up_in_doubt`).

    Parameters
    ----------
    mesh
        The scan in input coordinates, metres. Unless the way up is in doubt, it gives its
        corners and cross products to the plan mesh (:meth:`Mesh.transformed`'s ``reuse``).
    orientation
        What :func:`meshplan.orient.orient` (or the plausibility checks around it) found.
    options
        Every parameter of the run.
    """
    if up_in_doubt(orientation, options):  # the scan is oriented again the other way up
        return up_by_doors(mesh, orientation, mesh.transformed(orientation.transform, orientation.flipped), options)
    # the scan's corners and cross products are not needed again: the plan mesh's are written
    # over them (0.29 GB of fresh memory spared at 3M faces)
    return Upright(orientation, mesh.transformed(orientation.transform, orientation.flipped, reuse=True))

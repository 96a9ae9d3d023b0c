"""Is this a building, in these units, this way up? Checks on the geometry after orientation.

Orientation finds floors, ceilings and walls whatever the scale of the coordinates, so a scan read
in the wrong units gives stories of absurd but not impossible heights: a scan in feet read as
metres has 8.8 m ceilings and 194 m2 rooms. The one measure that every building shares is the
height of its stories, so :func:`orient_plausibly` reads it off the orientation and, when it is
implausible in the units the scan was read in, orients the scan again in each of the other
units (m, cm, mm, ft, in) and names the one that makes it a plausible building. It also refuses
a scan that holds no building at all (a sphere, a chair: no wall and no floor below a ceiling)
and an ``--up`` that the geometry contradicts.

The rules (the thresholds are the constants below):

* A story is *ordinary* at :data:`STORY_MIN_M` to :data:`STORY_MAX_M` floor to ceiling, *tall*
  (a double-height hall) up to :data:`HALL_MAX_M`. Without a ceiling, the height of what was
  scanned is measured instead, from :data:`SCANNED_MIN_M`.
* Units not given (``--units`` absent; with ``options=`` only ``m`` counts as absent): ordinary
  stories are accepted as they are. A tall story is accepted unless another unit makes every
  story ordinary; then the scan is refused, naming both readings (6.6-8.5 m is also 6.6-8.5 ft,
  the most common ceiling height of houses in feet). Anything else is refused, naming the unit
  that makes it ordinary (the nearest to :data:`TYPICAL_STORY_M` when several do). A scan that
  cannot be oriented at all in them (no floor found, no walls) is oriented in the other units
  too: one that makes it an ordinary building is named beside the error.
* Units given explicitly: trusted while the stories are possible in them (from the minimum up
  to ``max_story_height_m``), with a warning when another unit would make a tall story
  ordinary; refused with the right unit when the stories are impossible (``--units cm`` on a
  metre scan: 2.7 cm stories).
* ``--up`` given: refused when along that axis there is no floor below a ceiling, or the
  stories are implausible, while the automatic up finds a plausible floor below a ceiling along
  another axis. The sign is the user's to choose (an empty room has nothing to tell it by).
* No building: no flat vertical wall (:data:`WALL_MIN_AREA_M2` within a :data:`WALL_SLAB_M`
  thick slab, :data:`WALL_MIN_SPAN_M` tall, standing on the floor) and no floor below a ceiling
  (both at least :data:`SLAB_MIN_AREA_M2`). A fragment with a floor and one wall passes.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace

import numpy as np

from .errors import GeometryError, MeshplanError
from .geometry import AXIS_VECTORS, FloatArray, Mesh
from .io.mesh import UNITS_M
from .orient import Orientation, OrientParams, orient
from .units import UNIT_NAMES

log = logging.getLogger(__name__)

#: Lowest plausible floor-to-ceiling height (m): building codes ask for 2.1-2.4 m in rooms, and
#: basements and attics go a little lower; the levels stage pairs floors with ceilings from
#: 2.0 m (``min_room_height_m``) too.
STORY_MIN_M = 2.0
#: Highest ordinary floor-to-ceiling height (m): shops, lobbies, lecture rooms and workshops
#: stay below about 6 m.
STORY_MAX_M = 6.0
#: Highest height (m) taken for a story without a second thought when no other unit explains
#: it: a double-height hall (two 3-4 m stories with the slab left out) plus a 0.5 m margin.
HALL_MAX_M = 8.5
#: The story height (m) a unit is judged against when several make the scan plausible: the
#: usual 2.4-3 m of homes and offices.
TYPICAL_STORY_M = 2.7
#: Lowest plausible height (m) of what was scanned when there is no ceiling: a person scanning
#: a room in passing sees its walls up to chest height at least; a desk (0.75 m), a chair (about 1 m) or a
#: shelf scanned alone stay below.
SCANNED_MIN_M = 1.2
#: Share of a story's vertices (either end) left out of its scanned height: stray triangles
#: above or below the room (HoloLens meshes hold a few) must not make it taller.
SCANNED_QUANTILE = 0.005

#: Faces whose normal lies within this angle (degrees) of a wall direction count for that wall:
#: the 4-10 cm facets of a scanned flat wall tilt by up to about 15 degrees with the noise.
WALL_NORMAL_TOL_DEG = 20.0
#: Thickness (m) of the slab a flat wall's faces lie in: HoloLens and phone scans put a wall's
#: points within 2-3 cm of its plane. A sphere's faces fill such a slab only over a cap far
#: shorter than a wall, up to 11 m across.
WALL_SLAB_M = 0.1
#: Least face area (m2) in one slab for a wall: a 0.5 m wide strip of a 1 m tall wall, what a
#: fragment of a scan shows of its one wall. A chair back (0.2 m2) stays below.
WALL_MIN_AREA_M2 = 0.5
#: Least vertical extent (m) of a wall's faces: more than a desk or a table (0.75 m) or a chair
#: back; walls scanned only to chest height (an open office, scanned in passing) still rise
#: 1.2 m.
WALL_MIN_SPAN_M = 1.0
#: A wall's lowest faces must come this close (m) to the floor: walls stand on the floor, and
#: furniture in front of them (desks 0.75 m, sideboards 0.8 m) hides at most that much of them
#: from the scanner. (The flat-looking band round a sphere's equator hangs higher than this
#: above its lowest point from 1.2 m of radius; smaller spheres fail the span.)
WALL_FLOOR_REACH_M = 0.8
#: Depth (m) on the inner side of a wall's slab compared with the slab itself, and the least
#: share of that depth's area the slab must hold: a wall is flat, so most of what faces its way
#: nearby lies in its plane even with furniture in front, while a curved surface (a sphere's
#: zone area grows with its depth) spreads evenly and holds 0.1 / 0.4 = 25 % in the slab.
WALL_DEPTH_M = 0.4
WALL_MIN_FLATNESS = 0.4
#: Least area (m2) of horizontal faces at a story's floor and at its ceiling for a "floor below a
#: ceiling": the floor of a small bathroom. A sphere's poles hold 0.1 r2 within 10 degrees of
#: horizontal, less than this up to a 9 m sphere.
SLAB_MIN_AREA_M2 = 2.0
#: Axes that differ by more than this angle (degrees) are different axes (not the same axis,
#: tilted); ``--up`` names an axis only roughly, to within a few tens of degrees.
SAME_AXIS_DEG = 45.0


_AXIS_NAMES = ("x", "y", "z")


@dataclass(frozen=True)
class Assessment:
    """What orientation makes of the scan read in one unit.

    Attributes
    ----------
    units
        The unit the scan was read in.
    orientation
        The orientation, or ``None`` when orienting failed (``error``).
    error
        Why orienting failed.
    heights
        Per story, the floor-to-ceiling height, or the scanned height above the floor when the
        story has no ceiling (m).
    ceilings
        Per story, whether its ceiling was found.
    no_building
        Why the scan holds no building, or ``""`` when it does.
    """

    units: str
    orientation: Orientation | None
    error: MeshplanError | None
    heights: tuple[float, ...] = ()
    ceilings: tuple[bool, ...] = ()
    no_building: str = ""

    def grade(self, max_story_m: float = HALL_MAX_M) -> str:
        """``ordinary``, ``tall`` (a hall, :data:`STORY_MAX_M` to ``max_story_m``) or
        ``implausible`` (including when orienting failed)."""
        if self.orientation is None or not self.heights:
            return "implausible"
        grade = "ordinary"
        for h, ceiling in zip(self.heights, self.ceilings):
            if h < (STORY_MIN_M if ceiling else SCANNED_MIN_M) or h > max_story_m:
                return "implausible"
            if h > STORY_MAX_M:
                grade = "tall"
        return grade

    @property
    def plausible(self) -> bool:
        """Ordinary stories and a building."""
        return self.grade() == "ordinary" and not self.no_building

    def describe(self, chosen: str) -> str:
        """``story height 8.84 'm' = 2.69 m in ft``: the highest story, as the file's numbers
        read in ``chosen`` units and as metres in these units."""
        i = int(np.argmax(self.heights))
        what = "story height" if self.ceilings[i] else "scanned height"
        raw = self.heights[i] / UNITS_M[self.units]
        number = f"{raw:.3g}" if raw < 1000 else f"{raw:,.0f}"
        return f"{what} {number} '{chosen}' = {self.heights[i]:.2f} m in {self.units}"


def story_heights(mesh: Mesh, orientation: Orientation) -> tuple[tuple[float, ...], tuple[bool, ...]]:
    """Per story: floor to ceiling, or floor to the top of what was scanned without a ceiling.

    Parameters
    ----------
    mesh
        The scan in input coordinates (metres), as oriented.
    orientation
        Its orientation.
    """
    y = _plan_heights(mesh.face_centroids, orientation)
    heights, ceilings = [], []
    for s in orientation.stories:
        if s.ceiling_found:
            heights.append(float(s.height))
        else:
            sel = orientation.face_story == s.index
            top = float(np.quantile(y[sel], 1.0 - SCANNED_QUANTILE)) if np.any(sel) else s.floor
            heights.append(max(0.0, top - s.floor))
        ceilings.append(bool(s.ceiling_found))
    return tuple(heights), tuple(ceilings)


def _plan_heights(points: FloatArray, orientation: Orientation) -> FloatArray:
    t = orientation.transform
    return points @ t[1, :3] + t[1, 3]


def building_evidence(mesh: Mesh, orientation: Orientation, params: OrientParams) -> str:
    """Why the oriented scan holds no building, or ``""`` when it shows a wall or a floor below
    a ceiling (see the module docstring)."""
    rot = orientation.transform[:3, :3]
    normals = mesh.face_normals @ rot.T
    y = _plan_heights(mesh.face_centroids, orientation)
    areas = mesh.face_areas
    horiz = np.abs(normals[:, 1]) >= np.cos(np.radians(params.horizontal_tolerance_deg))
    tol = max(params.slab_tolerance_m, 0.5 * params.level_bucket_m)
    for s in orientation.stories:
        if not s.ceiling_found:
            continue
        floor = areas[horiz & (np.abs(y - s.floor) <= tol)].sum()
        ceiling = areas[horiz & (np.abs(y - s.ceiling) <= tol)].sum()
        if min(floor, ceiling) >= SLAB_MIN_AREA_M2:
            return ""
    # each face's story floor (0 for faces of no story), looked up by story index
    index = np.array([s.index for s in orientation.stories], dtype=np.int64)
    floor_of = np.zeros(int(index.max()) + 2 if len(index) else 1)
    floor_of[index] = [s.floor for s in orientation.stories]
    story = np.where(orientation.face_story >= 0, orientation.face_story, len(floor_of) - 1)
    cos_tol = np.cos(np.radians(WALL_NORMAL_TOL_DEG))
    for d in orientation.alignment.directions:
        along = np.abs(normals @ d.normal) >= cos_tol
        if areas[along].sum() < WALL_MIN_AREA_M2:
            continue
        offset = mesh.face_centroids[along] @ (rot.T @ d.normal)
        # two half-slab bins at a time, so that a wall straddling a bin edge is kept whole
        bins = np.floor(offset / (0.5 * WALL_SLAB_M)).astype(np.int64)
        bins -= bins.min()
        per_bin = np.bincount(bins, weights=areas[along])
        pair = per_bin + np.r_[per_bin[1:], 0.0]
        # the same direction's area within WALL_DEPTH_M either side, to judge flatness by
        reach = int(round(WALL_DEPTH_M / (0.5 * WALL_SLAB_M)))
        cum = np.r_[0.0, np.cumsum(per_bin)]
        face_floor = floor_of[story[along]]
        for b in np.flatnonzero(pair >= WALL_MIN_AREA_M2):
            near = max(cum[min(b + 2, len(per_bin))] - cum[max(b + 2 - reach, 0)], cum[min(b + reach, len(per_bin))] - cum[b])
            if pair[b] < WALL_MIN_FLATNESS * near:
                continue
            sel = (bins == b) | (bins == b + 1)
            h = y[along][sel] - face_floor[sel]
            lo, hi = np.quantile(h, [0.02, 0.98])
            if hi - lo >= WALL_MIN_SPAN_M and lo <= WALL_FLOOR_REACH_M:
                return ""
    lo, hi = mesh.bounds()
    size = ", ".join(f"{v:.2g}" for v in sorted(hi - lo))
    return (
        f"no wall (no flat vertical surface {WALL_MIN_SPAN_M:g} m tall on the floor) and no floor below a ceiling "
        f"in a scan of {size} m: a single object?"
    )


def assess(mesh: Mesh, units: str, params: OrientParams, declared_up: FloatArray | None = None, declared_by: str = "format") -> Assessment:
    """Orient ``mesh`` (metres, as read in ``units``; ``declared_up`` the format's or the
    device's up, ``declared_by`` which, see :func:`meshplan.orient.orient`) and measure what the
    orientation found."""
    try:
        o = orient(mesh, params, declared_up=declared_up, declared_by=declared_by)
    except MeshplanError as exc:
        return Assessment(units, None, exc)
    heights, ceilings = story_heights(mesh, o)
    return Assessment(units, o, None, heights, ceilings, building_evidence(mesh, o, params))


def _rescaled(mesh: Mesh, factor: float) -> Mesh:
    return Mesh(mesh.vertices * factor, mesh.faces)


def _scale_related(a: Assessment) -> bool:
    """Whether the units may be why the scan read in them looks wrong: implausible story heights
    (or scale) rather than, say, a missing floor in a scan of plausible size."""
    if a.orientation is not None:
        return a.grade() != "ordinary"
    assert a.error is not None  # orienting failed
    return "implausible" in a.error.problem


def _axis_name(v: FloatArray) -> str:
    """``+y`` for a direction within :data:`SAME_AXIS_DEG` of an input axis, else ``auto``."""
    k = int(np.argmax(np.abs(v)))
    if abs(v[k]) < np.cos(np.radians(SAME_AXIS_DEG)):
        return "auto"
    return ("+" if v[k] > 0 else "-") + _AXIS_NAMES[k]


def _check_up(mesh: Mesh, chosen: Assessment, params: OrientParams) -> None:
    """Refuse an explicit ``--up`` that the geometry contradicts (see the module docstring)."""
    has_ceiling = chosen.orientation is not None and any(chosen.ceilings)
    if has_ceiling and chosen.grade(params.max_story_height_m) != "implausible":
        return
    auto = assess(mesh, chosen.units, replace(params, up="auto"))
    if auto.orientation is None or not any(auto.ceilings) or auto.grade() == "implausible" or auto.no_building:
        return  # the geometry says no better: the user's axis stands
    named = np.asarray(AXIS_VECTORS[params.up])
    found = auto.orientation.gravity.up
    if abs(float(named @ found)) >= np.cos(np.radians(SAME_AXIS_DEG)):
        return  # the same axis: nothing to contradict
    if chosen.orientation is None:
        assert chosen.error is not None  # orienting failed
        along = chosen.error.problem
    elif not has_ceiling:
        along = f"no floor below a ceiling along {params.up[1]}"
    else:
        along = f"a story height of {max(chosen.heights):.2f} m along {params.up[1]}"
    axis = _axis_name(found)
    raise GeometryError(
        f"the scan contradicts --up {params.up}: {along}, but a floor {max(auto.heights):.2f} m "
        f"below a ceiling along {axis if axis != 'auto' else np.round(found, 2).tolist()}",
        f"pass --up {axis}" + (" or leave --up out" if axis != "auto" else ""),
    )




def orient_plausibly(
    mesh: Mesh, units: str, params: OrientParams, units_explicit: bool, declared_up: FloatArray | None = None, declared_by: str = "format"
) -> tuple[Orientation, tuple[str, ...]]:
    """Orient the scan and check that it is a building, in ``units``, the way ``params.up`` says.

    Parameters
    ----------
    mesh
        The scan in input coordinates, converted to metres as read in ``units``.
    units
        The unit it was read in (``m``, ``cm``, ``mm``, ``ft``, ``in``).
    params
        Orientation parameters (``up`` explicit unless ``auto``).
    units_explicit
        Whether the user named the units (``--units``), rather than taking the default.
    declared_up
        The up the file's format declares (:attr:`meshplan.io.LoadStats.declared_up`), a prior
        where the geometry cannot decide; ``declared_by`` (:attr:`~meshplan.io.LoadStats.declared_by`)
        says how strong a prior it is.

    Returns
    -------
    orientation, warnings
        The orientation in ``units`` and anything the user should know about its plausibility.

    Raises
    ------
    GeometryError
        Units that the geometry contradicts (naming the right one), no building, an ``--up``
        that the geometry contradicts, or any error of the orientation itself.
    """
    chosen = assess(mesh, units, params, declared_up, declared_by)
    if params.up != "auto":
        _check_up(mesh, chosen, params)
    building = chosen.orientation is not None and not chosen.no_building
    if building and chosen.grade() == "ordinary":
        assert chosen.orientation is not None  # a building was oriented
        return chosen.orientation, ()
    # a hall: up to HALL_MAX_M, or as tall as orientation allows (max_story_height_m) when the
    # user named the units, if no other unit explains it
    hall = building and chosen.grade(params.max_story_height_m if units_explicit else HALL_MAX_M) == "tall"
    # taller than HALL_MAX_M without --units: the other unit is named, the hall only in the hint
    hall_hint = building and chosen.grade(params.max_story_height_m) == "tall"
    others = []
    # orienting may also fail for want of a floor or walls at a building's scale (a scan in feet
    # read as metres: "no floor found" on hl1_ashro): without --units the other units are tried
    # then too, and the error stands unless one of them makes an ordinary building
    failed = chosen.orientation is None and not units_explicit
    if hall or _scale_related(chosen) or failed:
        for u in UNITS_M:
            if u == units:
                continue
            a = assess(_rescaled(mesh, UNITS_M[u] / UNITS_M[units]), u, params, declared_up, declared_by)
            log.debug("units %s: %s, heights %s, %s", u, a.grade(), np.round(a.heights, 2).tolist(), a.no_building or a.error or "a building")
            if a.plausible:
                others.append(a)
    others.sort(key=lambda a: max(abs(np.log(h / TYPICAL_STORY_M)) for h in a.heights))
    best = others[0] if others else None
    if hall:
        assert chosen.orientation is not None  # a hall is a building, which was oriented
        if best is None:
            return chosen.orientation, ()  # a hall: no other unit explains it
        if units_explicit:
            return chosen.orientation, (
                f"stories of {max(chosen.heights):.2f} m taken for a tall hall in {UNIT_NAMES[units]}, as --units says; "
                f"in {UNIT_NAMES[best.units]} they would be {max(best.heights):.2f} m",
            )
    if best is not None:
        if hall:
            raise GeometryError(
                f"the scan looks like it is in {UNIT_NAMES[best.units]} ({best.describe(units)}), "
                f"unless it is a hall {max(chosen.heights):.1f} m tall",
                f"pass --units {best.units}, or --units {units} if it is a hall",
            )
        # what orienting in the chosen units ran into (an implausible scale, ...) comes first
        found = ""
        if chosen.orientation is None:
            assert chosen.error is not None  # orienting failed
            found = f"{chosen.error.problem}: "
        raise GeometryError(
            f"{found}the scan looks like it is in {UNIT_NAMES[best.units]} ({best.describe(units)})",
            f"pass --units {best.units}" + (f" (or --units {units} if it is a hall that tall)" if hall_hint else ""),
        )
    if chosen.orientation is None:
        assert chosen.error is not None  # orienting failed
        if _scale_related(chosen):
            raise GeometryError(
                chosen.error.problem,
                f"no unit among {', '.join(UNITS_M)} makes it a plausible building; check the scan and --units",
            ) from chosen.error
        raise chosen.error
    if chosen.no_building:
        raise GeometryError(f"no building found: {chosen.no_building}", "scan a room: its floor, its walls and, if you can, its ceiling")
    i = int(np.argmax(np.abs(np.log(np.maximum(chosen.heights, 1e-9) / TYPICAL_STORY_M))))
    what = "story height" if chosen.ceilings[i] else "scanned height"
    raise GeometryError(
        f"implausible {what} of {chosen.heights[i]:.3g} m (read in {UNIT_NAMES[units]}), a building's in none of {', '.join(UNITS_M)}",
        "check the scan, --units and --up" if params.up == "auto" else "check the scan, --units and --up (try leaving --up out)",
    )

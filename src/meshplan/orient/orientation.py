"""The orientation stage itself: :class:`Orientation` and :func:`orient` (re-exported by
:mod:`meshplan.orient`)."""

from __future__ import annotations

import threading
from dataclasses import dataclass, replace

import numpy as np

from ..errors import GeometryError
from ..geometry import FloatArray, IntArray, Mesh, few_blas_threads, homogeneous, rotation_about_y, rotation_between
from .align import WallAlignment, WallDirection, align_walls
from .facing import inward_flips
from .gravity import GravityEstimate, estimate_gravity, refine_with_slabs
from .levels import Levels, find_levels
from .params import OrientParams
from .stories import Story, assign_faces, split_stories

#: Largest plausible median triangle size (m) of a scan: HoloLens and phone scans make 1-10 cm
#: triangles. Larger ones are refused as a unit mistake only where the scan is also taller than a
#: story in every direction (:func:`_check_scale`): a model of boxes (RoomPlan's walls and
#: furniture, a CAD export) has triangles of 1-4 m and a building's size.
_MAX_TRIANGLE_SIZE_M = 1.0

#: Above this many faces the up direction, the levels and the wall directions are estimated on
#: an even sample of the faces (every k-th, so the same scan gives the same sample), each face
#: of the sample standing for k faces' area. They are area-weighted statistics of the normals
#: and heights, which settle long before: measured on synthetic apartments of 0.3M, 0.6M (two
#: stories) and 1M faces, a 150k-face sample puts gravity within 0.002 degree and floors and
#: ceilings within 0.5 mm of every face's estimate, and takes the stage from 0.27 to 0.19 s
#: (0.3M faces), 0.41 to 0.29 s (0.6M), 0.45 to 0.35 s (1M). The real scans here (up to 140k
#: faces) are estimated on every face.
ESTIMATE_MAX_FACES = 150_000


#: From this many faces the mesh's pieces and centroids are computed in a thread beside the
#: estimates (:func:`_beside`): below, they take a few milliseconds, less than the thread's
#: start and the competition for the GIL cost.
BESIDE_MIN_FACES = 1_000_000


def _beside(mesh: Mesh) -> threading.Thread:
    """A started thread computing ``mesh.face_roots`` and ``mesh.face_centroids`` and caching
    them on the mesh (the same arrays as the properties compute; not through them: a cached
    property holds one lock for every mesh, and the sample's centroids would wait for it)."""

    def work() -> None:
        for name in ("face_roots", "face_centroids"):
            value = getattr(Mesh, name).func(mesh)
            mesh.__dict__.setdefault(name, value)

    t = threading.Thread(target=work, name="meshplan-orient-beside", daemon=True)
    t.start()
    return t


def estimation_sample(mesh: Mesh, max_faces: int | None = None) -> Mesh:
    """``mesh`` itself when it has at most ``max_faces`` faces (``None``:
    :data:`ESTIMATE_MAX_FACES`, read at the call), else every k-th of its faces
    (``k = ceil(F / max_faces)``) as a triangle soup whose face areas are ``k`` times their
    own, so that areas compared with absolute thresholds (m2) keep their meaning.

    The soup has no connectivity: it serves statistics of normals, heights and areas (the
    up direction, the levels, the wall directions), not what follows the surface.
    """
    k = -(-mesh.n_faces // (ESTIMATE_MAX_FACES if max_faces is None else max_faces))
    if k <= 1:
        return mesh
    idx = np.arange(0, mesh.n_faces, k)
    tri = np.ascontiguousarray(mesh.triangles[idx])
    soup = Mesh._adopt(tri.reshape(-1, 3).copy(), np.arange(3 * len(idx), dtype=np.int64).reshape(-1, 3))
    return soup._seed(triangles=tri, _cross=mesh._cross[idx], face_normals=mesh.face_normals[idx], face_areas=k * mesh.face_areas[idx])


@dataclass(frozen=True)
class Orientation:
    """Everything the orientation stage found.

    Attributes
    ----------
    transform
        4x4 rigid transform (det +1) from input coordinates (metres) to the plan frame.
    gravity
        The up estimate, in input coordinates.
    levels
        The altitude histogram, its spikes and the floor and ceiling heights (plan frame).
    alignment
        The wall clustering; its directions are given in the plan frame.
    stories
        Floor, ceiling and extent of each story (plan frame).
    face_story
        ``(F,)`` story index of every face.
    flipped
        ``(F,)`` faces whose winding was reversed so that normals face into the rooms.
    warnings
        Things the user should know (no ceiling found, ...).
    """

    transform: FloatArray
    gravity: GravityEstimate
    levels: Levels
    alignment: WallAlignment
    stories: tuple[Story, ...]
    face_story: IntArray
    flipped: np.ndarray
    warnings: tuple[str, ...]

    @property
    def rotation(self) -> FloatArray:
        return self.transform[:3, :3]

    def wall_directions(self) -> tuple[WallDirection, ...]:
        return self.alignment.directions


def _check_scale(mesh: Mesh, params: OrientParams) -> None:
    """Refuse a scan whose triangles and size both say its units are not metres (see
    :data:`_MAX_TRIANGLE_SIZE_M`), suggesting the unit that makes both plausible."""
    size = float(np.sqrt(2.0 * np.median(mesh.face_areas)))
    if size > _MAX_TRIANGLE_SIZE_M:
        lo, hi = mesh.bounds()
        extent = np.sort(hi - lo)
        if extent[0] <= params.max_story_height_m:
            # a story's height fits in one direction at least: a model of boxes in metres (a
            # RoomPlan room without its furniture's small faces: 1.1 m triangles), not a unit
            # mistake; the stories' heights are checked once found
            return
        problem = f"implausible scale: the median triangle is {size:.3g} m across"
        # every direction is taller than a story: whichever is up, the stories are implausible
        problem += f" and the scan measures at least {extent[0]:,.0f} m in every direction, an implausible story height"
        hint = "check the units of the scan (--units)"
        for unit, factor in (("mm", 0.001), ("cm", 0.01), ("in", 0.0254)):
            # suggest a unit only when it makes both the triangles and the building plausible
            if 0.002 <= size * factor <= 0.5 and extent[-1] * factor >= 1.0:
                hint = f"the scan seems to be in {unit}: pass --units {unit}"
                break
        raise GeometryError(problem, hint)


#: What decided the sign of up weakly enough for the walls to overrule it (``sign_by`` of
#: :class:`~meshplan.orient.gravity.GravityEstimate`): the furniture's low-against-high
#: balance, or the file's axes when the furniture said nothing. The user's ``--up``, a hint, the
#: format's or the device's declared up are not overruled.
_OVERRULED_SIGNS = ("furniture", "file axes")

#: Below this sign evidence (a log-ratio, :func:`meshplan.orient.gravity.sign_evidence`) the
#: furniture says nothing of up and down: the real scans, furnished, give 0.3-2.3 the right
#: way up, empty buildings about 0. Only then do walls found below the floor turn the scan over;
#: with more, a scan without its floor (walls and furniture under a ceiling) stays the right
#: way up and is refused as one.
_NO_SIGN_EVIDENCE = 0.3


#: Wall area lies below a floor when it lies deeper than this under it (m): more than a sunken
#: floor's step or a floor's scatter.
_BELOW_FLOOR_M = 0.3

#: A "floor" with more than this share of the wall area below it is no floor: walls stand on
#: theirs (a table top or a ceiling taken for the floor).
_MAX_WALL_SHARE_BELOW = 0.25


def _wall_share_below(normals: FloatArray, heights: FloatArray, areas: FloatArray, floor: float, params: OrientParams) -> float:
    """Share of the wall area lying more than :data:`_BELOW_FLOOR_M` below ``floor``."""
    walls = np.abs(normals[:, 1]) < np.sin(np.radians(params.wall_exclusion_deg))
    total = float(areas[walls].sum())
    return float(areas[walls & (heights < floor - _BELOW_FLOOR_M)].sum()) / total if total > 0 else 0.0


def _check_floor(normals: FloatArray, heights: FloatArray, areas: FloatArray, floor: float, params: OrientParams) -> None:
    """Walls stand on the floor: when much of the wall area lies well below the lowest floor
    found, that "floor" is a table top or a ceiling, and the real floor is not in the scan."""
    below = _wall_share_below(normals, heights, areas, floor, params)
    if below > _MAX_WALL_SHARE_BELOW:
        raise GeometryError(
            f"no floor found: {100 * below:.0f} % of the wall area lies below the lowest horizontal surface",
            "make sure the scan includes the floor, or name the up axis with --up",
        )


def orient(
    mesh: Mesh, params: OrientParams | None = None, up_hint: FloatArray | None = None, declared_up: FloatArray | None = None, declared_by: str = "format"
) -> Orientation:
    """Level the mesh, find its floors, ceilings and stories, and turn its walls onto the axes.

    Parameters
    ----------
    mesh
        The scan in input coordinates, metres.
    params
        Orientation parameters; the paper's defaults when omitted.
    up_hint
        A rough up direction in input coordinates, to use instead of searching for one (see
        :func:`meshplan.pipeline.compute`, which tries the other way up when the scan says
        little about it).
    declared_up
        The up direction the file's format declares (input coordinates; glTF: +y), a prior
        where the geometry cannot decide (:func:`meshplan.orient.gravity.estimate_gravity`).
    declared_by
        ``"format"`` (a file format's convention) or ``"device"`` (the gravity-aligned frame of
        the capturing device, a stronger prior): see ``estimate_gravity``.

    Raises
    ------
    GeometryError
        No floor, no walls, or an implausible scale.
    """
    with few_blas_threads():  # its products are thin (geometry.BLAS_THREADS)
        return _orient(mesh, params or OrientParams(), up_hint, declared_up, declared_by)


def _orient(mesh: Mesh, params: OrientParams, up_hint: FloatArray | None, declared_up: FloatArray | None, declared_by: str) -> Orientation:
    """:func:`orient` itself, with its parameters given."""
    _check_scale(mesh, params)
    # what the facing test and the levelling of every face need of the mesh alone (its pieces,
    # its centroids) is computed beside the estimates, on the other core: the union-find is
    # compiled without the GIL and numpy releases it in its loops (0.2-0.4 s at 3M faces)
    beside = _beside(mesh) if mesh.n_faces >= BESIDE_MIN_FACES else None
    # the estimates on a sample of a very large mesh; the faces' stories and facing on all
    sample = estimation_sample(mesh)
    gravity = estimate_gravity(sample, params, up_hint, declared_up, declared_by)
    areas = sample.face_areas

    def level(up):
        r = rotation_between(up, [0.0, 1.0, 0.0])
        n, c = sample.face_normals @ r.T, sample.face_centroids @ r.T
        return r, n, c, find_levels(c[:, 1], n[:, 1], areas, params)

    r_level, normals, centroids, levels = level(gravity.up)
    if params.gravity_plane_fit and params.gravity_method == "kmeans":
        slabs = [s.floor for s in levels.stories]
        # slab heights are along the current up; refine in input coordinates
        up, used = refine_with_slabs(
            sample.face_centroids, sample.face_normals, areas, gravity.up, slabs, params
        )
        if used:
            gravity = replace(gravity, up=up, faces_used=used)
            r_level, normals, centroids, levels = level(up)
    heights = centroids[:, 1]
    lowest = levels.stories[0].floor
    if (
        gravity.sign_by in _OVERRULED_SIGNS
        and abs(gravity.sign_evidence) < _NO_SIGN_EVIDENCE
        and _wall_share_below(normals, heights, areas, lowest, params) > _MAX_WALL_SHARE_BELOW
    ):
        # up points down: the "floor" is the top of the walls (a story without a ceiling, whose
        # furniture gave the sign no lead). Walls stand on the floor: turned over, they do
        r_over, n_over, c_over, levels_over = level(-gravity.up)
        if _wall_share_below(n_over, c_over[:, 1], areas, levels_over.stories[0].floor, params) <= _MAX_WALL_SHARE_BELOW:
            gravity = replace(gravity, up=-gravity.up, rough_up=-gravity.rough_up, sign_evidence=-gravity.sign_evidence, sign_by="walls on the floor")
            r_level, normals, centroids, levels = r_over, n_over, c_over, levels_over
            heights, lowest = centroids[:, 1], levels.stories[0].floor
    _check_floor(normals, heights, areas, lowest, params)
    highest = levels.stories[-1].ceiling
    alignment = align_walls(normals, areas, heights, lowest, highest, params)
    if beside is not None:
        beside.join()
    if sample is not mesh:  # every face levelled, once
        normals, centroids = mesh.face_normals @ r_level.T, mesh.face_centroids @ r_level.T
        heights = centroids[:, 1]
    if not alignment.directions:
        raise GeometryError(
            "no walls found: the scan has no vertical surfaces between its floor and ceiling",
            "check that the scan includes the walls and that --up names the up axis",
        )
    r_yaw = rotation_about_y(alignment.yaw)
    rotation = r_yaw @ r_level
    verts = mesh.vertices @ rotation.T
    x0 = float(np.quantile(verts[:, 0], 0.005))
    z0 = float(np.quantile(verts[:, 2], 0.005))
    transform = homogeneous(rotation, [-x0, -lowest, -z0])
    levels = levels.shifted(-lowest)
    heights = heights - lowest
    stories = split_stories(levels)
    directions = tuple(
        WallDirection(normal=r_yaw @ d.normal, weight=d.weight, principal=d.principal) for d in alignment.directions
    )
    alignment = WallAlignment(alignment.yaw, directions, alignment.centers @ r_yaw.T, alignment.weights, alignment.faces_used)
    face_story = assign_faces(heights, stories)
    flipped = inward_flips(mesh, normals, centroids, heights, stories, params.slab_tolerance_m, rotation=r_level)
    for s in stories:
        if s.height > params.max_story_height_m:
            raise GeometryError(f"implausible story height of {s.height:.1f} m", "check the units of the scan (--units)")
    return Orientation(
        transform=transform,
        gravity=gravity,
        levels=levels,
        alignment=alignment,
        stories=stories,
        face_story=face_story,
        flipped=flipped,
        warnings=levels.warnings,
    )

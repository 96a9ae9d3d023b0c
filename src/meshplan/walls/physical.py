"""Physical walls: the flat wall faces paired into walls with a thickness.

A scan sees each wall from the rooms on its sides. Two faces that look away from each other, lie
less than ``max_thickness_m`` apart and overlap along the wall by at least half of the shorter
one are the two sides of one wall, whose thickness is their distance. Further faces in the plane
of one side (a corridor wall seen as several faces from the rooms behind it) join that wall. A
face seen from one side only (an outer wall, or a partition whose other side was not scanned)
makes a wall of the stated default thickness behind it.

Walls meet: scans round corners off, so the centre lines stop 5-15 cm short of each other.
:func:`join_walls` extends (or trims) each end to the nearest centre line it meets within
``reach_m``: at an L corner both walls end at the intersection of their centre lines, at a T
junction the stem ends on the centre line of the wall it meets.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..geometry import FloatArray
from .flat import FlatWalls


@dataclass(frozen=True)
class PhysicalWall:
    """A wall body in the plan frame (x, z) between two heights."""

    story: int
    faces: tuple[int, ...]  # indices of the flat wall faces it carries
    start: tuple[float, float]  # centre line
    end: tuple[float, float]
    thickness: float
    paired: bool  # thickness measured from both faces (else the default)
    bottom: float = 0.0  # lowest and highest scanned point of its faces (y)
    top: float = 0.0
    #: how far each end (start, end) was moved along the wall by :func:`join_walls`, in metres:
    #: positive where it was extended to the wall it meets, negative where it was trimmed
    joined: tuple[float, float] = (0.0, 0.0)
    #: one face scanned, the thickness read from the reveals of its openings instead of the
    #: default (:func:`meshplan.plan.elements.reveal_thickness`)
    revealed: bool = False
    #: what :mod:`meshplan.plan.elements` adds once the rooms are known: whether one side is
    #: outside the building, the rooms (indices into the result's rooms) on the side of
    #: ``normal`` and on the other side, and how sure the wall is (high, medium, low) and why
    exterior: bool | None = None
    rooms: tuple[tuple[int, ...], tuple[int, ...]] = ((), ())
    confidence: str = ""
    confidence_reason: str = ""

    @property
    def length(self) -> float:
        return float(np.hypot(self.end[0] - self.start[0], self.end[1] - self.start[1]))

    @property
    def direction(self) -> FloatArray:
        d = np.subtract(self.end, self.start)
        return d / max(np.linalg.norm(d), 1e-12)

    @property
    def normal(self) -> FloatArray:
        """Unit normal ``(dz, -dx)`` of the centre line (the convention of the flat walls):
        ``rooms[0]`` lie on this side."""
        d = self.direction
        return np.array([d[1], -d[0]])


#: Two faces are in one plane (the same side of a wall) when their planes lie this close (m):
#: the scatter of the planes fitted to pieces of one wall face (plaster, scan noise, 1-2 cm).
COPLANAR_M = 0.03

#: Pairs of faces are taken by the length they share, in steps of this (m; then the thinnest
#: first): lengths closer than a scan's ragged face ends count as equal.
PAIR_OVERLAP_STEP_M = 0.25

#: How far a wall end moves to meet another wall (m; :func:`join_walls`): the 0.1-0.2 m that
#: headset meshes bevel off a corner plus half of the thickest wall (0.2 m, ``max_thickness_m``),
#: well below the shortest wall kept, so an end never jumps to a wall across a room or a door.
JOIN_REACH_M = 0.35

#: Two centre lines cross at a junction only when they meet at this angle or more (degrees):
#: parallel pieces never meet, and walls of a non-Manhattan building meet at 30-90 degrees.
JOIN_MIN_ANGLE_DEG = 20.0


def physical_walls(walls: FlatWalls, max_thickness_m: float, default_thickness_m: float) -> tuple[PhysicalWall, ...]:
    """Pair the faces of ``walls`` into physical walls (greedily, thinnest pair first).

    Parameters
    ----------
    walls
        The flat wall faces of every story.
    max_thickness_m
        Faces farther apart are not the two sides of one wall.
    default_thickness_m
        Thickness of a wall seen from one side only.

    Returns
    -------
    tuple of PhysicalWall
        Every face in exactly one wall, sorted by story and faces.
    """
    n = len(walls)
    tan, nor, off = walls.tangent, walls.normal, walls.offset
    candidates = []
    for a in range(n):
        for b in range(a + 1, n):
            if walls.story[a] != walls.story[b] or nor[a] @ nor[b] > -0.99:
                continue
            gap = off[a] + off[b]  # b's plane lies at n_a . p = -off_b, behind a by this much
            if not 0.02 < gap <= max_thickness_m:
                continue
            ua = sorted((walls.start[a] @ tan[a], walls.end[a] @ tan[a]))
            ub = sorted((walls.start[b] @ tan[a], walls.end[b] @ tan[a]))
            overlap = min(ua[1], ub[1]) - max(ua[0], ub[0])
            if overlap >= 0.5 * min(ua[1] - ua[0], ub[1] - ub[0]) and overlap > 0:
                candidates.append((-round(overlap / PAIR_OVERLAP_STEP_M), gap, a, b))
    used = np.zeros(n, dtype=bool)
    groups: list[tuple[list[int], list[int], float]] = []  # (faces of side a, of side b, gap)
    # the pairs sharing the longest stretch first (then the thinnest): a short face standing
    # within a wall's depth (a closed leaf in its frame, the back of a niche) is nearer to
    # either side than the other side is, but shares less of its length
    for _, gap, a, b in sorted(candidates):
        if used[a] or used[b]:
            continue
        used[a] = used[b] = True
        groups.append(([a], [b], gap))
    # a face left over in the plane of one side of a paired wall, behind the other side, joins it
    for c in map(int, np.flatnonzero(~used)):
        for side_a, side_b, _gap in groups:
            if walls.story[c] != walls.story[side_a[0]]:
                continue
            for same, other in ((side_a, side_b), (side_b, side_a)):
                f = same[0]
                if nor[c] @ nor[f] < 0.99 or abs(off[c] - off[f]) > COPLANAR_M:
                    continue
                uc = sorted((walls.start[c] @ tan[f], walls.end[c] @ tan[f]))
                uo = [u for g in other for u in (walls.start[g] @ tan[f], walls.end[g] @ tan[f])]
                if min(uc[1], max(uo)) - max(uc[0], min(uo)) >= 0.5 * (uc[1] - uc[0]):
                    same.append(c)
                    used[c] = True
                    break
            if used[c]:
                break
    # ... and so does a face standing within its depth along it (a closed leaf set back in its
    # frame, the back of a niche): it is no wall of its own
    for c in map(int, np.flatnonzero(~used)):
        for side_a, side_b, gap in groups:
            f = side_a[0]
            if walls.story[c] != walls.story[f] or abs(nor[c] @ nor[f]) < 0.99:
                continue
            depth = off[f] - nor[f] @ (nor[c] * off[c])  # how far c's plane lies behind f's
            if not COPLANAR_M < depth < gap - COPLANAR_M:
                continue
            uc = sorted((walls.start[c] @ tan[f], walls.end[c] @ tan[f]))
            ug = [u for g in side_a + side_b for u in (walls.start[g] @ tan[f], walls.end[g] @ tan[f])]
            if uc[0] >= min(ug) - COPLANAR_M and uc[1] <= max(ug) + COPLANAR_M:
                (side_a if nor[c] @ nor[f] > 0 else side_b).append(c)
                used[c] = True
                break
    out = []
    for side_a, side_b, gap in groups:
        a = side_a[0]
        faces = side_a + side_b
        u = [p @ tan[a] for g in faces for p in (walls.start[g], walls.end[g])]
        centre = off[a] - gap / 2
        s = min(u) * tan[a] + centre * nor[a]
        e = max(u) * tan[a] + centre * nor[a]
        out.append(
            PhysicalWall(
                int(walls.story[a]), (side_a[0], side_b[0], *sorted(side_a[1:] + side_b[1:])), (float(s[0]), float(s[1])),
                (float(e[0]), float(e[1])), float(gap), True, float(walls.bottom[faces].min()), float(walls.top[faces].max()),
            )
        )
    for a in map(int, np.flatnonzero(~used)):
        centre = off[a] - default_thickness_m / 2
        s = walls.u_min[a] * tan[a] + centre * nor[a]
        e = walls.u_max[a] * tan[a] + centre * nor[a]
        out.append(
            PhysicalWall(
                int(walls.story[a]), (int(a),), (float(s[0]), float(s[1])), (float(e[0]), float(e[1])), float(default_thickness_m), False,
                float(walls.bottom[a]), float(walls.top[a]),
            )
        )
    out.sort(key=lambda w: (w.story, w.faces))
    return tuple(out)


def join_walls(physical: tuple[PhysicalWall, ...], reach_m: float) -> tuple[PhysicalWall, ...]:
    """The walls with their centre lines ending on each other at corners and T junctions.

    Each end of each wall moves along the wall to the nearest centre line of another wall of
    its story that it meets at :data:`JOIN_MIN_ANGLE_DEG` or more, when that line lies within
    ``reach_m`` beyond the end (extended) or behind it (trimmed: an end that overshoots the
    wall it meets), and the meeting point lies on that wall or within ``reach_m`` of its ends.
    The ends move once, from the walls as scanned, so the result does not depend on the order.

    Parameters
    ----------
    physical
        The walls (:func:`physical_walls`).
    reach_m
        How far an end may move: the corners scans leave open or rounded plus half a wall's
        thickness (headset meshes bevel corners over 0.1-0.2 m).

    Returns
    -------
    tuple of PhysicalWall
        The same walls, with ``start``/``end`` moved and ``joined`` recording by how much.
    """
    n = len(physical)
    if n < 2:
        return physical
    p0 = np.array([w.start for w in physical], dtype=np.float64)
    p1 = np.array([w.end for w in physical], dtype=np.float64)
    d = p1 - p0
    length = np.maximum(np.linalg.norm(d, axis=1), 1e-12)
    t = d / length[:, None]
    story = np.array([w.story for w in physical])
    sin_min = np.sin(np.radians(JOIN_MIN_ANGLE_DEG))
    moved = np.zeros((n, 2))
    for k, (ends, sign) in enumerate(((p0, -1.0), (p1, 1.0))):
        out_dir = sign * t  # outward along each wall at this end
        # line b: p0_b + v t_b; solve ends_a + s out_a = p0_b + v t_b
        cross = out_dir[:, None, 0] * t[None, :, 1] - out_dir[:, None, 1] * t[None, :, 0]  # (a, b)
        rel = p0[None, :, :] - ends[:, None, :]
        with np.errstate(divide="ignore", invalid="ignore"):
            s = (rel[..., 0] * t[None, :, 1] - rel[..., 1] * t[None, :, 0]) / cross
            v = (rel[..., 0] * out_dir[:, None, 1] - rel[..., 1] * out_dir[:, None, 0]) / cross
        ok = (np.abs(cross) >= sin_min) & (story[:, None] == story[None, :]) & (np.abs(s) <= reach_m)
        ok &= (v >= -reach_m) & (v <= length[None, :] + reach_m)
        # never trim a wall to less than half its length
        ok &= s >= -0.5 * length[:, None]
        np.fill_diagonal(ok, False)
        cost = np.where(ok, np.abs(s), np.inf)
        best = np.argmin(cost, axis=1)
        hit = np.isfinite(cost[np.arange(n), best])
        moved[hit, k] = s[np.flatnonzero(hit), best[hit]]
    out = []
    for i, w in enumerate(physical):
        s0 = p0[i] - moved[i, 0] * t[i]
        s1 = p1[i] + moved[i, 1] * t[i]
        out.append(replace(w, start=(float(s0[0]), float(s0[1])), end=(float(s1[0]), float(s1[1])), joined=(float(moved[i, 0]), float(moved[i, 1]))))
    return tuple(out)


def wall_of_face(physical: tuple[PhysicalWall, ...], n_faces: int) -> np.ndarray:
    """``(n_faces,)`` index of the physical wall carrying each flat wall face."""
    out = np.full(n_faces, -1, dtype=np.int64)
    for i, w in enumerate(physical):
        out[list(w.faces)] = i
    return out

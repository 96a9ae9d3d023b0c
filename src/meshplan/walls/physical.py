"""Physical walls: the flat wall faces paired into walls with a thickness.

A scan sees each wall from the rooms on its sides. Two faces that look away from each other, lie
less than ``max_thickness_m`` apart and overlap along the wall by at least half of the shorter
one are the two sides of one wall, whose thickness is their distance. A face seen from one side
only (an outer wall, or a partition whose other side was not scanned) makes a wall of the stated
default thickness behind it.
"""

from __future__ import annotations

from dataclasses import dataclass

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

    @property
    def length(self) -> float:
        return float(np.hypot(self.end[0] - self.start[0], self.end[1] - self.start[1]))

    @property
    def direction(self) -> FloatArray:
        d = np.subtract(self.end, self.start)
        return d / max(np.linalg.norm(d), 1e-12)


def physical_walls(walls: FlatWalls, max_thickness_m: float, default_thickness_m: float) -> tuple[PhysicalWall, ...]:
    """Pair the faces of ``walls`` into physical walls (greedily, thinnest pair first)."""
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
                candidates.append((gap, a, b))
    used = np.zeros(n, dtype=bool)
    out = []
    for gap, a, b in sorted(candidates):
        if used[a] or used[b]:
            continue
        used[a] = used[b] = True
        u = [walls.start[a] @ tan[a], walls.end[a] @ tan[a], walls.start[b] @ tan[a], walls.end[b] @ tan[a]]
        centre = off[a] - gap / 2
        s = min(u) * tan[a] + centre * nor[a]
        e = max(u) * tan[a] + centre * nor[a]
        out.append(PhysicalWall(int(walls.story[a]), (a, b), (float(s[0]), float(s[1])), (float(e[0]), float(e[1])), float(gap), True))
    for a in map(int, np.flatnonzero(~used)):
        centre = off[a] - default_thickness_m / 2
        s = walls.u_min[a] * tan[a] + centre * nor[a]
        e = walls.u_max[a] * tan[a] + centre * nor[a]
        out.append(
            PhysicalWall(int(walls.story[a]), (int(a),), (float(s[0]), float(s[1])), (float(e[0]), float(e[1])), float(default_thickness_m), False)
        )
    out.sort(key=lambda w: (w.story, w.faces))
    return tuple(out)


def wall_of_face(physical: tuple[PhysicalWall, ...], n_faces: int) -> np.ndarray:
    """``(n_faces,)`` index of the physical wall carrying each flat wall face."""
    out = np.full(n_faces, -1, dtype=np.int64)
    for i, w in enumerate(physical):
        out[list(w.faces)] = i
    return out

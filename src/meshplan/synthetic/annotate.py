"""Annotated objects of a synthetic scan: sensors, thermostats, doors and windows (truth frame).

Every object sits on the inner face of a wall and points into the room it is in, the way a user
would place it in the HoloLens app.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import FloatArray
from .layout import Building, free_centres


@dataclass(frozen=True)
class Marker:
    """One annotated object, truth frame."""

    label: str
    kind: str
    position: FloatArray  # (3,)
    direction: FloatArray  # (3,) unit, the wall normal into the room
    wall: int
    u_m: float  # along the wall from its start
    height_m: float  # above the story's floor


def _on_wall(b: Building, wi: int, u: float, height_m: float) -> tuple[FloatArray, FloatArray]:
    w = b.walls[wi]
    p = w.point(u)
    floor = b.stories[w.story][0]
    return np.array([p[0], floor + height_m, p[1]]), np.array([w.normal[0], 0.0, w.normal[1]])


def place_annotations(b: Building, rng: np.random.Generator) -> list[Marker]:
    """Sensors (0-2 per room, 1.2-1.8 m), one thermostat per story (1.5 m, beside a door), and a
    marker for every door (centre, 1.0 m) and window (centre)."""
    taken: dict[int, list[tuple[float, float]]] = {}
    for o in b.openings:
        taken.setdefault(o.wall, []).append((o.u_m - o.width_m / 2, o.u_m + o.width_m / 2))
    sensors: list[Marker] = []
    thermostats: list[Marker] = []

    def free_spot(wi: int, width: float = 0.2) -> float | None:
        w = b.walls[wi]
        free = free_centres(0.0, w.length, width, 0.2, taken.get(wi, []))
        if not free:
            return None
        lens = np.array([hi - lo for lo, hi in free]) + 1e-9
        lo, hi = free[int(rng.choice(len(free), p=lens / lens.sum()))]
        return float(rng.uniform(lo, hi))

    for s in range(len(b.stories)):
        doors = [o for o in b.openings if o.story == s and o.kind == "door"]
        for k in rng.permutation(len(doors)):
            o = doors[k]
            w = b.walls[o.wall]
            side = 1.0 if rng.random() < 0.5 else -1.0
            placed = False
            for sgn in (side, -side):
                u = o.u_m + sgn * (o.width_m / 2 + rng.uniform(0.25, 0.5))
                if not 0.3 <= u <= w.length - 0.3:
                    continue
                if any(a - 0.15 < u < c + 0.15 for a, c in taken.get(o.wall, [])):
                    continue
                pos, nrm = _on_wall(b, o.wall, u, 1.5)
                thermostats.append(Marker(f"T{len(thermostats) + 1}", "thermostat", pos, nrm, o.wall, u, 1.5))
                taken.setdefault(o.wall, []).append((u, u))
                placed = True
                break
            if placed:
                break

    for r in range(len(b.rooms)):
        walls = b.room_walls(r)
        lengths = np.array([b.walls[i].length for i in walls])
        for _ in range(int(rng.integers(0, 3))):
            wi = walls[int(rng.choice(len(walls), p=lengths / lengths.sum()))]
            u = free_spot(wi)
            if u is None:
                continue
            h = float(rng.uniform(1.2, 1.8))
            pos, nrm = _on_wall(b, wi, u, h)
            sensors.append(Marker(f"S{len(sensors) + 1}", "sensor", pos, nrm, wi, u, h))
            taken.setdefault(wi, []).append((u, u))

    out = sensors + thermostats
    for o in b.openings:
        if not o.primary:
            continue
        floor = b.stories[o.story][0]
        h = 1.0 if o.kind == "door" else 0.5 * (o.bottom + o.top) - floor
        pos, nrm = _on_wall(b, o.wall, o.u_m, h)
        out.append(Marker(o.label, o.kind, pos, nrm, o.wall, o.u_m, h))
    return out

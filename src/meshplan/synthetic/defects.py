"""HoloLens-like defects: missing wall strips, holes, correlated noise and the scan pose.

The pose follows a HoloLens session: the device's origin is where the user's head was when the
scan started, 1.6 m above the floor of the first room, with an arbitrary heading and a small
tilt of the gravity axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import FloatArray, homogeneous, rotation_about_axis, rotation_about_y
from .layout import Building, free_centres, point_in_polygon

#: Head height of the user where the scan starts, above the floor.
HEAD_HEIGHT_M = 1.6
#: Standard deviation of the white (uncorrelated) vertex noise, per axis.
WHITE_NOISE_M = 0.002


@dataclass(frozen=True)
class Missing:
    """A full-height vertical strip missing from a wall face, ``from_m`` to ``to_m`` along it."""

    story: int
    wall: int
    from_m: float
    to_m: float


@dataclass(frozen=True)
class Hole:
    """An elliptical hole in a floor, ceiling (``index`` = room) or wall face (``index`` = wall).

    ``center`` is ``(x, z)`` on floors and ceilings, ``(u along the wall, height above the floor)``
    on walls.
    """

    surface: str
    story: int
    index: int
    center: tuple[float, float]
    radii: tuple[float, float]
    angle_rad: float


def pick_missing(b: Building, avoid: dict[int, list[float]], bevel_m: float, rng: np.random.Generator) -> list[Missing]:
    """One to three missing wall strips, 0.5-1.5 m wide, at most a third of their wall, clear of
    corners, openings and annotated objects (``avoid``: positions along each wall)."""
    count = int(rng.integers(1, 4))
    lengths = np.array([w.length for w in b.walls])
    order = rng.permutation(len(b.walls))
    out: list[Missing] = []
    for wi in order:
        if len(out) == count:
            break
        w = b.walls[wi]
        if lengths[wi] < 1.5 + 2 * (bevel_m + 0.15):
            continue
        width = float(rng.uniform(0.5, min(1.5, lengths[wi] / 3.0)))
        taken = [(o.u_m - o.width_m / 2, o.u_m + o.width_m / 2) for o in b.wall_openings(int(wi))]
        taken += [(u, u) for u in avoid.get(int(wi), [])]
        margin = bevel_m + 0.15
        free = free_centres(0.0, lengths[wi], width, margin, taken)
        if not free:
            continue
        lens = np.array([hi - lo for lo, hi in free]) + 1e-9
        lo, hi = free[int(rng.choice(len(free), p=lens / lens.sum()))]
        c = float(rng.uniform(lo, hi))
        out.append(Missing(w.story, int(wi), c - width / 2, c + width / 2))
    return out


def pick_holes(b: Building, avoid: dict[int, list[tuple[float, float]]], missing: list[Missing], rng: np.random.Generator) -> list[Hole]:
    """A few elliptical holes (semi-axes 0.1-0.6 m) in floors, ceilings and walls. Walls that
    miss a strip and the spots of annotated objects (``avoid``: ``(u, height)`` per wall) are
    spared."""
    n = int(rng.integers(2, 5)) + len(b.rooms) // 2
    areas = np.array([r.area for r in b.rooms])
    skip = {m.wall for m in missing}
    wall_ids = [i for i, w in enumerate(b.walls) if i not in skip and w.length >= 1.0]
    wall_areas = np.array([b.walls[i].length * (b.walls[i].top - b.walls[i].bottom) for i in wall_ids])
    out: list[Hole] = []
    for _ in range(n):
        surface = ("floor", "ceiling", "wall")[int(rng.choice(3, p=[0.35, 0.35, 0.3]))]
        radii = (float(rng.uniform(0.1, 0.6)), float(rng.uniform(0.1, 0.6)))
        angle = float(rng.uniform(0.0, np.pi))
        if surface == "wall" and wall_ids:
            wi = wall_ids[int(rng.choice(len(wall_ids), p=wall_areas / wall_areas.sum()))]
            w = b.walls[wi]
            height = w.top - w.bottom
            r = min(max(radii), w.length / 3.0, height / 3.0)
            radii = (min(radii[0], r), min(radii[1], r))
            for _try in range(10):
                c = (float(rng.uniform(r, w.length - r)), float(rng.uniform(r, height - r)))
                if all(np.hypot(c[0] - u, c[1] - v) > r + 0.15 for u, v in avoid.get(wi, [])):
                    out.append(Hole("wall", w.story, wi, c, radii, angle))
                    break
        else:
            surface = "ceiling" if surface == "wall" else surface
            ri = int(rng.choice(len(areas), p=areas / areas.sum()))
            poly = b.rooms[ri].polygon
            lo, hi = poly.min(axis=0), poly.max(axis=0)
            for _try in range(20):
                x, z = rng.uniform(lo, hi)
                if point_in_polygon(poly, x, z):
                    out.append(Hole(surface, b.rooms[ri].story, ri, (float(x), float(z)), radii, angle))
                    break
    return out


def smooth_noise(points: FloatArray, amplitude_m: float, rng: np.random.Generator, n_waves: int = 8) -> FloatArray:
    """A smooth random field at ``points``: a sum of ``n_waves`` plane waves with random
    directions, phases and wavelengths of 0.3-3 m, scaled so that its standard deviation is
    ``amplitude_m``.

    Returns
    -------
    ``(N,)`` field values, metres.
    """
    dirs = rng.normal(size=(n_waves, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    wavelengths = np.exp(rng.uniform(np.log(0.3), np.log(3.0), n_waves))
    phases = rng.uniform(0.0, 2.0 * np.pi, n_waves)
    weights = rng.uniform(0.5, 1.0, n_waves)
    weights *= amplitude_m / np.sqrt(0.5 * np.sum(weights**2))  # a sine of amplitude a has std a/sqrt(2)
    k = dirs * (2.0 * np.pi / wavelengths)[:, None]
    out = np.zeros(len(points))
    for i in range(n_waves):
        out += weights[i] * np.sin(points @ k[i] + phases[i])
    return out


def scan_transform(
    rng: np.random.Generator,
    start: FloatArray,
    yaw_deg: float | None,
    tilt_deg: float | None,
    max_tilt_deg: float,
    z_up: bool,
) -> tuple[FloatArray, float, float, FloatArray]:
    """The rigid transform truth -> scan.

    A yaw about +y, a tilt about a random horizontal axis, the translation that puts ``start``
    (the user's head where the scan began) at the origin and, with ``z_up``, a quarter turn about
    +x that takes +y to +z.

    Returns
    -------
    transform, yaw_deg, tilt_deg, tilt_axis
    """
    yaw = float(rng.uniform(0.0, 360.0))  # always drawn, so that overriding it changes nothing else
    tilt = float(rng.uniform(0.0, max_tilt_deg))
    heading = float(rng.uniform(0.0, 2.0 * np.pi))
    yaw = float(yaw_deg) % 360.0 if yaw_deg is not None else yaw
    tilt = float(tilt_deg) if tilt_deg is not None else tilt
    axis = np.array([np.cos(heading), 0.0, np.sin(heading)])
    rot = rotation_about_axis(axis, np.radians(tilt)) @ rotation_about_y(np.radians(yaw))
    m = homogeneous(rot, -rot @ np.asarray(start, dtype=np.float64))
    if z_up:
        m = homogeneous(rotation_about_axis([1.0, 0.0, 0.0], np.pi / 2)) @ m
    return m, yaw, tilt, axis

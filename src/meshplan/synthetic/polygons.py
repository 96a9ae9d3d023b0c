"""Plan polygons: ``(k, 2)`` arrays of ``[x, z]``, counter-clockwise seen from above (x to the
right, z down the page), which makes their shoelace sum over ``(x, z)`` negative."""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import box as shapely_box

from ..geometry import FloatArray


def signed_area(poly: FloatArray) -> float:
    """Shoelace sum over ``(x, z)``: negative for counter-clockwise seen from above."""
    x, z = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.dot(x, np.roll(z, -1)) - np.dot(np.roll(x, -1), z))


def ccw(poly: FloatArray) -> FloatArray:
    """``poly`` counter-clockwise seen from above."""
    poly = np.asarray(poly, dtype=np.float64)
    return poly if signed_area(poly) < 0 else poly[::-1].copy()


def rect_polygon(x0: float, x1: float, z0: float, z1: float) -> FloatArray:
    """Axis-aligned rectangle, counter-clockwise seen from above."""
    return np.array([[x0, z0], [x0, z1], [x1, z1], [x1, z0]], dtype=np.float64)


def union_polygon(rects: list[tuple[float, float, float, float]]) -> FloatArray:
    """Outline of the union of touching rectangles ``(x0, x1, z0, z1)``, without collinear corners."""
    geom = shapely.union_all([shapely_box(x0, z0, x1, z1) for x0, x1, z0, z1 in rects])
    pts = np.asarray(geom.exterior.coords)[:-1]
    keep = []
    for i in range(len(pts)):
        a, b, c = pts[i - 1], pts[i], pts[(i + 1) % len(pts)]
        if abs((b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0])) > 1e-12:
            keep.append(b)
    return ccw(np.array(keep))


def inset_polygon(poly: FloatArray, d: float) -> FloatArray:
    """A rectilinear counter-clockwise polygon with every edge moved ``d`` into it."""
    normals = edge_normals(poly)
    return poly + d * (normals + np.roll(normals, 1, axis=0))


def edge_normals(poly: FloatArray) -> FloatArray:
    """Unit normal of every edge ``i -> i+1``, into the polygon (counter-clockwise from above)."""
    d = np.roll(poly, -1, axis=0) - poly
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.stack([d[:, 1], -d[:, 0]], axis=1)


def point_in_polygon(poly: FloatArray, x: float, z: float) -> bool:
    inside = False
    for i in range(len(poly)):
        (ax, az), (bx, bz) = poly[i - 1], poly[i]
        if (az > z) != (bz > z) and x < ax + (z - az) * (bx - ax) / (bz - az):
            inside = not inside
    return inside


def is_rectilinear(poly: FloatArray, tol: float = 1e-9) -> bool:
    """Every edge of ``poly`` runs along x or along z."""
    d = np.roll(poly, -1, axis=0) - poly
    return bool(np.all(np.min(np.abs(d), axis=1) <= tol))


def trapezoids(poly: FloatArray, along_x: bool) -> list[tuple[float, float, float, float, float, float]]:
    """A simple polygon cut into trapezoids by lines through its vertices.

    With ``along_x`` the cuts are lines of constant z and every trapezoid is
    ``(v0, v1, a0, b0, a1, b1)``: it spans ``v0 <= z <= v1`` and ``a(z) <= x <= b(z)``, with
    ``(a0, b0)`` at ``v0`` and ``(a1, b1)`` at ``v1`` (x and z swapped otherwise). Either width
    may be 0 (a triangle).
    """
    p = np.asarray(poly, dtype=np.float64)
    if not along_x:
        p = p[:, ::-1]
    q = np.roll(p, -1, axis=0)
    levels = np.unique(np.round(p[:, 1], 12))
    out = []
    for v0, v1 in zip(levels[:-1], levels[1:]):
        mid = 0.5 * (v0 + v1)
        hits = []
        for (ax, az), (bx, bz) in zip(p, q):
            if (az > mid) == (bz > mid):
                continue

            def at(v: float, ax: float = ax, az: float = az, bx: float = bx, bz: float = bz) -> float:
                return float(ax + (v - az) * (bx - ax) / (bz - az))

            hits.append((at(mid), at(v0), at(v1)))
        hits.sort()
        for (_, l0, l1), (_, r0, r1) in zip(hits[0::2], hits[1::2]):
            out.append((float(v0), float(v1), l0, r0, l1, r1))
    return out


def max_skew(pieces: list[tuple[float, float, float, float, float, float]]) -> float:
    """Largest sideways run per unit of height of the slanted sides of ``trapezoids``."""
    s = 0.0
    for v0, v1, a0, b0, a1, b1 in pieces:
        s = max(s, abs(a1 - a0) / (v1 - v0), abs(b1 - b0) / (v1 - v0))
    return s

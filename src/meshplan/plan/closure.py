"""Closing rooms where walls were not scanned, and straightening what the scanned floor closes.

Scans miss pieces of wall: near corners (HoloLens meshes round them off), behind furniture, at
doors (a door is a gap in the wall's flat faces) and wherever the sensor did not look. A room is
the free floor between its walls, so where a wall is missing the room is closed along the most
plausible line, the extension of the walls that were scanned:

* a wall end runs on, by at most ``gap_m``, to the first wall line it meets, provided that the
  other wall was scanned near that point (a T junction, or an L corner whose other leg was
  scanned up to it) or runs on to it too (an L corner whose two legs both stop short);
* two pieces of one wall line (the same direction, within ``collinear_m`` of each other across)
  separated by at most ``gap_m`` are joined along their line.

``gap_m`` is a door's width plus what scans miss beside it: the widest gap that is still one
wall pierced by a door rather than an open side of the room. An extension runs no further than
the first wall line it meets, so it never passes a scanned wall.

Where no wall closes a room, its outline follows the scanned floor, which is ragged (furniture
hides the floor along the walls, the sensor's reach ends in a fringe). :func:`straighten` replaces
it by the room's bounding rectangle along the walls' directions when the floor fills most of it.
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon

from ..geometry import FloatArray
from ..walls import FlatWalls

#: Smallest angle (degrees) between a wall end's direction and a wall line it may run into:
#: nearly parallel lines meet far away, and their crossing is no corner.
MIN_MEETING_ANGLE_DEG = 20.0

#: Longer than this a wall end is moved 1 mm past the line it meets, so that the two lines cross
#: and are noded despite rounding (polygonize drops the 1 mm dangles).
NODE_OVERSHOOT_M = 1e-3

#: Largest angle (degrees) between two wall pieces taken as one wall line across a gap: within
#: the alignment's own scatter on a patchy scan; beyond it they are two walls.
COLLINEAR_ANGLE_DEG = 5.0


def end_crossings(tan: FloatArray, nor: FloatArray, off: FloatArray, ends: FloatArray, sign: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Where the wall ends ``ends`` (along each wall's tangent), run on outward (``sign``: -1 the
    low ends, +1 the high ends), cross every wall line ``normal . p = offset``.

    Returns
    -------
    denom, s, ub
        ``(n, n)`` arrays: the cosine between end a's outward direction and line b's normal
        (near 0: parallel), the distance along a's direction to line b (inf or nan when
        parallel), and the crossing's position along b's tangent.
    """
    p = ends[:, None] * tan + off[:, None] * nor  # (n, 2) wall ends
    d = sign * tan  # outward directions
    denom = d @ nor.T  # (n, n): d_a . n_b
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (off[None, :] - p @ nor.T) / denom  # distance along d_a to line b
        x = p[:, None, :] + s[..., None] * d[:, None, :]
    ub = np.einsum("abk,bk->ab", x, tan)
    return denom, s, ub


def close_walls(walls: FlatWalls, index: np.ndarray, corner_m: float, gap_m: float, collinear_m: float) -> tuple[FloatArray, FloatArray, list[LineString]]:
    """Extended spans of the walls in ``index`` and the bridges joining pieces of one line.

    Parameters
    ----------
    walls, index
        The flat walls and the rows of one story.
    corner_m
        How far a scanned wall is taken to reach beyond its scanned ends (corners rounded off).
    gap_m
        Longest unscanned piece of wall that is closed (a door's width and what scans miss
        beside it).
    collinear_m
        Two wall pieces whose lines lie this close across are one wall (plaster, scan noise).

    Returns
    -------
    u_lo, u_hi
        The extended spans along each wall's tangent.
    bridges
        Segments closing the gaps between collinear pieces.
    """
    u_lo = walls.u_min[index].copy()
    u_hi = walls.u_max[index].copy()
    n = len(index)
    if n < 2:
        return u_lo, u_hi, []
    tan, nor, off = walls.tangent[index], walls.normal[index], walls.offset[index]
    lo, hi = walls.u_min[index], walls.u_max[index]
    best, target, far_end = {}, {}, {}
    for sign, ends in ((-1.0, lo), (1.0, hi)):
        denom, s, ub = end_crossings(tan, nor, off, ends, sign)
        outside = np.maximum(lo[None, :] - ub, ub - hi[None, :])  # beyond b's scanned span
        crossing = (np.abs(denom) >= np.sin(np.radians(MIN_MEETING_ANGLE_DEG))) & (s >= -1e-9) & (s <= gap_m)
        # a run to a wall scanned (nearly) that far: a corner rounded off (up to corner_m), a
        # door or a missed piece of wall (up to gap_m)
        ok = crossing & ((outside <= corner_m) | (s <= corner_m) & (outside <= corner_m))
        # or an L corner whose two legs both stop short (each runs on to the other's line;
        # checked to be mutual below)
        leg = crossing & (outside > corner_m) & (outside <= gap_m)
        np.fill_diagonal(ok, False)
        np.fill_diagonal(leg, False)
        cand = np.where(ok | leg, s, np.inf)
        t = np.argmin(cand, axis=1)
        rows = np.arange(n)
        best[sign] = np.where(np.isfinite(cand[rows, t]), cand[rows, t], np.inf)
        target[sign] = np.where(np.isfinite(best[sign]), t, -1)
        # which end of the target the crossing lies beyond (+1: its high end), for the legs
        far_end[sign] = np.where(leg[rows, t], np.sign(ub[rows, t] - 0.5 * (lo[t] + hi[t])), 0.0)
    for sign in (-1.0, 1.0):
        hit = np.isfinite(best[sign])
        for a in np.flatnonzero(hit & (far_end[sign] != 0)):
            b, e = target[sign][a], far_end[sign][a]
            if target[e][b] != a:  # the other leg runs elsewhere: no corner here
                hit[a] = False
        if sign < 0:
            u_lo[hit] -= best[sign][hit] + NODE_OVERSHOOT_M
        else:
            u_hi[hit] += best[sign][hit] + NODE_OVERSHOOT_M
    bridges = _collinear_bridges(tan, nor, off, u_lo, u_hi, gap_m, collinear_m)
    return u_lo, u_hi, bridges


def _collinear_bridges(tan, nor, off, u_lo, u_hi, gap_m: float, collinear_m: float) -> list[LineString]:
    """Segments joining the facing ends of collinear wall pieces at most ``gap_m`` apart."""
    n = len(off)
    cos = nor @ nor.T
    same = np.abs(cos) >= np.cos(np.radians(COLLINEAR_ANGLE_DEG))
    # offsets on a common normal (a piece seen from the other side has the opposite normal)
    flip = np.sign(cos)
    across = np.abs(off[:, None] - flip * off[None, :])
    # positions along a's tangent of b's span (the tangent flips with the normal)
    b_lo = np.where(flip > 0, u_lo[None, :], -u_hi[None, :])
    gap = b_lo - u_hi[:, None]  # b starts after a ends
    ok = same & (across <= collinear_m) & (gap > 0) & (gap <= gap_m)
    np.fill_diagonal(ok, False)
    out = []
    for a in range(n):
        cand = np.flatnonzero(ok[a])
        if not len(cand):
            continue
        b = cand[np.argmin(gap[a, cand])]  # the next piece along the line only
        pa = u_hi[a] * tan[a] + off[a] * nor[a]
        pb = b_lo[a, b] * tan[a] + flip[a, b] * off[b] * nor[a]
        out.append(LineString([pa - NODE_OVERSHOOT_M * tan[a], pb + NODE_OVERSHOOT_M * tan[a]]))
    return out


def straighten(piece: Polygon, others, fit_m: float, smooth_m: float) -> Polygon:
    """``piece`` (a room closed by the scanned floor) as its bounding rectangle along the
    plan's axes, which are the walls' main directions, less ``others`` (what lies beyond the
    walls around it), when the rectangle's outline lies within ``fit_m`` of the piece's (their
    Hausdorff distance); else
    ``piece`` smoothed (:func:`smooth`, over ``smooth_m``). The rotated bounding rectangle is
    tried too (walls drift off the axes in long scans) and the smaller one that fits kept.

    The rectangle replaces the ragged edge of the scanned floor by the straight lines of its
    extreme reach; ``fit_m`` bounds how far it reaches where no floor was seen.
    """
    best = piece
    core = smooth(piece, smooth_m)  # spikes of the fringe set no rectangle's side
    for rect in (shapely.envelope(core), shapely.oriented_envelope(core)):
        if others is not None and not others.is_empty:
            rect = rect.difference(others)
        parts = [p for p in shapely.get_parts(rect) if isinstance(p, Polygon)]
        if not parts:
            continue
        rect = max(parts, key=lambda p: p.intersection(piece).area)
        if rect.area > 0 and shapely.hausdorff_distance(rect.exterior, piece.exterior) <= fit_m and (best is piece or rect.area < best.area):
            best = Polygon(rect.exterior)
    if best is piece:
        best = core
    return best


def smooth(piece: Polygon, radius: float) -> Polygon:
    """``piece`` without the notches and spikes narrower than ``2 * radius`` (a closing, then
    an opening, with a square: the ragged fringe of a scanned floor goes, its straight runs
    and right-angled corners stay)."""
    if radius <= 0:
        return piece
    with np.errstate(divide="ignore", invalid="ignore"):
        out = piece.buffer(radius, join_style="mitre").buffer(-2 * radius, join_style="mitre").buffer(radius, join_style="mitre")
    parts = [p for p in shapely.get_parts(out) if isinstance(p, Polygon) and p.area > 0]
    if not parts:
        return piece
    return Polygon(max(parts, key=lambda p: p.area).exterior).simplify(0.01)

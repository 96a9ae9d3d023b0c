"""Closing rooms where walls were not scanned, and straightening what the scanned floor closes.

Scans miss pieces of wall: near corners (HoloLens meshes round them off), behind furniture, at
doors (a door is a gap in the wall's flat faces) and wherever the sensor did not look. A room is
the free floor between its walls, so where a wall is missing the room is closed along the most
plausible line, the extension of the walls that were scanned:

* a wall end runs on, by at most ``gap_m``, to the first wall line it meets, provided that the
  other wall was scanned near that point (a T junction, or an L corner whose other leg was
  scanned up to it) or runs on to it too (an L corner whose two legs both stop short);
* two pieces of one wall line (the same direction, within ``collinear_m`` of each other across)
  separated by at most ``gap_m`` are joined along their line;
* farther than ``gap_m``, where the other face of the same wall was scanned along the whole
  run (a face turned away within :data:`WALL_BODY_M` behind it, :func:`back_reach`): furniture
  against a wall hides its face on one side only, and a wall's two faces run together, so the
  face hidden on this side runs on, to the first wall line it meets or the next piece of its
  own line, as far as its other face does.

``gap_m`` is a door's width plus what scans miss beside it: the widest gap that is still one
wall pierced by a door rather than an open side of the room. An extension runs no further than
the first wall line it meets, so it never passes a scanned wall.

Where no wall closes a room, its outline follows the scanned floor, which is ragged (furniture
hides the floor along the walls, the sensor's reach ends in a fringe). :func:`straighten` replaces
it by the room's bounding rectangle along the walls' directions when the floor fills most of it.
"""

from __future__ import annotations

from collections.abc import Callable

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

#: A wall end past the line of a turned wall by at most this (m) meets it there (the two faces'
#: ends overlap at a corner by the scan's noise, 2-3 cm each) and is trimmed back to it.
CORNER_OVERSHOOT_M = 0.05

#: A wall end closer than this (m) to another wall line meets it (a corner, a T junction);
#: farther, it is free: a partition ending in the room or short of the edge of the scan.
FREE_END_M = 0.02

#: Beyond a door's width, a wall end runs on to the next wall or the edge of the scan only when
#: the wall was scanned over at least this share of the length it would then have: a partition
#: a third of which was seen (the rest hidden by a stair, furniture or the sensor's reach) is
#: still the likeliest reading; a short piece (a jamb, a pillar, a counter's end) implies none.
PARTITION_SEEN_SHARE = 1.0 / 3.0

#: Beyond a door's width, a wall end runs on only where the floor was seen along at most this
#: share of the run: a partition that continued would stand on that floor and hide it from one
#: side or the other (half, since the floor beside a wall reaches into the cells under it).
RUN_FLOOR_SHARE = 0.5

#: Numeric tolerance (m) of the positions compared along and across a wall (rounding only).
ROUNDING_M = 1e-9

#: Largest angle (degrees) between two wall pieces taken as one wall line across a gap: within
#: the alignment's own scatter on a patchy scan; beyond it they are two walls.
COLLINEAR_ANGLE_DEG = 5.0

#: Thickest wall body (m) between two faces turned away from each other that are taken for the
#: two faces of one wall (:func:`back_reach`): a 20 cm partition plus plaster and the scan's
#: noise. Two such faces cannot be the sides of a space (a space lies in front of its faces),
#: and no cupboard or room fits in 25 cm behind a face.
WALL_BODY_M = 0.25


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

    Notes
    -----
    Beyond ``gap_m``, an end runs on only along the other face of its own wall
    (:func:`back_reach`), to the first wall line it meets there (scanned near the crossing, as
    within ``gap_m``), and not past the next piece of its own line: that gap is bridged instead.
    """
    u_lo = walls.u_min[index].copy()
    u_hi = walls.u_max[index].copy()
    n = len(index)
    if n < 2:
        return u_lo, u_hi, []
    tan, nor, off = walls.tangent[index], walls.normal[index], walls.offset[index]
    lo, hi = walls.u_min[index], walls.u_max[index]
    best, target, far_end, backed = {}, {}, {}, {}
    met_lo, met_hi = _ends_met(tan, nor, off, lo, hi)
    for sign, ends in ((-1.0, lo), (1.0, hi)):
        denom, s, ub = end_crossings(tan, nor, off, ends, sign)
        outside = np.maximum(lo[None, :] - ub, ub - hi[None, :])  # beyond b's scanned span
        # a wall whose end meets another wall's face reaches no further there: the crossing
        # beyond that end would lie past the face, inside or behind the wall it meets
        reached = np.where(ub < lo[None, :], met_lo[None, :], np.where(ub > hi[None, :], met_hi[None, :], False))
        outside = np.where(reached & (outside > FREE_END_M), np.inf, outside)
        # a line the end has passed by the scan's noise is met too (CORNER_OVERSHOOT_M): the end
        # is trimmed back to it, and does not run on across the room to the next line (an
        # alcove's side wall, 2 cm past the alcove's back wall, drawn across the alcove's mouth)
        meets = (np.abs(denom) >= np.sin(np.radians(MIN_MEETING_ANGLE_DEG))) & (s >= -CORNER_OVERSHOOT_M)
        crossing = meets & (s <= gap_m)
        # beyond gap_m: along the other face of the wall, and short of the next piece of its line
        backed[sign] = back_reach(tan, nor, off, lo, hi, sign, corner_m)
        run = np.minimum(backed[sign], _next_in_line(tan, nor, off, lo, hi, sign, collinear_m))
        crossing |= meets & (s <= run[:, None])
        # a run to a wall scanned (nearly) that far: a corner rounded off (up to corner_m), a
        # door or a missed piece of wall (up to gap_m, or along the wall's other face)
        ok = crossing & ((outside <= corner_m) | (s <= corner_m) & (outside <= corner_m))
        # or an L corner whose two legs both stop short (each runs on to the other's line;
        # checked to be mutual below)
        leg = crossing & (outside > corner_m) & (outside <= gap_m)
        np.fill_diagonal(ok, False)
        np.fill_diagonal(leg, False)
        cand = np.where(ok | leg, s, np.inf)
        t = np.argmin(np.abs(cand), axis=1)  # the nearest line, passed or ahead
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
    bridges = _collinear_bridges(tan, nor, off, u_lo, u_hi, gap_m, collinear_m, backed[1.0] - (u_hi - hi))
    return u_lo, u_hi, bridges


def _ends_met(tan: FloatArray, nor: FloatArray, off: FloatArray, lo: FloatArray, hi: FloatArray) -> tuple[np.ndarray, np.ndarray]:
    """Whether each wall's low and high end meets another wall's face: lies within
    :data:`FREE_END_M` of the scanned segment of a wall turned from it by at least
    :data:`MIN_MEETING_ANGLE_DEG` (a T junction, or a corner both walls were scanned into)."""
    n = len(off)
    a = lo[:, None] * tan + off[:, None] * nor  # (n, 2) segment starts
    b = hi[:, None] * tan + off[:, None] * nor
    turned = np.abs(nor @ nor.T) <= np.cos(np.radians(MIN_MEETING_ANGLE_DEG))
    np.fill_diagonal(turned, False)
    out = []
    for p in (a, b):
        # distance of each end (rows) to each segment (columns)
        d = b - a
        t = np.clip(np.einsum("abk,bk->ab", p[:, None, :] - a[None, :, :], d) / np.maximum(np.einsum("bk,bk->b", d, d), ROUNDING_M), 0.0, 1.0)
        near = np.linalg.norm(p[:, None, :] - (a[None, :, :] + t[..., None] * d[None, :, :]), axis=2) <= FREE_END_M
        out.append(np.any(turned & near, axis=1) if n else np.zeros(0, dtype=bool))
    return out[0], out[1]


def back_reach(tan: FloatArray, nor: FloatArray, off: FloatArray, lo: FloatArray, hi: FloatArray, sign: float, corner_m: float) -> FloatArray:
    """How far (m) beyond each wall's end (``sign``: -1 its low end ``lo``, +1 its high end
    ``hi``, along its tangent ``tan``) the other face of the same wall was scanned: the farthest
    reach past that end of a face turned away from it (normals within
    :data:`COLLINEAR_ANGLE_DEG` of opposite), behind it by at most :data:`WALL_BODY_M` at both
    of its ends, whose span covers the end, plus ``corner_m`` (the other face's own end is
    rounded off at its corner too); 0 where there is none.

    A wall's two faces run together: where furniture against it hid one face, the face scanned
    from the other side shows where the wall goes on.
    """
    n = len(off)
    out = np.zeros(n)
    if n < 2:
        return out
    away = nor @ nor.T <= -np.cos(np.radians(COLLINEAR_ANGLE_DEG))
    np.fill_diagonal(away, False)
    if not away.any():
        return out
    ends_b = np.stack([lo[:, None] * tan + off[:, None] * nor, hi[:, None] * tan + off[:, None] * nor], axis=1)  # (n, 2, 2)
    # depth of b's two ends behind a's face, and their positions along a's tangent
    depth = off[:, None, None] - np.einsum("ak,bek->abe", nor, ends_b)
    along = np.einsum("ak,bek->abe", tan, ends_b)
    b_lo, b_hi = along.min(axis=2), along.max(axis=2)
    end = hi if sign > 0 else lo
    behind = away & np.all((depth >= -ROUNDING_M) & (depth <= WALL_BODY_M), axis=2)
    covers = behind & (b_lo <= end[:, None] + ROUNDING_M) & (b_hi >= end[:, None] - ROUNDING_M)
    reach = np.where(covers, (b_hi - end[:, None]) if sign > 0 else (end[:, None] - b_lo), -np.inf).max(axis=1)
    return np.where(np.isfinite(reach), np.maximum(reach, 0.0) + corner_m, 0.0)


def _next_in_line(tan: FloatArray, nor: FloatArray, off: FloatArray, lo: FloatArray, hi: FloatArray, sign: float, collinear_m: float) -> FloatArray:
    """Distance (m) from each wall's end (``sign`` as in :func:`back_reach`) to the nearest end
    of the next piece of its own line ahead (the same facing within
    :data:`COLLINEAR_ANGLE_DEG`, within ``collinear_m`` across); inf where there is none."""
    cos = nor @ nor.T
    same = cos >= np.cos(np.radians(COLLINEAR_ANGLE_DEG))
    np.fill_diagonal(same, False)
    across = np.abs(off[:, None] - off[None, :])
    end = hi if sign > 0 else lo
    near = lo[None, :] if sign > 0 else hi[None, :]  # b's end facing a's end (same facing: same tangent)
    ahead = sign * (near - end[:, None])
    ok = same & (across <= collinear_m) & (ahead > 0)
    return np.where(ok, ahead, np.inf).min(axis=1) if len(off) else np.zeros(0)


def _collinear_bridges(tan, nor, off, u_lo, u_hi, gap_m: float, collinear_m: float, backed: FloatArray | None = None) -> list[LineString]:
    """Segments joining the facing ends of collinear wall pieces at most ``gap_m`` apart, or,
    beyond ``gap_m``, at most ``backed`` (per wall: how far the other face of its wall runs on
    past its high end, :func:`back_reach`)."""
    n = len(off)
    cos = nor @ nor.T
    same = np.abs(cos) >= np.cos(np.radians(COLLINEAR_ANGLE_DEG))
    # offsets on a common normal (a piece seen from the other side has the opposite normal)
    flip = np.sign(cos)
    across = np.abs(off[:, None] - flip * off[None, :])
    # positions along a's tangent of b's span (the tangent flips with the normal)
    b_lo = np.where(flip > 0, u_lo[None, :], -u_hi[None, :])
    gap = b_lo - u_hi[:, None]  # b starts after a ends
    reach = np.full(n, gap_m) if backed is None else np.maximum(gap_m, backed)
    ok = same & (across <= collinear_m) & (gap > 0) & (gap <= reach[:, None])
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


def straighten(piece: Polygon, others, fit_m: float, smooth_m: float, hold=None) -> Polygon:
    """``piece`` (a room closed by the scanned floor) as its bounding rectangle along the
    plan's axes, which are the walls' main directions, less ``others`` (what lies beyond the
    walls around it), when the rectangle's outline lies within ``fit_m`` of the piece's (their
    Hausdorff distance); else
    ``piece`` smoothed (:func:`smooth`, over ``smooth_m``). The rotated bounding rectangle is
    tried too (walls drift off the axes in long scans) and the smaller one that fits kept.

    The rectangle replaces the ragged edge of the scanned floor by straight lines, each side
    moved in from the floor's extreme reach to the middle of its fringe (where the floor covers
    half the side, :func:`_sides_on_the_floor`); ``fit_m`` bounds how far it reaches where no
    floor was seen. Within ``hold`` (the strip along the walls' lines) the smoothed floor the
    rectangle leaves out stays: a wall the floor was scanned up to may run at an angle to the
    rectangle's sides, and a room's outline holds to its walls (which the energy model pairs
    across).
    """
    best = piece
    core = smooth(piece, smooth_m)  # spikes of the fringe set no rectangle's side
    for rect in (shapely.envelope(core), shapely.oriented_envelope(core)):
        rect = _sides_on_the_floor(rect, core, fit_m)
        if others is not None and not others.is_empty:
            rect = rect.difference(others)
        parts = [p for p in shapely.get_parts(rect) if isinstance(p, Polygon)]
        if not parts:
            continue
        rect = max(parts, key=lambda p: p.intersection(piece).area)
        if rect.area > 0 and shapely.hausdorff_distance(rect.exterior, piece.exterior) <= fit_m and (best is piece or rect.area < best.area):
            best = Polygon(rect.exterior)
    if best is piece:
        return core
    if hold is not None:
        best = _held(best, core, hold, others)
    return best


def _held(rect: Polygon, core: Polygon, hold, others) -> Polygon:
    """``rect`` with what of ``core`` lies in ``hold`` outside it (less ``others``), as one
    polygon (see :func:`straighten`)."""
    extra = core.intersection(hold).difference(rect)
    if others is not None and not others.is_empty:
        extra = extra.difference(others)
    if extra.is_empty or extra.area <= 0:
        return rect
    merged = shapely.union_all([rect, extra.buffer(JOIN_M, join_style="mitre")]).buffer(-JOIN_M, join_style="mitre")
    parts = [p for p in shapely.get_parts(merged) if isinstance(p, Polygon) and p.area > 0]
    if not parts:
        return rect
    return Polygon(max(parts, key=lambda p: p.intersection(rect).area).exterior)


#: Pieces of floor added to a straightened room are grown by this (m) and the union shrunk back,
#: so that pieces meeting the rectangle along an edge join it (0.1 mm: below any drawing's
#: resolution, above the rounding of the coordinates).
JOIN_M = 1e-4


#: Step (m) by which a side of a straightened room is moved in from the floor's extreme reach:
#: finer than the fringe of a scan (5-10 cm), coarser than rounding.
SIDE_STEP_M = 0.01

#: A side of a straightened room stands where the scanned floor covers at least this share of
#: its length: the middle of the fringe, not its outermost tooth (a side set on the floor's
#: extreme reach takes in every tooth of the fringe, and past a missing wall the floor runs on
#: in teeth into the next room), nor its innermost notch.
SIDE_COVER_SHARE = 0.5


def _sides_on_the_floor(rect: Polygon, core: Polygon, limit_m: float) -> Polygon:
    """``rect`` (a rectangle round ``core``) with each side moved in, by at most ``limit_m``,
    to the first line along which ``core`` covers :data:`SIDE_COVER_SHARE` of the side."""
    if not isinstance(rect, Polygon) or limit_m <= 0:
        return rect
    xy = np.asarray(rect.exterior.coords)[:4]
    if len(xy) < 4:
        return rect
    a, b, d = xy[0], xy[1] - xy[0], xy[3] - xy[0]
    la, ld = float(np.hypot(*b)), float(np.hypot(*d))
    if la <= 2 * SIDE_STEP_M or ld <= 2 * SIDE_STEP_M:
        return rect
    eb, ed = b / la, d / ld
    steps = np.arange(0.0, min(limit_m, 0.45 * min(la, ld)) + 1e-9, SIDE_STEP_M)
    # for each side (its first corner, the way in, its direction, its length): its line moved
    # in by each step, across the whole rectangle
    cut = []
    for base, e_move, e_line, span in ((a, ed, eb, la), (a + ld * ed, -ed, eb, la), (a, eb, ed, ld), (a + la * eb, -eb, ed, ld)):
        starts = base[None, :] + steps[:, None] * e_move[None, :]
        lines = shapely.linestrings(np.stack([starts, starts + span * e_line[None, :]], axis=1))
        cover = shapely.length(shapely.intersection(lines, core)) / span
        ok = np.flatnonzero(cover >= SIDE_COVER_SHARE)
        cut.append(float(steps[ok[0]]) if len(ok) else 0.0)
    lo_d, hi_d, lo_b, hi_b = cut[0], ld - cut[1], cut[2], la - cut[3]
    corners = [a + lo_b * eb + lo_d * ed, a + hi_b * eb + lo_d * ed, a + hi_b * eb + hi_d * ed, a + lo_b * eb + hi_d * ed]
    return Polygon(corners)


#: Shortest stretch (m) of a wall that a room must come near for the room to be carried up to
#: it: a jamb, a pillar or a wall's corner piece seen beside the room is no side of it.
MIN_REACH_SPAN_M = 0.5

#: How far (m) inside the band next to a wall another wall line may pass without stopping the
#: room from being carried across it: the rounding of lines that meet at the wall.
REACH_CROSSING_M = 0.01

#: Two walls' lines meet in a corner when an end of each lies within this distance (m) of the
#: other's: the ends of lines closed onto each other, which meet to rounding.
CORNER_ENDS_M = 0.1

#: How far along either wall of a corner a room carried up to both walls may stop short of the
#: corner and still be carried into it, in multiples of ``wall_reach_m`` (1.6 m by default): a
#: corner hidden by furniture along both walls (a wardrobe, an L of desks, each up to
#: ``wall_reach_m`` deep, so the corner they hide runs twice that along the walls at most); a
#: room that stops farther short has a notch there, not furniture.
CORNER_REACH_TIMES = 2.0


def reach_walls(shape: Polygon, walls: list[LineString], normals: FloatArray, beyond, reach_m: float) -> Polygon:
    """``shape`` (a room the scanned floor closes) carried up to every wall in ``walls`` (as
    scanned, or continued across what the scan missed) that it stops short of by at most
    ``reach_m``.

    Furniture stands along walls and hides the floor under it, so a room closed by its floor
    ends that far inside a wall that was scanned; the room is the floor up to the wall. For each
    wall, the band between the wall and ``reach_m`` inside it, over the stretch of the wall the
    room comes within ``reach_m`` of, joins the room, less ``beyond`` (the other rooms). A band
    that another wall line crosses (a partition between the room and the wall) is left out, as
    is a stretch shorter than :data:`MIN_REACH_SPAN_M`. A wall face is reached only from its
    front, the side its normal (``normals``, ``(W, 2)``: into the room it was scanned from)
    points to: the face of a wall seen from the next room lies behind the wall's thickness, and
    a room whose own face of that wall was not scanned stops where its floor does, at that face.
    """
    if reach_m <= 0 or not walls:
        return shape
    grown = shape
    centre = np.asarray(shape.representative_point().coords[0])
    tree = shapely.STRtree(walls)  # the walls that may cross a band, from one tree
    reached: dict[int, tuple[float, float, float]] = {}  # wall: (u0, u1, length) of its band
    for k, wall in enumerate(walls):
        a, b = np.asarray(wall.coords[0], float), np.asarray(wall.coords[-1], float)
        length = float(np.hypot(*(b - a)))
        if length < MIN_REACH_SPAN_M:
            continue
        t = (b - a) / length
        n = np.asarray(normals[k], float)
        # a room behind the face whose floor crosses its line (scan noise, a fringe) would meet
        # the band and be carried beyond its own wall
        if (centre - a) @ n <= 0:
            continue
        inward = n * reach_m
        band = Polygon([a, b, b + inward, a + inward])
        near = shape.intersection(band)
        if near.is_empty or near.area <= 0:
            continue
        u = (np.asarray(shapely.get_coordinates(near)) - a) @ t
        u0, u1 = max(0.0, float(u.min())), min(length, float(u.max()))
        if u1 - u0 < MIN_REACH_SPAN_M:
            continue
        p0, p1 = a + u0 * t, a + u1 * t
        fill = Polygon([p0, p1, p1 + inward, p0 + inward])
        core = fill.buffer(-REACH_CROSSING_M, join_style="mitre")
        if any(j != k for j in tree.query(core, predicate="intersects")):
            continue
        if beyond is not None and not beyond.is_empty:
            fill = fill.difference(beyond)
        grown = grown.union(fill)
        reached[k] = (u0, u1, length)
    for k, j, fill in _corner_fills(walls, normals, reached, reach_m * CORNER_REACH_TIMES):
        core = fill.buffer(-REACH_CROSSING_M, join_style="mitre")
        if any(w not in (k, j) for w in tree.query(core, predicate="intersects")):
            continue  # another wall line crosses the corner: the room does not run into it
        if beyond is not None and not beyond.is_empty:
            fill = fill.difference(beyond)
        grown = grown.union(fill)
    parts = [p for p in shapely.get_parts(grown) if isinstance(p, Polygon) and p.area > 0]
    if not parts:
        return shape
    return Polygon(max(parts, key=lambda p: p.intersection(shape).area).exterior)


def _corner_fills(
    walls: list[LineString], normals: FloatArray, reached: dict[int, tuple[float, float, float]], longest_m: float
) -> list[tuple[int, int, Polygon]]:
    """The corners a room carried up to two walls stops short of (see :func:`reach_walls`):
    for each two walls in ``reached`` (their bands' stretch ``u0``-``u1`` of their ``length``)
    whose lines meet in a corner, end to end and not in line, with each in front of the other
    (``normals``: a room's corner, not the outside of one it wraps round): the two walls and
    the rectangle (a parallelogram at an oblique corner) between the corner and the ends of both
    bands, where neither stops more than ``longest_m`` short of it."""
    ends = {k: (np.asarray(walls[k].coords[0], float), np.asarray(walls[k].coords[-1], float)) for k in reached}
    out = []
    keys = sorted(reached)
    for i, k in enumerate(keys):
        for j in keys[i + 1 :]:
            for ek, pk in enumerate(ends[k]):
                for ej, pj in enumerate(ends[j]):
                    if np.hypot(*(pk - pj)) > CORNER_ENDS_M:
                        continue
                    # from the corner along each wall, and how far its band stops short of it
                    dk = ends[k][1 - ek] - pk
                    dj = ends[j][1 - ej] - pj
                    dk, dj = dk / np.hypot(*dk), dj / np.hypot(*dj)
                    if abs(float(dk @ dj)) > np.cos(np.radians(MIN_MEETING_ANGLE_DEG)):
                        continue  # in line, or nearly: no corner
                    if float(dj @ normals[k]) <= 0 or float(dk @ normals[j]) <= 0:
                        continue  # the corner's inside lies behind a wall's face
                    u0, u1, length = reached[k]
                    gk = u0 if ek == 0 else length - u1
                    u0, u1, length = reached[j]
                    gj = u0 if ej == 0 else length - u1
                    if min(gk, gj) <= REACH_CROSSING_M or max(gk, gj) > longest_m:
                        continue  # the bands meet already, or the room stops too far short
                    c = 0.5 * (pk + pj)
                    out.append((k, j, Polygon([c, c + gk * dk, c + gk * dk + gj * dj, c + gj * dj])))
    return out


def smooth(piece: Polygon, radius: float) -> Polygon:
    """``piece`` without the notches and spikes narrower than ``2 * radius`` (a closing, then
    an opening, with a square: the ragged fringe of a scanned floor goes, its straight runs
    and right-angled corners stay).

    The result is kept inside the piece's convex hull, where a closing and an opening with a
    square stay: mitred offsets of a jagged outline are not those of a square, and at its sharp
    corners they reach out by up to the mitre limit (5 radii), which would set a rectangle's
    side beyond anything scanned."""
    if radius <= 0:
        return piece
    with np.errstate(divide="ignore", invalid="ignore"):
        out = piece.buffer(radius, join_style="mitre").buffer(-2 * radius, join_style="mitre").buffer(radius, join_style="mitre")
        out = out.intersection(piece.convex_hull)
    parts = [p for p in shapely.get_parts(out) if isinstance(p, Polygon) and p.area > 0]
    if not parts:
        return piece
    return Polygon(max(parts, key=lambda p: p.area).exterior).simplify(0.01)


def run_to_boundary(
    walls: FlatWalls,
    index: np.ndarray,
    u_lo: FloatArray,
    u_hi: FloatArray,
    boundary,
    gap_m: float,
    reach_m: float,
    floor_share: Callable[[FloatArray, FloatArray], float] | None = None,
) -> tuple[FloatArray, FloatArray]:
    """``u_lo`` and ``u_hi`` with every free wall end run on to the first thing it meets, the
    line of another wall or ``boundary`` (the story's outline: where the scan ends), when that
    lies within ``reach_m``.

    A partition scanned only part of the way to another wall or to the edge of the scan (the
    rest hidden by the stair beside it, or out of the sensor's view) still divides the two
    spaces on either side: the room is closed along its extension. Up to ``gap_m`` (a door and
    what scans miss beside it) any free end runs on, as across a door; up to ``reach_m`` (the
    widest mouth between two spaces that are still two rooms) only the end of a partition
    scanned over at least :data:`PARTITION_SEEN_SHARE` of the length it would then have (a jamb,
    a pillar or a counter's end implies no partition across a room), and only where the floor
    was not seen along the run (``floor_share(a, b)``: the share of the segment ``a``-``b`` over
    scanned floor, at most :data:`RUN_FLOOR_SHARE`): floor seen where the partition would
    stand shows that it stops (an open side, an alcove's mouth); floor unseen leaves the
    partition the likeliest reading. A door's gap shows floor, so the runs up to ``gap_m``
    are not asked. An end is free when no other wall line passes within :data:`FREE_END_M` of it
    (after :func:`close_walls`, an end that met a wall overshoots it by
    :data:`NODE_OVERSHOOT_M`). The walls are the spans given; an end's run does not see the
    runs of the others.
    """
    span = u_hi - u_lo  # as scanned and closed, before any run
    u_lo, u_hi = u_lo.copy(), u_hi.copy()
    n = len(index)
    if boundary is None or not n:
        return u_lo, u_hi
    tan, nor, off = walls.tangent[index], walls.normal[index], walls.offset[index]
    lines = np.array([LineString([u_lo[k] * tan[k] + off[k] * nor[k], u_hi[k] * tan[k] + off[k] * nor[k]]) for k in range(n)], dtype=object)
    ring = shapely.union_all([shapely.boundary(p) for p in shapely.get_parts(boundary)])
    # the other walls near an end or along a run, from one tree (not a union of the others per wall)
    tree = shapely.STRtree(lines)
    for k in range(n):
        for sign in (-1.0, 1.0):
            u = u_lo[k] if sign < 0 else u_hi[k]
            end = u * tan[k] + off[k] * nor[k]
            near = tree.query(shapely.Point(end), predicate="dwithin", distance=FREE_END_M)
            if np.any(near != k):
                continue
            ray = LineString([end, end + sign * reach_m * tan[k]])
            crossed = tree.query(ray, predicate="intersects")
            hits = shapely.intersection(ray, np.append(lines[crossed[crossed != k]], ring))
            hit = shapely.union_all(shapely.extract_unique_points(hits))
            if hit.is_empty:
                continue
            s = min(float(np.dot(np.asarray(p.coords[0]) - end, sign * tan[k])) for p in shapely.get_parts(shapely.extract_unique_points(hit)))
            if s <= FREE_END_M or s > gap_m and span[k] < PARTITION_SEEN_SHARE * (span[k] + s):
                continue
            if s > gap_m and floor_share is not None and floor_share(end, end + s * sign * tan[k]) > RUN_FLOOR_SHARE:
                continue
            if sign < 0:
                u_lo[k] -= s + NODE_OVERSHOOT_M
            else:
                u_hi[k] += s + NODE_OVERSHOOT_M
    return u_lo, u_hi

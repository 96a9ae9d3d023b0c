"""Story plans of the synthetic presets.

A plan is drawn in a canonical orientation (the building spans ``[0, width] x [0, depth]`` between
the inner faces of its exterior walls); :func:`meshplan.synthetic.layout.make_building` mirrors
and transposes it at random. Rooms are rectangles (the living room of an apartment may be
L-shaped) separated by gaps as thick as the partitions between them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..geometry import FloatArray
from .polygons import ccw, rect_polygon, union_polygon

#: Smallest width or depth of a generated room (corridors excepted), metres.
MIN_ROOM_M = 2.2
#: Clear floor kept in front of the stair, on the side of the stairwell door.
STAIR_APPROACH_M = 1.0
#: Clearance between the stair opening and the stairwell walls.
STAIR_WALL_GAP_M = 0.15
#: Target riser height of the stairs.
RISE_M = 0.18


@dataclass
class Plan:
    """One story as drawn by a preset, before walls and openings are derived."""

    rooms: list[tuple[str, str, FloatArray]] = field(default_factory=list)  # label, kind, polygon
    doors: list[tuple[str, str]] = field(default_factory=list)
    entrance: str | None = None
    windows: dict[str, tuple[int, int]] = field(default_factory=dict)
    stairwell: str | None = None  # room holding a stair up to the next story
    envelope: FloatArray | None = None  # inner outline of the exterior walls, when not the rectangle


# --------------------------------------------------------------------------------------------
# Random helpers


def uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    """A float drawn uniformly in ``[lo, hi]`` (``lo`` when the range is empty)."""
    return float(rng.uniform(lo, hi)) if hi > lo else float(lo)


def _fill(total: float, n: int, lo: float, hi: float, rng: np.random.Generator) -> list[float]:
    """``n`` lengths in ``[lo, hi]`` summing to ``total`` (water-filled random shares)."""
    extra = total - n * lo
    cap = hi - lo
    extra = float(np.clip(extra, 0.0, n * cap))
    share = rng.dirichlet(np.full(n, 3.0)) * extra
    for _ in range(n):
        over = np.maximum(share - cap, 0.0)
        if over.sum() <= 1e-12:
            break
        share = np.minimum(share, cap)
        room = share < cap
        share[room] += over.sum() * (cap - share[room]) / max((cap - share[room]).sum(), 1e-12)
    return list(lo + share)


def _split(lo: float, hi: float, n: int, gap: float, rng: np.random.Generator, min_m: float = MIN_ROOM_M) -> list[tuple[float, float]]:
    """``[lo, hi]`` cut into ``n`` intervals of at least ``min_m`` separated by ``gap``."""
    free = hi - lo - (n - 1) * gap
    lengths = _fill(free, n, min_m, max(free, min_m), rng)
    out, x = [], lo
    for k, length in enumerate(lengths):
        end = hi if k == n - 1 else x + length
        out.append((x, end))
        x = end + gap
    return out


def _max_cells(length: float, gap: float) -> int:
    return int((length + gap) // (MIN_ROOM_M + 0.1 + gap))


# --------------------------------------------------------------------------------------------
# Presets


PlanOut = tuple[list[Plan], list[float], list[float], float, float, tuple[float, float]]


def plan_room(rng: np.random.Generator, angled: bool = False) -> PlanOut:
    w, d = uniform(rng, 3.5, 6.0), uniform(rng, 3.0, 5.0)
    plan = Plan(rooms=[("room", "room", rect_polygon(0, w, 0, d))], entrance="room", windows={"room": (1, 2)})
    ceiling = uniform(rng, 2.4, 3.0)
    if angled:  # drawn after everything else, so that the rest of the room is the same
        poly = angled_rect(0.0, w, 0.0, d, rng, slant=True, chamfer=True)
        plan.rooms = [("room", "room", poly)]
        plan.envelope = poly
    return [plan], [ceiling], [], w, d, (0.28, 0.9)


# --------------------------------------------------------------------------------------------
# Walls off the axes

#: Angle of a slanted wall from the walls along x, degrees (real rooms: bay fronts, plots cut at
#: an angle); it is 90 degrees minus this from the walls along z.
SLANT_DEG = (20.0, 40.0)
#: How far a slanted wall cuts into its room along the wall it starts from, metres.
SLANT_DROP_M = (0.8, 1.6)
#: Length of the 45-degree chamfer across a corner, measured along each of the two walls, metres.
CHAMFER_M = (0.8, 1.4)


def angled_rect(
    x0: float, x1: float, z0: float, z1: float, rng: np.random.Generator, slant: bool = True, chamfer: bool = True
) -> FloatArray:
    """The rectangle ``[x0, x1] x [z0, z1]`` with a slanted wall across its ``(x0, z1)`` corner
    (:data:`SLANT_DEG` off the x walls) and a 45-degree chamfer across its ``(x1, z0)`` corner.

    Both corners must be on the outside of the building (nothing is behind them).
    """
    w, d = x1 - x0, z1 - z0
    pts: list[tuple[float, float]] = [(x0, z0)]
    if chamfer:
        c = uniform(rng, CHAMFER_M[0], min(CHAMFER_M[1], 0.3 * min(w, d)))
        pts += [(x1 - c, z0), (x1, z0 + c)]
    else:
        pts.append((x1, z0))
    pts.append((x1, z1))
    if slant:
        alpha = np.radians(uniform(rng, *SLANT_DEG))
        drop = uniform(rng, SLANT_DROP_M[0], min(SLANT_DROP_M[1], 0.4 * d))
        run = min(drop / np.tan(alpha), 0.5 * w)
        drop = run * np.tan(alpha)
        pts += [(x0 + run, z1), (x0, z1 - drop)]
    else:
        pts.append((x0, z1))
    return ccw(np.array(pts, dtype=np.float64))


def plan_hard(rng: np.random.Generator, angled: bool = True) -> PlanOut:
    """A flat: an (optionally slanted) living room, a kitchen big enough for an island, two
    bedrooms (one chamfered), a bath and a hall joining them."""
    g = uniform(rng, 0.10, 0.15)
    ceiling = uniform(rng, 2.5, 2.9)
    living, kitchen, bed1 = uniform(rng, 3.8, 4.6), uniform(rng, 3.9, 4.5), uniform(rng, 3.2, 4.0)
    top, hall, bottom = uniform(rng, 3.9, 4.4), uniform(rng, 1.5, 1.8), uniform(rng, 3.2, 4.0)
    bath = uniform(rng, 2.2, 2.8)
    xs = living + g
    width = xs + kitchen + g + bed1
    zh0, zh1 = top + g, top + g + hall
    zb = zh1 + g
    depth = zb + bottom
    living_poly = angled_rect(0.0, living, 0.0, depth, rng, slant=True, chamfer=False) if angled else rect_polygon(0, living, 0, depth)
    bed1_poly = (
        angled_rect(xs + kitchen + g, width, 0.0, top, rng, slant=False, chamfer=True)
        if angled else rect_polygon(xs + kitchen + g, width, 0.0, top)
    )
    plan = Plan()
    plan.rooms = [
        ("living", "living", living_poly),
        ("kitchen", "kitchen", rect_polygon(xs, xs + kitchen, 0.0, top)),
        ("bedroom1", "bedroom", bed1_poly),
        ("hall", "hall", rect_polygon(xs, width, zh0, zh1)),
        ("bath", "bath", rect_polygon(xs, xs + bath, zb, depth)),
        ("bedroom2", "bedroom", rect_polygon(xs + bath + g, width, zb, depth)),
    ]
    plan.doors = [("hall", r) for r in ("living", "kitchen", "bedroom1", "bath", "bedroom2")] + [("living", "kitchen")]
    plan.entrance = "hall"
    plan.windows = {"living": (2, 3), "kitchen": (1, 2), "bedroom1": (1, 2), "bedroom2": (1, 2), "bath": (0, 1)}
    # the inner outline of the exterior walls: the flat is convex (its cut corners are convex)
    plan.envelope = _outline(np.concatenate([poly for _, _, poly in plan.rooms]))
    return [plan], [ceiling], [], width, depth, (0.28, 0.9)


def _outline(points: FloatArray) -> FloatArray:
    """The convex hull of ``points``, counter-clockwise seen from above."""
    import shapely

    hull = shapely.MultiPoint([tuple(p) for p in points]).convex_hull
    pts = np.asarray(hull.exterior.coords)[:-1]
    return ccw(pts)


def plan_office(rng: np.random.Generator) -> PlanOut:
    g = uniform(rng, 0.10, 0.15)
    n = int(rng.integers(6, 11))
    n_top = (n + 1) // 2 if n % 2 else n // 2 + 1
    n_bot = n - n_top
    meet_lo, meet_hi = 4.5, 8.0
    lo = max(3.0 * n_top + (n_top - 1) * g, 3.0 * n_bot + meet_lo + n_bot * g)
    hi = min(4.0 * n_top + (n_top - 1) * g, 4.0 * n_bot + meet_hi + n_bot * g)
    length = uniform(rng, lo, hi)
    tops = _fill(length - (n_top - 1) * g, n_top, 3.0, 4.0, rng)
    m_lo = max(meet_lo, length - n_bot * g - 4.0 * n_bot)
    m_hi = min(meet_hi, length - n_bot * g - 3.0 * n_bot)
    meet = uniform(rng, m_lo, m_hi)
    bots = _fill(length - n_bot * g - meet, n_bot, 3.0, 4.0, rng)
    bots = [meet] + bots if rng.random() < 0.5 else bots + [meet]
    dt, db, wc = uniform(rng, 4.0, 5.0), uniform(rng, 4.0, 5.0), uniform(rng, 1.5, 2.0)
    zc0, zc1 = dt + g, dt + g + wc
    zb0, zb1 = zc1 + g, zc1 + g + db
    plan = Plan()
    plan.rooms.append(("corridor", "corridor", rect_polygon(0, length, zc0, zc1)))
    k = 0
    for widths, (z0, z1) in ((tops, (0.0, dt)), (bots, (zb0, zb1))):
        x = 0.0
        for j, w in enumerate(widths):
            x1 = length if j == len(widths) - 1 else x + w
            if widths is bots and w == meet:
                label, kind, win = "meeting", "meeting", (2, 3)
            else:
                k += 1
                label, kind, win = f"office{k}", "office", (1, 1)
            plan.rooms.append((label, kind, rect_polygon(x, x1, z0, z1)))
            plan.doors.append(("corridor", label))
            plan.windows[label] = win
            x = x1 + g
    plan.entrance = "corridor"
    plan.windows["corridor"] = (0, 1)
    return [plan], [uniform(rng, 2.7, 3.0)], [], length, zb1, (0.28, 0.9)


def stair_depth_m(rise_total_m: float, going_m: float, flight_m: float) -> float:
    """Depth of stairwell a U-stair needs (approach, first flight, landing, clearance)."""
    n = max(2, int(round(rise_total_m / RISE_M)))
    n1 = (n + 1) // 2
    return STAIR_APPROACH_M + (n1 - 1) * going_m + flight_m + 0.05 + STAIR_WALL_GAP_M + 0.1


def plan_apartment(rng: np.random.Generator, n_stories: int) -> PlanOut:
    multi = n_stories > 1
    g = uniform(rng, 0.10, 0.15)
    ceilings = [uniform(rng, 2.5, 2.8) for _ in range(n_stories)]
    slabs = [uniform(rng, 0.2, 0.35) for _ in range(n_stories - 1)]
    hall = uniform(rng, 2.0, 2.3)
    width = uniform(rng, 10.0, 12.0) if multi else uniform(rng, 9.0, 12.0)
    well = uniform(rng, 2.3, 2.6) if multi else 0.0
    # the side rooms need at least two cells on the hall's long side
    need = max(well + g + MIN_ROOM_M + 0.1, 2 * MIN_ROOM_M + 0.2 + g) if multi else 2 * MIN_ROOM_M + 0.2 + g
    living = uniform(rng, 3.4, min(5.0, width - g - need - 0.1))
    going, flight = uniform(rng, 0.26, 0.29), uniform(rng, 0.85, 0.95)
    if multi:
        stair = max(stair_depth_m(c + s, going, flight) for c, s in zip(ceilings, slabs))
        top = max(uniform(rng, 2.8, 3.8), stair)
        depth = top + 2 * g + hall + uniform(rng, 2.6, 3.8)
    else:
        depth = uniform(rng, max(7.2, 5.3 + hall + 2 * g), 10.0)
        sides = depth - hall - 2 * g  # shared by the rooms on both sides of the hall
        top = uniform(rng, max(2.6, sides - 4.8), min(4.8, sides - 2.6))
    xs = living + g
    zh0, zh1 = top + g, top + g + hall
    zb = zh1 + g
    top_end = width - (well + g if multi else 0.0)
    kt_max, kb_max = max(1, _max_cells(top_end - xs, g)), max(1, _max_cells(width - xs, g))

    plans = []
    for s in range(n_stories):
        target = int(rng.integers(3 if multi else 4, 6))
        target = min(target, kt_max + kb_max)
        kt = int(rng.integers(max(1, target - kb_max), min(kt_max, target - 1) + 1))
        kb = target - kt
        tops = [(x0, x1, 0.0, top) for x0, x1 in _split(xs, top_end, kt, g, rng)]
        bots = [(x0, x1, zb, depth) for x0, x1 in _split(xs, width, kb, g, rng)]
        cells = tops + bots
        merged = rng.random() < 0.5 and len(cells) >= 4
        rooms: list[tuple[str, str, FloatArray]] = []
        if merged:  # an L-shaped living room taking in the first cell of the far side
            b = bots[0]
            rooms.append(("living", "living", union_polygon([(0, living, 0, depth), (living, b[0], b[2], b[3]), b])))
            cells = [c for c in cells if c is not b]
        else:
            rooms.append(("living", "living", rect_polygon(0, living, 0, depth)))
        labels: dict[int, tuple[str, str]] = {}
        free = list(range(len(cells)))
        if not merged:
            near = [i for i in free if cells[i][0] == xs]
            k = near[int(rng.integers(len(near)))]
            labels[k] = ("kitchen", "kitchen")
            free.remove(k)
        area = {i: (cells[i][1] - cells[i][0]) * (cells[i][3] - cells[i][2]) for i in free}
        by_size = sorted(free, key=lambda i: area[i])
        labels[by_size[0]] = ("bath", "bath")
        rest = by_size[1:][::-1]
        for j, i in enumerate(rest):
            if j < 2:
                labels[i] = (f"bedroom{j + 1}", "bedroom")
            else:
                labels[i] = ("study", "study")
        plan = Plan(rooms=rooms)
        plan.rooms.append(("hall", "hall", rect_polygon(xs, width, zh0, zh1)))
        for i, c in enumerate(cells):
            label, kind = labels[i]
            plan.rooms.append((label, kind, rect_polygon(*c)))
            plan.doors.append(("hall", label))
        if multi:
            plan.rooms.append(("stairwell", "stairwell", rect_polygon(width - well, width, 0.0, top)))
            plan.doors.append(("hall", "stairwell"))
            plan.stairwell = "stairwell" if s < n_stories - 1 else None
        plan.doors.append(("hall", "living"))
        if not merged and rng.random() < 0.5:
            plan.doors.append(("living", "kitchen"))
        plan.entrance = "hall" if s == 0 else None
        plan.windows = {"living": (1, 3), "kitchen": (1, 1), "bath": (0, 1), "study": (1, 1), "hall": (0, 0), "stairwell": (0, 0)}
        plan.windows.update({f"bedroom{j}": (1, 2) for j in (1, 2)})
        if multi:  # room labels unique over the building
            plan.rooms = [(f"s{s}_{lab}", kind, poly) for lab, kind, poly in plan.rooms]
            plan.doors = [(f"s{s}_{a}", f"s{s}_{b}") for a, b in plan.doors]
            plan.entrance = plan.entrance and f"s{s}_{plan.entrance}"
            plan.windows = {f"s{s}_{k}": v for k, v in plan.windows.items()}
            plan.stairwell = plan.stairwell and f"s{s}_{plan.stairwell}"
        plans.append(plan)
    return plans, ceilings, slabs, width, depth, (going, flight)

"""Room shells as planar pieces: floors, ceilings, wall faces, corner bevels, door and window
reveals, and the edges of the slab openings over the stairs (truth frame).

With a bevel ``d`` (HoloLens meshes round every inside corner), floors and ceilings stop ``d``
short of the walls, walls stop ``d`` short of the floor, the ceiling and each convex corner, and
45-degree strips join them; a small triangle closes each three-way corner. The truth walls are
not moved: they still run corner to corner on the wall planes.
"""

from __future__ import annotations

import numpy as np

from ..geometry import FloatArray
from .defects import Hole, Missing
from .layout import Building, Opening, Wall
from .polygons import inset_polygon, is_rectilinear, max_skew, trapezoids
from .tessellate import Piece

_UP = np.array([0.0, 1.0, 0.0])
_X = np.array([1.0, 0.0, 0.0])
_Z = np.array([0.0, 0.0, 1.0])
_SQRT2 = np.sqrt(2.0)


def _v3(p2: FloatArray, y: float = 0.0) -> FloatArray:
    """Plan ``[x, z]`` (point or direction) as a 3D vector at height ``y``."""
    return np.array([p2[0], y, p2[1]], dtype=np.float64)


def _is_rect(poly: FloatArray) -> bool:
    return len(poly) == 4


def shell_pieces(b: Building, bevel_m: float, missing: list[Missing], holes: list[Hole]) -> list[Piece]:
    """Every scanned surface of every room (group = room index).

    Parameters
    ----------
    b
        The building.
    bevel_m
        Width ``d`` of the corner bevels; 0 for sharp corners.
    missing
        Vertical strips removed from walls.
    holes
        Elliptical holes in floors, ceilings and walls.
    """
    d = float(bevel_m)
    pieces: list[Piece] = []
    missing_by_wall: dict[int, list[Missing]] = {}
    for m in missing:
        missing_by_wall.setdefault(m.wall, []).append(m)
    holes_by: dict[tuple[str, int], list[tuple]] = {}
    for h in holes:
        holes_by.setdefault((h.surface, h.index), []).append((h.center[0], h.center[1], h.radii[0], h.radii[1], h.angle_rad))
    floor_cuts: dict[int, list[tuple]] = {}
    for above, (x0, x1, z0, z1) in b.floor_openings:
        floor_cuts.setdefault(above, []).append((x0, x1, z0, z1))
    ceiling_cuts: dict[int, list[tuple]] = {}
    for st in b.stairs:
        ceiling_cuts.setdefault(st.room, []).append(st.opening)

    for r, room in enumerate(b.rooms):
        floor, ceiling = b.stories[room.story]
        height = ceiling - floor
        poly = inset_polygon(room.polygon, d) if d > 0 else room.polygon
        lo, hi = poly.min(axis=0), poly.max(axis=0)
        keep = None if _is_rect(poly) else poly
        for kind, y, normal, cuts in (
            ("floor", floor, _UP, floor_cuts.get(r, [])),
            ("ceiling", ceiling, -_UP, ceiling_cuts.get(r, [])),
        ):
            if not is_rectilinear(poly):
                pieces += _slanted_pieces(poly, kind, y, normal, r, cuts, holes_by.get((kind, r), []))
                continue
            pieces.append(
                Piece(
                    origin=np.array([0.0, y, 0.0]),
                    eu=_X,
                    ev=_Z,
                    normal=normal,
                    u_range=(lo[0], hi[0]),
                    v_range=(lo[1], hi[1]),
                    kind=kind,
                    group=r,
                    cuts=list(cuts),
                    keep=keep,
                    ellipses=list(holes_by.get((kind, r), [])),
                )
            )
        wall_ids = b.room_walls(r)
        for k, wi in enumerate(wall_ids):
            w = b.walls[wi]
            prev = b.walls[wall_ids[k - 1]]
            ops = b.wall_openings(wi)
            strips = [(m.from_m, m.to_m, -1.0, height + 1.0) for m in missing_by_wall.get(wi, [])]
            pieces += _wall_pieces(wi, w, r, floor, height, d, ops, strips, holes_by.get(("wall", wi), []))
            if d > 0:
                pieces += _bevel_pieces(w, prev, r, floor, ceiling, d, ops, strips)
            for o in ops:
                if o.primary:
                    pieces += _reveal_pieces(w, o, r, d)
        for st in b.stairs:
            if st.room == r:
                pieces += _slab_edges(st.opening, ceiling, b.stories[room.story + 1][0], r)
    return pieces


def _slanted_pieces(
    poly: FloatArray, kind: str, y: float, normal: FloatArray, group: int, cuts: list, ellipses: list
) -> list[Piece]:
    """A floor or ceiling whose outline has walls off the axes, as trapezoids between lines through
    its corners (exact edges along every wall). The lines run across the direction in which the
    slanted sides lean least, so that the cells stay nearly square."""
    if cuts:
        raise ValueError("stair openings in rooms with slanted walls are not supported")
    along_x = max_skew(trapezoids(poly, True)) <= max_skew(trapezoids(poly, False))
    eu, ev = (_X, _Z) if along_x else (_Z, _X)
    if along_x:
        holes = list(ellipses)
    else:  # (u, v) = (z, x): a mirror, which turns an ellipse's angle a into pi/2 - a
        holes = [(cz, cx, a, b, np.pi / 2 - ang) for cx, cz, a, b, ang in ellipses]
    return [
        Piece(
            origin=np.array([0.0, y, 0.0]),
            eu=eu,
            ev=ev,
            normal=normal,
            u_range=(a0, b0),
            u_range_top=(a1, b1),
            v_range=(v0, v1),
            kind=kind,
            group=group,
            ellipses=list(holes),
        )
        for v0, v1, a0, b0, a1, b1 in trapezoids(poly, along_x)
    ]


def _wall_pieces(
    wi: int, w: Wall, group: int, floor: float, height: float, d: float, ops: list[Opening], strips: list, ellipses: list
) -> list[Piece]:
    """The wall face, stopped ``d`` short of the floor, the ceiling and its convex corners, with
    its openings cut exactly and its missing strips and holes raggedly."""
    length = w.length
    u0 = d if w.convex_start else 0.0
    u1 = length - d if w.convex_end else length
    cuts = []
    for o in ops:
        bottom = -1.0 if o.kind == "door" else o.bottom - floor
        cuts.append((o.u_m - o.width_m / 2, o.u_m + o.width_m / 2, bottom, o.top - floor))
    return [
        Piece(
            origin=_v3(w.start, floor),
            eu=_v3(w.direction),
            ev=_UP,
            normal=_v3(w.normal),
            u_range=(u0, u1),
            v_range=(d, height - d),
            kind="wall",
            group=group,
            wall=wi,
            cuts=cuts,
            soft_cuts=list(strips),
            ellipses=list(ellipses),
        )
    ]


def _bevel_pieces(w: Wall, prev: Wall, group: int, floor: float, ceiling: float, d: float, ops: list[Opening], strips: list) -> list[Piece]:
    """The floor and ceiling bevels along ``w``, and the vertical bevel and corner triangles at its
    start corner (shared with ``prev``) when that corner is convex."""
    length = w.length
    a, n = _v3(w.direction), _v3(w.normal)
    tw = (d if w.convex_start else 0.0, length - d if w.convex_end else length)
    tf = (d if w.convex_start else -d, length - d if w.convex_end else length + d)
    doors = [(o.u_m - o.width_m / 2, o.u_m + o.width_m / 2, -1.0, 1.0) for o in ops if o.kind == "door"]
    full = [(s[0], s[1], -1.0, 1.0) for s in strips]
    out = [
        Piece(
            origin=_v3(w.start, floor + d),
            eu=a,
            ev=(n - _UP) / _SQRT2,
            normal=(n + _UP) / _SQRT2,
            u_range=tw,
            u_range_top=tf,
            v_range=(0.0, d * _SQRT2),
            kind="bevel",
            group=group,
            soft_cuts=doors + full,
        ),
        Piece(
            origin=_v3(w.start, ceiling - d),
            eu=a,
            ev=(n + _UP) / _SQRT2,
            normal=(n - _UP) / _SQRT2,
            u_range=tw,
            u_range_top=tf,
            v_range=(0.0, d * _SQRT2),
            kind="bevel",
            group=group,
            soft_cuts=full,
        ),
    ]
    if w.convex_start:
        p = w.start
        pa = p - d * prev.direction  # on the previous wall
        pb = p + d * w.direction  # on this wall
        inward = _v3(prev.normal + w.normal)
        out.append(
            Piece(
                origin=_v3(pa, floor + d),
                eu=_v3((pb - pa) / np.linalg.norm(pb - pa)),
                ev=_UP,
                normal=inward / np.linalg.norm(inward),
                u_range=(0.0, d * _SQRT2),
                v_range=(0.0, ceiling - floor - 2 * d),
                kind="bevel",
                group=group,
            )
        )
        corner = p + d * (prev.normal + w.normal)
        for y_edge, y_bevel, up in ((floor, floor + d, _UP), (ceiling, ceiling - d, -_UP)):
            tri = np.array([_v3(corner, y_edge), _v3(pb, y_bevel), _v3(pa, y_bevel)])
            out.append(
                Piece(
                    origin=tri[0],
                    eu=_X,
                    ev=_Z,
                    normal=inward + up,
                    u_range=(0.0, 0.0),
                    v_range=(0.0, 0.0),
                    kind="bevel",
                    group=group,
                    triangle=tri,
                )
            )
    return out


def _reveal_pieces(w: Wall, o: Opening, group: int, d: float) -> list[Piece]:
    """Jambs, head and threshold (door) or sill (window) of an opening, across the wall."""
    a, n = _v3(w.direction), _v3(w.normal)
    left = w.point(o.u_m - o.width_m / 2)
    right = w.point(o.u_m + o.width_m / 2)
    h = o.top - o.bottom
    out = []
    for base, normal in ((left, a), (right, -a)):
        out.append(
            Piece(
                origin=_v3(base, o.bottom),
                eu=-n,
                ev=_UP,
                normal=normal,
                u_range=(0.0, o.depth_m),
                v_range=(0.0, h),
                kind="opening",
                group=group,
            )
        )
    out.append(  # head (soffit)
        Piece(
            origin=_v3(left, o.top),
            eu=a,
            ev=-n,
            normal=-_UP,
            u_range=(0.0, o.width_m),
            v_range=(0.0, o.depth_m),
            kind="opening",
            group=group,
        )
    )
    if o.kind == "window":
        v_range = (0.0, o.depth_m)  # the sill, up to the glass
    else:  # the threshold reaches the floors stopped short by the bevel on both sides
        v_range = (-d, o.depth_m + (0.0 if o.exterior else d))
    out.append(
        Piece(
            origin=_v3(left, o.bottom),
            eu=a,
            ev=-n,
            normal=_UP,
            u_range=(0.0, o.width_m),
            v_range=v_range,
            kind="opening",
            group=group,
        )
    )
    return out


def _slab_edges(rect: tuple[float, float, float, float], ceiling: float, floor_above: float, group: int) -> list[Piece]:
    """The four faces of the slab around a stair opening, facing into the opening."""
    x0, x1, z0, z1 = rect
    t = floor_above - ceiling
    out = []
    for origin, eu, length, normal in (
        ((x0, z0), _Z, z1 - z0, _X),
        ((x1, z0), _Z, z1 - z0, -_X),
        ((x0, z0), _X, x1 - x0, _Z),
        ((x0, z1), _X, x1 - x0, -_Z),
    ):
        out.append(
            Piece(
                origin=np.array([origin[0], ceiling, origin[1]]),
                eu=eu,
                ev=_UP,
                normal=normal,
                u_range=(0.0, length),
                v_range=(0.0, t),
                kind="slab_edge",
                group=group,
            )
        )
    return out

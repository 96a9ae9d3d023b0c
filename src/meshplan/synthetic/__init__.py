"""Synthetic scans of building interiors with exact ground truth.

:func:`generate` builds a deterministic, HoloLens-like scan of one of the :data:`PRESETS`: a
patchy, noisy, tilted triangle mesh of everything a person walking through the rooms could see
(floors, ceilings, the inner faces of the walls with their door and window reveals, stairs and
furniture), together with annotations and a JSON-ready ``truth`` describing the building in the
*truth frame* (metres, +y up, walls along x and z, floor of story 0 at y = 0) and the rigid
transform that maps it to the scan.

Example
-------
>>> from meshplan.synthetic import generate
>>> scan = generate(preset="room", seed=3, triangle_size_m=(0.15, 0.25))
>>> scan.truth["rooms"][0]["label"]
'room'

Why one long module: it is the generator's public face: SynthParams with every option and its
validation, the presets table and :func:`generate`, which only sequences the submodules (layout,
shell, furniture, fixtures, defects, tessellation, truth).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from ..geometry import Annotations, FloatArray, IntArray, Mesh
from .annotate import place_annotations
from .defects import HEAD_HEIGHT_M, WHITE_NOISE_M, Hole, Missing, pick_holes, pick_missing, scan_transform, smooth_noise
from .fixtures import place_fixtures, place_leaves
from .furniture import place_furniture
from .layout import Building, make_building
from .parametric import parametric_mesh
from .polygons import is_rectilinear, point_in_polygon
from .shell import shell_pieces
from .tessellate import SURFACE_KINDS, Piece, box_pieces, face_count_model, tessellate
from .truth import TRUTH_FORMAT, add_options_truth, build_truth

__all__ = ["HARD_PRESETS", "PRESETS", "SURFACE_KINDS", "TRUTH_FORMAT", "SynthParams", "SyntheticScan", "generate"]

#: The buildings :func:`generate` knows (the original four; see also :data:`HARD_PRESETS`).
PRESETS = ("room", "apartment", "office", "multistory")
#: Presets that turn on what real captures show: ``hard`` (a raw scan with every option of
#: :data:`HARD_OPTIONS` on) and ``hard-parametric`` (the same flat as a RoomPlan-like model).
HARD_PRESETS = ("hard", "hard-parametric")
#: Range of the height up to which walls are scanned with ``wall_top_m=True``, metres (a user who
#: never looks up: real raw scans stop between 1.4 and 2.0 m).
WALL_TOP_M = (1.4, 2.0)
#: The options beyond the original generator, their values when off, and under each hard preset.
HARD_OPTIONS: dict[str, dict[str, object]] = {
    "off": dict(kitchen=False, built_ins=False, open_doors=False, drop_ceiling=False, wall_top_m=False,
                decimate=False, parametric=False, angled_walls=False),
    "hard": dict(kitchen=True, built_ins=True, open_doors=True, drop_ceiling=True, wall_top_m=WALL_TOP_M,
                 decimate=True, parametric=False, angled_walls=True),
    "hard-parametric": dict(kitchen=True, built_ins=True, open_doors=False, drop_ceiling=True, wall_top_m=False,
                            decimate=False, parametric=True, angled_walls=True),
}
#: Longest triangle edge of a decimated scan (``decimate``), metres.
DECIMATE_MAX_EDGE_M = 0.25
#: Part of :data:`DECIMATE_MAX_EDGE_M` the grid may use; the rest is left to the vertex noise.
_DECIMATE_GRID_EDGE_M = 0.24
#: In-plane jitter of the vertices of a decimated scan (a fraction of the local spacing): less
#: than a raw scan's, so that the big cells keep within the longest edge.
DECIMATE_JITTER = 0.15
#: Winding of the scan's faces.
WINDINGS = ("inward", "outward", "mixed")

# Independent random streams, so that e.g. the triangle size does not change the furniture.
_STREAMS = {
    "layout": 1, "annotations": 2, "furniture": 3, "defects": 4, "cells": 5, "grid": 6, "noise": 7, "pose": 8,
    "fixtures": 9, "leaves": 10, "wall_top": 11,
}


def _bad(field: str, value: object, want: str) -> ParameterError:
    return ParameterError(f"synthetic scan: {field} must be {want}, got {value!r}", f"pass {field} as {want}")


def _pair(name: str, value: object, lo: float, hi: float) -> tuple[float, float]:
    try:
        # value is whatever the caller gave: not iterable is one of the TypeErrors caught below
        a, b = (float(x) for x in value)  # type: ignore[attr-defined]
    except (TypeError, ValueError):
        raise _bad(name, value, "a pair (min, max) of numbers") from None
    if not (np.isfinite(a) and np.isfinite(b) and lo <= a <= b <= hi):
        raise _bad(name, value, f"a pair min <= max within [{lo}, {hi}]")
    return a, b


@dataclass(frozen=True)
class SynthParams:
    """What to generate.

    Attributes
    ----------
    preset
        ``room``, ``apartment``, ``office`` or ``multistory`` (see :data:`PRESETS`).
    seed
        Seed of every random choice: the same parameters give a bit-identical scan.
    stories
        Number of stories: 2 (default) or 3 for ``multistory``, 1 (or None) otherwise.
    triangle_size_m
        Range of the grid cell size, drawn per planar surface.
    target_faces
        When set, every cell size is scaled so that the scan has about this many faces (+-15 %).
    noise_m
        Range of the standard deviation of the smooth vertex noise (drawn once per scan); with
        ``(0, 0)`` the scan is noise-free (no white noise either).
    max_tilt_deg
        Largest tilt of the scan's up axis from gravity.
    yaw_deg, tilt_deg
        Fixed yaw and tilt; random when None.
    z_up
        Turn the scan so that up is +z (as many exporters do).
    furniture
        Furnish the rooms.
    holes
        Random elliptical holes and 1-3 missing wall strips.
    bridging
        Bevel every inside corner like a HoloLens mesh.
    winding
        ``inward`` (normals into the rooms), ``outward`` (all flipped) or ``mixed`` (each planar
        piece flipped with probability 0.5).

    The options below are what real captures show and the original presets lack. Each is off
    by default (None means "as the preset says": on under ``hard``, see :data:`HARD_OPTIONS`), so
    the original presets give the same scans as before.

    kitchen
        A kitchen per story (in its kitchen, else its living room): base units with a 0.9 m
        worktop along a wall, wall cabinets from 1.4 to 2.1 m above them and a free-standing
        island. Furniture, not walls, in the truth.
    built_ins
        Wardrobes (2.0-2.2 m high, 0.6 m deep, often wall to wall) in bedrooms, halls and
        offices and 0.75 m desks in bedrooms, studies and offices, flush against a wall.
    open_doors
        A 4 cm leaf in every door, hinged at a jamb, opened 0-110 degrees into the room on
        either side (``truth["openings"][i]["leaf"]``).
    drop_ceiling
        No ceiling: the ceiling faces and the bevels along them are not scanned.
    wall_top_m
        ``(lo, hi)``: nothing but the ceiling is scanned above a height drawn per room in this
        range (``True``: :data:`WALL_TOP_M`; ``False``: off).
    decimate
        A coarse, adaptively decimated mesh: cells of ``triangle_size_m`` along every edge and
        opening, growing away from them to big triangles (no edge longer than 0.25 m).
    parametric
        A RoomPlan-like parametric model instead of a scan (see :mod:`.parametric`): no noise,
        no holes, no bevels, no ceiling, no tilt unless ``tilt_deg`` is given; ``triangle_size_m``,
        ``target_faces``, ``noise_m``, ``holes``, ``bridging``, ``winding``, ``drop_ceiling``,
        ``wall_top_m`` and ``decimate`` play no part.
    parametric_openings
        ``boxes`` (doors and windows as boxes of their own in the wall plane) or ``holes`` (the
        walls built around them).
    parametric_wall_m
        Thickness of the parametric wall boxes (0.1 mm as RoomPlan; 0 leaves two faces).
    angled_walls
        Walls off the axes: a slanted wall (20-40 degrees off its neighbours) and a 45-degree
        chamfer (presets ``room``, ``hard`` and ``hard-parametric``). Corners are then sharp.
    """

    preset: str = "apartment"
    seed: int = 0
    stories: int | None = None
    triangle_size_m: tuple[float, float] = (0.04, 0.10)
    target_faces: int | None = None
    noise_m: tuple[float, float] = (0.005, 0.02)
    max_tilt_deg: float = 6.0
    yaw_deg: float | None = None
    tilt_deg: float | None = None
    z_up: bool = False
    furniture: bool = True
    holes: bool = True
    bridging: bool = True
    winding: str = "inward"
    kitchen: bool | None = None
    built_ins: bool | None = None
    open_doors: bool | None = None
    drop_ceiling: bool | None = None
    wall_top_m: tuple[float, float] | bool | None = None
    decimate: bool | None = None
    parametric: bool | None = None
    parametric_openings: str = "boxes"
    parametric_wall_m: float = 1e-4
    angled_walls: bool | None = None

    def __post_init__(self) -> None:
        put = lambda name, value: object.__setattr__(self, name, value)  # noqa: E731 - frozen
        if self.preset not in PRESETS + HARD_PRESETS:
            raise ParameterError(f"unknown synthetic preset {self.preset!r}", f"use one of {', '.join(PRESETS + HARD_PRESETS)}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or not 0 <= int(self.seed) < 2**63:
            raise _bad("seed", self.seed, "an integer in [0, 2**63)")
        put("seed", int(self.seed))
        if self.stories is not None:
            ok = isinstance(self.stories, (int, np.integer)) and not isinstance(self.stories, bool)
            allowed = (2, 3) if self.preset == "multistory" else (1,)
            if not ok or int(self.stories) not in allowed:
                raise _bad("stories", self.stories, f"one of {allowed} for preset {self.preset!r}")
            put("stories", int(self.stories))
        put("triangle_size_m", _pair("triangle_size_m", self.triangle_size_m, 0.005, 2.0))
        if self.triangle_size_m[0] <= 0:
            raise _bad("triangle_size_m", self.triangle_size_m, "positive")
        if self.target_faces is not None:
            ok = isinstance(self.target_faces, (int, np.integer)) and not isinstance(self.target_faces, bool)
            if not ok or not 1_000 <= int(self.target_faces) <= 50_000_000:
                raise _bad("target_faces", self.target_faces, "an integer in [1000, 50000000]")
            put("target_faces", int(self.target_faces))
        put("noise_m", _pair("noise_m", self.noise_m, 0.0, 0.2))
        for name, hi in (("max_tilt_deg", 45.0), ("tilt_deg", 45.0)):
            v = getattr(self, name)
            if v is None:
                continue
            try:
                v = float(v)
            except (TypeError, ValueError):
                raise _bad(name, v, f"a number in [0, {hi}]") from None
            if not (np.isfinite(v) and 0.0 <= v <= hi):
                raise _bad(name, v, f"a number in [0, {hi}]")
            put(name, v)
        if self.yaw_deg is not None:
            try:
                yaw = float(self.yaw_deg)
            except (TypeError, ValueError):
                raise _bad("yaw_deg", self.yaw_deg, "a number") from None
            if not np.isfinite(yaw):
                raise _bad("yaw_deg", self.yaw_deg, "a finite number")
            put("yaw_deg", yaw)
        for name in ("z_up", "furniture", "holes", "bridging"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise _bad(name, getattr(self, name), "True or False")
            put(name, bool(getattr(self, name)))
        if self.winding not in WINDINGS:
            raise ParameterError(f"unknown winding {self.winding!r}", f"use one of {', '.join(WINDINGS)}")
        self._check_options(put)

    def _check_options(self, put) -> None:
        """Resolve and validate the options beyond the original generator."""
        preset_values = HARD_OPTIONS.get(self.preset, HARD_OPTIONS["off"])
        for name, default in preset_values.items():
            value = getattr(self, name)
            if value is None:
                value = default
            if name == "wall_top_m":
                if isinstance(value, (bool, np.bool_)):
                    value = WALL_TOP_M if value else False
                else:
                    value = _pair(name, value, 0.3, 4.0)
            elif not isinstance(value, (bool, np.bool_)):
                raise _bad(name, value, "True or False")
            else:
                value = bool(value)
            put(name, value)
        if self.angled_walls and self.preset not in ("room",) + HARD_PRESETS:
            raise _bad("angled_walls", self.angled_walls, f"False for preset {self.preset!r} (only room and the hard presets have them)")
        if self.parametric_openings not in ("boxes", "holes"):
            raise ParameterError(f"unknown parametric_openings {self.parametric_openings!r}", "use boxes or holes")
        try:
            t = float(self.parametric_wall_m)
        except (TypeError, ValueError):
            raise _bad("parametric_wall_m", self.parametric_wall_m, "a number in [0, 0.05]") from None
        if not (np.isfinite(t) and 0.0 <= t <= 0.05):
            raise _bad("parametric_wall_m", self.parametric_wall_m, "a number in [0, 0.05]")
        put("parametric_wall_m", t)

    @property
    def extended(self) -> bool:
        """Any option beyond the original generator is on (or a hard preset is chosen)."""
        off = HARD_OPTIONS["off"]
        return self.preset in HARD_PRESETS or any(getattr(self, k) != v for k, v in off.items())

    @property
    def n_stories(self) -> int:
        """The number of stories actually built."""
        return self.stories or (2 if self.preset == "multistory" else 1)

    def to_dict(self) -> dict:
        """JSON-ready parameters (tuples as lists).

        The options beyond the original generator are listed only when one of them is on (or a
        hard preset is chosen), so the original presets' truth is the same as before; the
        ``parametric_*`` details only with ``parametric``.
        """
        out = {k: list(v) if isinstance(v, tuple) else v for k, v in dataclasses.asdict(self).items()}
        if not self.extended:
            for k in list(HARD_OPTIONS["off"]) + ["parametric_openings", "parametric_wall_m"]:
                del out[k]
        elif not self.parametric:
            del out["parametric_openings"], out["parametric_wall_m"]
        return out


@dataclass(frozen=True, eq=False)
class SyntheticScan:
    """A generated scan and its ground truth.

    Attributes
    ----------
    mesh
        The scan, scan coordinates.
    annotations
        The annotated objects, scan coordinates.
    truth
        JSON-ready ground truth (truth frame unless said otherwise; see :func:`generate`).
    face_groups
        ``(F,)`` object of every face (a room shell, a stair or a furniture item).
    group_names
        Name of every group.
    face_kinds
        ``(F,)`` surface kind of every face, an index into :data:`SURFACE_KINDS`.
    face_walls
        ``(F,)`` index into ``truth["walls"]`` of the faces of a wall face, -1 for other faces.
    """

    mesh: Mesh
    annotations: Annotations
    truth: dict
    face_groups: IntArray
    group_names: tuple[str, ...]
    face_kinds: IntArray
    face_walls: IntArray

    @property
    def transform(self) -> FloatArray:
        """4x4 rigid transform truth frame -> scan."""
        return np.array(self.truth["transform"], dtype=np.float64)

    def truth_mesh(self) -> Mesh:
        """The scan mapped back into the truth frame."""
        return self.mesh.transformed(np.linalg.inv(self.transform))


def generate(params: SynthParams | None = None, **overrides) -> SyntheticScan:
    """Generate a synthetic scan.

    Parameters
    ----------
    params
        What to generate; the defaults of :class:`SynthParams` when omitted.
    **overrides
        Fields of :class:`SynthParams` replacing those of ``params``.

    Returns
    -------
    SyntheticScan
        ``truth`` holds ``format``, ``preset``, ``seed``, ``parameters``, ``transform`` (truth ->
        scan, 4x4), ``up`` (scan coordinates), ``yaw_deg``, ``tilt_deg``, ``tilt_axis``, ``z_up``,
        ``winding``, ``noise_m``, ``triangle_size_m``, ``bevel_m``, ``stories``, ``footprint``,
        ``rooms``, ``walls``, ``openings``, ``missing``, ``holes``, ``stairs``, ``furniture``,
        ``annotations``, ``faces`` and ``vertices``.

    Raises
    ------
    ParameterError
        On invalid parameters.
    """
    try:
        params = dataclasses.replace(params, **overrides) if params is not None else SynthParams(**overrides)
    except TypeError as exc:
        raise ParameterError(f"synthetic scan: {exc}", "see meshplan.synthetic.SynthParams for the parameters") from None
    rng = {k: np.random.default_rng([params.seed, v]) for k, v in _STREAMS.items()}

    building = make_building(params.preset, params.n_stories, rng["layout"], angled=bool(params.angled_walls))
    markers = place_annotations(building, rng["annotations"])
    fixed = place_fixtures(building, markers, rng["fixtures"], bool(params.kitchen), bool(params.built_ins)) if params.kitchen or params.built_ins else []
    items = place_furniture(building, markers, rng["furniture"], fixed) if params.furniture else list(fixed)
    leaves = place_leaves(building, items, rng["leaves"]) if params.open_doors else []
    sharp = not all(is_rectilinear(r.polygon) for r in building.rooms)  # bevels are made for right angles

    r_def = rng["defects"]
    bevel = float(r_def.uniform(0.03, 0.10))
    noise_amp = float(r_def.uniform(*params.noise_m))
    missing: list[Missing] = []
    holes: list[Hole] = []
    if params.holes and not params.parametric:
        along: dict[int, list[float]] = {}
        spots: dict[int, list[tuple[float, float]]] = {}
        for m in markers:
            along.setdefault(m.wall, []).append(m.u_m)
            spots.setdefault(m.wall, []).append((m.u_m, m.height_m))
        missing = pick_missing(building, along, bevel if params.bridging and not sharp else 0.0, r_def)
        holes = pick_holes(building, spots, missing, r_def)
    if not params.bridging or sharp or params.parametric:
        bevel = 0.0
    wall_tops = _wall_tops(building, params, rng["wall_top"])

    tilt_deg: float | None = params.tilt_deg
    if params.parametric:
        verts, faces, face_group, group_names, face_kind, face_wall = parametric_mesh(
            building, items, leaves, params.parametric_wall_m, params.parametric_openings
        )
        used_cells = np.zeros(1)
        noise_amp = 0.0
        tilt_deg = params.tilt_deg if params.tilt_deg is not None else 0.0  # gravity-aligned, as RoomPlan
    else:
        pieces, group_names = _pieces(building, items, bevel, missing, holes)
        group_rooms = list(range(len(building.rooms))) + [st.room for st in building.stairs] + [it.room for it in items]
        for lf in leaves:
            group_rooms.append(lf.room if lf.room >= 0 else building.walls[_door_wall(building, lf.label)].room)
            pieces += box_pieces(lf.box, "door_leaf", len(group_names))
            group_names.append(f"{lf.label}_leaf")
        if params.drop_ceiling:
            pieces = [p for p in pieces if not _ceiling_piece(p)]
        cells = _cell_sizes(pieces, params, rng["cells"])
        if params.winding == "outward":
            flips = np.ones(len(pieces), dtype=bool)
        elif params.winding == "mixed":
            flips = rng["cells"].random(len(pieces)) < 0.5
        else:
            flips = np.zeros(len(pieces), dtype=bool)
        for p, c, f in zip(pieces, cells, flips):
            p.cell_m, p.flip = float(c), bool(f)
        if params.decimate:
            for k, p in enumerate(pieces):
                p.max_cell_m, p.jitter = _decimated_cell(p), DECIMATE_JITTER
                p.cell_m = cells[k] = min(p.cell_m, p.max_cell_m)

        verts, faces, face_piece, vert_piece = tessellate(pieces, rng["grid"])
        if params.extended:  # the zero-width ends of trapezoids leave empty triangles: drop them
            verts, faces, face_piece, vert_piece = _drop_flat(verts, faces, face_piece, vert_piece)
        if noise_amp > 0:
            normals = np.array([p.normal / np.linalg.norm(p.normal) for p in pieces])
            field = smooth_noise(verts, noise_amp, rng["noise"])
            verts = verts + field[:, None] * normals[vert_piece] + rng["noise"].normal(0.0, WHITE_NOISE_M, verts.shape)
        piece_group = np.array([p.group for p in pieces], dtype=np.int64)
        piece_kind = np.array([p.kind_index for p in pieces], dtype=np.int64)
        if wall_tops is not None:  # nothing but the ceiling scanned above each room's height
            top = wall_tops[np.array(group_rooms, dtype=np.int64)[piece_group[face_piece]]]
            keep = (verts[faces][:, :, 1].max(axis=1) <= top) | (piece_kind[face_piece] == SURFACE_KINDS.index("ceiling"))
            faces, face_piece = faces[keep], face_piece[keep]
            used = np.zeros(len(verts), dtype=bool)
            used[faces] = True
            verts, faces = verts[used], (np.cumsum(used) - 1)[faces]
        verts, faces, face_piece = _drop_degenerate(verts, faces, face_piece)
        face_group, face_kind = piece_group[face_piece], piece_kind[face_piece]
        face_wall = np.array([p.wall for p in pieces], dtype=np.int64)[face_piece]
        used_cells = cells[np.unique(face_piece)] if len(face_piece) else cells

    start = _start_point(building, rng["pose"])
    transform, yaw, tilt, axis = scan_transform(rng["pose"], start, params.yaw_deg, tilt_deg, params.max_tilt_deg, params.z_up)
    mesh = Mesh(verts, faces).transformed(transform)
    truth_ann = Annotations(
        tuple(m.label for m in markers),
        tuple(m.kind for m in markers),
        np.array([m.position for m in markers]).reshape(-1, 3),
        np.array([m.direction for m in markers]).reshape(-1, 3),
    )
    annotations = truth_ann.transformed(transform)

    truth = build_truth(
        params, building, items, missing, holes, truth_ann, transform, yaw, tilt, axis, noise_amp, bevel, used_cells, mesh
    )
    if params.extended:
        add_options_truth(truth, params, building, items, leaves, wall_tops)
    return SyntheticScan(
        mesh=mesh,
        annotations=annotations,
        truth=truth,
        face_groups=_readonly(face_group),
        group_names=tuple(group_names),
        face_kinds=_readonly(face_kind),
        face_walls=_readonly(face_wall),
    )


def _door_wall(b: Building, label: str) -> int:
    """The wall of the primary opening of door ``label``."""
    return next(o.wall for o in b.openings if o.label == label and o.primary)


def _ceiling_piece(p: Piece) -> bool:
    """A piece of the ceiling or of a bevel along it (facing down)."""
    return p.kind == "ceiling" or (p.kind == "bevel" and float(p.normal[1]) < -1e-6)


def _wall_tops(b: Building, params: SynthParams, rng: np.random.Generator) -> FloatArray | None:
    """Per room, the absolute height above which nothing but the ceiling is scanned (None: off)."""
    if params.wall_top_m is False or params.parametric:
        return None
    lo, hi = params.wall_top_m  # type: ignore[misc]  # a pair once validated
    return np.array([b.stories[r.story][0] + rng.uniform(lo, hi) for r in b.rooms])


def _decimated_cell(p: Piece) -> float:
    """Largest cell of piece ``p`` on a decimated grid: its longest possible triangle edge (the
    diagonal of a cell, sheared by the slant of a trapezoid's sides, with the vertex jitter)
    stays within the edge budget."""
    skew = 0.0
    if p.u_range_top is not None and p.v_range[1] > p.v_range[0]:
        h = p.v_range[1] - p.v_range[0]
        skew = max(abs(p.u_range_top[0] - p.u_range[0]), abs(p.u_range_top[1] - p.u_range[1])) / h
    return _DECIMATE_GRID_EDGE_M / ((1.0 + 2.0 * DECIMATE_JITTER) * float(np.hypot(1.0 + skew, 1.0)))


def _drop_flat(verts: FloatArray, faces: IntArray, face_piece: IntArray, vert_piece: IntArray) -> tuple[FloatArray, IntArray, IntArray, IntArray]:
    """Drop faces of (almost) no area before the noise, and the vertices left unused."""
    t = verts[faces]
    ok = 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1) > 1e-8
    faces, face_piece = faces[ok], face_piece[ok]
    used = np.zeros(len(verts), dtype=bool)
    used[faces] = True
    return verts[used], (np.cumsum(used) - 1)[faces], face_piece, vert_piece[used]


def _pieces(b: Building, items: list, bevel: float, missing: list[Missing], holes: list[Hole]) -> tuple[list[Piece], list[str]]:
    """Every planar piece to scan and the names of the face groups: one per room shell, then one
    per stair, then one per furniture item."""
    pieces = shell_pieces(b, bevel, missing, holes)
    names = [r.label for r in b.rooms]
    solids = [(f"stair{k + 1}", "stair", st.boxes) for k, st in enumerate(b.stairs)]
    solids += [(it.name, "furniture", it.boxes) for it in items]
    for name, kind, boxes in solids:
        for bx in boxes:
            pieces += box_pieces(bx, kind, len(names))
        names.append(name)
    return pieces, names


def _readonly(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


def _cell_sizes(pieces: list[Piece], params: SynthParams, rng: np.random.Generator) -> FloatArray:
    """Cell size of every piece: drawn in ``triangle_size_m``, then scaled to ``target_faces``."""
    lo, hi = params.triangle_size_m
    cells = rng.uniform(lo, hi, len(pieces))
    if params.target_faces is None:
        return cells
    count = face_count_model(pieces, cells)
    a, b = np.log(1e-3), np.log(1e3)  # predicted faces fall as the scale grows
    for _ in range(60):
        mid = 0.5 * (a + b)
        if count(np.exp(mid)) > params.target_faces:
            a = mid
        else:
            b = mid
    return cells * np.exp(0.5 * (a + b))


def _drop_degenerate(verts: FloatArray, faces: IntArray, face_piece: IntArray) -> tuple[FloatArray, IntArray, IntArray]:
    """Drop faces of area <= 1e-10 m2 (none are expected; noise could in principle make one)."""
    t = verts[faces]
    area = 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1)
    ok = area > 1e-10
    if ok.all():
        return verts, faces, face_piece
    faces, face_piece = faces[ok], face_piece[ok]
    used = np.zeros(len(verts), dtype=bool)
    used[faces] = True
    return verts[used], (np.cumsum(used) - 1)[faces], face_piece


def _start_point(b: Building, rng: np.random.Generator) -> FloatArray:
    """Where the user's head was when the scan started: somewhere in the first room."""
    room = b.rooms[0]
    lo, hi = room.polygon.min(axis=0), room.polygon.max(axis=0)
    margin = np.minimum(0.5, 0.25 * (hi - lo))
    for _ in range(50):
        x, z = rng.uniform(lo + margin, hi - margin)
        if point_in_polygon(room.polygon, x, z):
            break
    return np.array([x, b.stories[0][0] + HEAD_HEIGHT_M, z])

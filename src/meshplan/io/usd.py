"""USD stages in (USD, USDA, USDC, USDZ): Apple RoomPlan exports, Polycam and other captures.

A stage is flattened into one triangle soup in world coordinates, read with usd-core (``pxr``,
the ``usd`` extra: ``pip install 'meshplan[usd]'``):

* every ``UsdGeom.Mesh`` (polygons fan-triangulated) and every implicit surface: ``Cube``,
  ``Sphere``, ``Cylinder``, ``Cone``, ``Capsule`` and ``Plane``, tessellated, each moved by its
  full local-to-world transform (the product of every ``xformOp`` above it); instance proxies
  included, guides and invisible prims left out;
* the stage's ``metersPerUnit`` (:func:`UsdGeom.GetStageMetersPerUnit`) is returned for the caller
  to apply with ``--units``, and a ``Z``-up stage (:func:`UsdGeom.GetStageUpAxis`) is turned
  ``Y``-up (+z onto +y, a rotation of -90 degrees about x), so that a USD scan's input frame is
  ``Y``-up as glTF's is.

A RoomPlan export (``/Room/Parametric_grp`` holding walls, doors, windows, openings and objects
as named, scaled ``Cube`` prims, and a floor ``Mesh``) is recognised: its parts are counted by
kind (:attr:`UsdScene.parts`), it reads into the same triangles as a conversion that turns each
cube into its 12 triangles (``roomplan_*_parametric.ply`` in the shared scans), and its boxes are
kept as they are, :class:`RoomPlanElements` (:attr:`UsdScene.parametric`): the eight corners of
each, in the same input coordinates as the vertices, with its kind and, for a door, window or
opening, the wall that holds it (RoomPlan puts them in that wall's ``Wall_<n>_grp``). The plan
stage (:func:`meshplan.plan.parametric.apply_parametric`) takes the doors and windows from them
and keeps the furniture's fronts out of the walls.

The layout read, as RoomPlan (iOS 16 and 17) writes it::

    /Room/Parametric_grp/Arch_grp/Wall_0_grp/Wall0      Cube  (size 1, scaled: length x height x 0.1 mm)
    /Room/Parametric_grp/Arch_grp/Wall_0_grp/Door1      Cube  (a door in Wall0)
    /Room/Parametric_grp/Arch_grp/Wall_17_grp/Window0   Cube
    /Room/Parametric_grp/Floor_grp/Floor0               Mesh
    /Room/Parametric_grp/Object_grp/Storage_grp/Storage4  Cube (objects: Storage, Table, Sofa, Bed...)
    /Room/Section_grp/livingRoom0                       Xform (RoomPlan's room labels, at each room's centre)
"""

from __future__ import annotations

import logging
import re
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..geometry import BOX_CORNERS, BOX_FACES, FloatArray, IntArray
from .readers import RawMesh, fan

log = logging.getLogger(__name__)

__all__ = ["ROOMPLAN_OPENINGS", "USD_HINT", "RoomPlanElements", "UsdScene", "read_usd"]

#: What to install to read USD.
USD_HINT = "pip install 'meshplan[usd]'"

#: Segments around the circumference of tessellated cylinders, cones and capsules: 32 keep the
#: chord within 0.5 % of the radius (5 mm on a 1 m column), far below any scan's noise.
ROUND_SEGMENTS = 32

#: Subdivisions of the icosphere standing for a ``Sphere`` (320 triangles, within 1 % of the
#: radius).
SPHERE_SUBDIVISIONS = 2

#: The rotation turning a Z-up stage Y-up: +z onto +y, +y onto -z (a right-handed turn of -90
#: degrees about x), applied to row vectors (``p @ Z_UP_TO_Y_UP``).
Z_UP_TO_Y_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


#: RoomPlan's prim names and the kind of part each stands for.
_ROOMPLAN_KINDS = {"Wall": "wall", "Door": "door", "Window": "window", "Opening": "opening", "Floor": "floor"}
_ROOMPLAN_NAME = re.compile(r"^([A-Za-z]+?)(\d+)$")
#: The group RoomPlan puts a wall and the doors, windows and openings in it into.
_ROOMPLAN_WALL_GROUP = re.compile(r"^Wall_(\d+)_grp$")

#: The group holding RoomPlan's sections (its room labels, one Xform at each room's centre).
_ROOMPLAN_SECTIONS = "Section_grp"

#: RoomPlan's kinds of the openings in a wall.
ROOMPLAN_OPENINGS = ("door", "window", "opening")


@dataclass(frozen=True, eq=False)
class RoomPlanElements:
    """RoomPlan's parametric elements: one box per wall, door, window, opening and object, in
    input coordinates (the stage's units, Y-up, as :attr:`UsdScene.vertices`).

    Attributes
    ----------
    kind
        Per box: ``wall``, ``door``, ``window``, ``opening`` or the object's category in lower
        case (``storage``, ``table``, ``sofa``, ``bed``...).
    name
        Per box, the prim's name (``Wall0``, ``Door1``, ``Storage4``).
    host
        Per box, the row of the wall a door, window or opening is in (-1: none, and for walls and
        objects).
    corners
        ``(N, 8, 3)`` corners of each box (a wall is a box 0.1 mm thick), in the order of
        :data:`meshplan.geometry.BOX_CORNERS` (so ``corners[:, 4] - corners[:, 0]`` is the box's
        local x edge, ``[:, 2] - [:, 0]`` its y edge and ``[:, 1] - [:, 0]`` its z edge).
    section_label, section_center
        RoomPlan's sections (``/Room/Section_grp``): per section its label (``livingRoom``,
        ``bedroom``, ``kitchen``, ``bathroom``, ``diningRoom``, ``unidentified``) and ``(K, 3)``
        its centre (input coordinates, Y-up), which names the room holding it.
    """

    kind: tuple[str, ...]
    name: tuple[str, ...]
    host: IntArray
    corners: FloatArray
    section_label: tuple[str, ...] = ()
    section_center: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))

    def __len__(self) -> int:
        return len(self.kind)

    def of_kind(self, *kinds: str) -> IntArray:
        """Rows of the boxes of these kinds."""
        return np.array([i for i, k in enumerate(self.kind) if k in kinds], dtype=np.int64)

    @property
    def objects(self) -> IntArray:
        """Rows of the objects (furniture, appliances): every box that is not part of the building."""
        return np.array([i for i, k in enumerate(self.kind) if k != "wall" and k not in ROOMPLAN_OPENINGS], dtype=np.int64)

    def counts(self) -> dict[str, int]:
        """Number of boxes of each kind."""
        return dict(sorted(Counter(self.kind).items()))


@dataclass(frozen=True, eq=False)
class UsdScene(RawMesh):
    """The triangles of a USD stage in world coordinates (stage units, Y-up), as a
    :class:`~meshplan.io.readers.RawMesh`, with what the stage said about itself.

    Attributes
    ----------
    meters_per_unit
        The stage's ``metersPerUnit`` (1 when unset, as RoomPlan and Polycam write metres).
    up_axis
        The stage's up axis as authored (``"Y"`` or ``"Z"``; the vertices are Y-up either way).
    roomplan
        Whether the stage is a RoomPlan parametric export.
    parts
        Number of geometric prims of each kind: RoomPlan's ``wall``, ``door``, ``window``,
        ``opening``, ``floor`` and object categories (``table``, ``chair``...), or the prim type
        (``Mesh``, ``Cube``...) for other stages.
    skipped
        Prims with geometry meshplan does not read (points, curves, point instancers), by type.
    parametric
        A RoomPlan export's boxes (:class:`RoomPlanElements`); ``None`` for other stages.
    """

    meters_per_unit: float = 1.0
    up_axis: str = "Y"
    roomplan: bool = False
    parts: dict[str, int] = field(default_factory=dict)
    skipped: dict[str, int] = field(default_factory=dict)
    parametric: RoomPlanElements | None = None


def _pxr():
    try:
        from pxr import Usd, UsdGeom
    except ImportError:
        raise InputError("reading USD needs usd-core", USD_HINT) from None
    return Usd, UsdGeom


def check_usd_extra() -> None:
    """Refuse, before any work, a USD file when usd-core is not installed."""
    _pxr()


def _round_solid(kind: str, radius: float, height: float, axis: str) -> tuple[np.ndarray, np.ndarray]:
    """A cylinder, cone or capsule along ``axis`` centred on the origin (trimesh builds them
    along z)."""
    import trimesh

    if kind == "Cylinder":
        tm = trimesh.creation.cylinder(radius=radius, height=height, sections=ROUND_SEGMENTS)
    elif kind == "Cone":
        tm = trimesh.creation.cone(radius=radius, height=height, sections=ROUND_SEGMENTS)
        tm.apply_translation([0.0, 0.0, -height / 2.0])  # USD's cone is centred; trimesh's sits on z = 0
    else:
        tm = trimesh.creation.capsule(height=height, radius=radius, count=[ROUND_SEGMENTS, ROUND_SEGMENTS // 2])
    v = np.asarray(tm.vertices, np.float64)
    if axis == "X":
        v = v[:, [2, 0, 1]]
    elif axis == "Y":
        v = v[:, [1, 2, 0]]
    return v, np.asarray(tm.faces, np.int64)


def _local_geometry(prim, UsdGeom, time) -> tuple[np.ndarray, np.ndarray] | None:
    """Vertices (local coordinates) and triangles of one geometric prim; ``None`` when it holds
    none meshplan reads."""
    if prim.IsA(UsdGeom.Mesh):
        m = UsdGeom.Mesh(prim)
        pts = m.GetPointsAttr().Get(time)
        counts = m.GetFaceVertexCountsAttr().Get(time)
        idx = m.GetFaceVertexIndicesAttr().Get(time)
        if pts is None or counts is None or idx is None or not len(pts):
            return None
        v = np.asarray(pts, np.float64).reshape(-1, 3)
        c = np.asarray(counts, np.int64)
        i = np.asarray(idx, np.int64)
        if c.sum() != len(i):
            raise InputError(f"{prim.GetPath()}: faceVertexCounts and faceVertexIndices disagree", "export the USD file again")
        poly = c >= 3
        first = np.cumsum(c) - c
        f = fan(c[poly], i, first[poly])
        if m.GetOrientationAttr().Get(time) == UsdGeom.Tokens.leftHanded:
            f = f[:, ::-1]
        return v, f
    if prim.IsA(UsdGeom.Cube):
        size = float(UsdGeom.Cube(prim).GetSizeAttr().Get(time))
        return BOX_CORNERS * size, BOX_FACES
    if prim.IsA(UsdGeom.Sphere):
        import trimesh

        tm = trimesh.creation.icosphere(subdivisions=SPHERE_SUBDIVISIONS, radius=float(UsdGeom.Sphere(prim).GetRadiusAttr().Get(time)))
        return np.asarray(tm.vertices, np.float64), np.asarray(tm.faces, np.int64)
    for kind in ("Cylinder", "Cone", "Capsule"):
        klass = getattr(UsdGeom, kind, None)
        if klass is not None and prim.IsA(klass):
            g = klass(prim)
            return _round_solid(kind, float(g.GetRadiusAttr().Get(time)), float(g.GetHeightAttr().Get(time)), str(g.GetAxisAttr().Get(time)))
    plane = getattr(UsdGeom, "Plane", None)
    if plane is not None and prim.IsA(plane):
        g = plane(prim)
        w, length, axis = float(g.GetWidthAttr().Get(time)), float(g.GetLengthAttr().Get(time)), str(g.GetAxisAttr().Get(time))
        # the plane's normal is along axis; width along the next axis, length along the one after
        a, b = {"X": (1, 2), "Y": (2, 0), "Z": (0, 1)}[axis]
        v = np.zeros((4, 3))
        v[:, a] = np.array([-0.5, 0.5, 0.5, -0.5]) * w
        v[:, b] = np.array([-0.5, -0.5, 0.5, 0.5]) * length
        return v, np.array([[0, 1, 2], [0, 2, 3]], np.int64)
    return None


def _roomplan_kind(prim) -> str | None:
    """RoomPlan's kind of a prim under ``Parametric_grp``: ``wall``, ``door``... or the object
    category (``table``, ``chair``), from its name (``Wall3``, ``Table0``)."""
    m = _ROOMPLAN_NAME.match(prim.GetName())
    if m is None:
        return None
    return _ROOMPLAN_KINDS.get(m.group(1), m.group(1).lower())


def read_usd(path: Path, max_faces: int | None = None) -> UsdScene:
    """The triangles of a USD stage, in world coordinates (stage units), Y-up.

    Parameters
    ----------
    path
        USD, USDA, USDC or USDZ file.
    max_faces
        Refuse stages with more triangles than this (counted while reading, before the
        clean-up); ``None``: no limit beyond the memory.

    Returns
    -------
    UsdScene

    Raises
    ------
    InputError
        When usd-core is not installed, the stage cannot be opened, or it holds no triangle.
    """
    Usd, UsdGeom = _pxr()
    try:
        stage = Usd.Stage.Open(str(path), Usd.Stage.LoadAll)
    except Exception as exc:  # pxr raises Tf.ErrorException, with a multi-line text
        reason = " ".join(str(exc).split())[:120] or type(exc).__name__
        raise InputError(f"{path}: cannot be read as USD ({reason})", "check that the file is a complete, uncorrupted USD export") from None
    if stage is None:
        raise InputError(f"{path}: cannot be read as USD", "check that the file is a complete, uncorrupted USD export")
    meters = float(UsdGeom.GetStageMetersPerUnit(stage))
    if not (np.isfinite(meters) and meters > 0):
        meters = 1.0
    up = str(UsdGeom.GetStageUpAxis(stage))
    time = Usd.TimeCode.EarliestTime()
    cache = UsdGeom.XformCache(time)
    verts, faces, offset, n_faces = [], [], 0, 0
    parts: Counter[str] = Counter()
    skipped: Counter[str] = Counter()
    roomplan = False
    boxes: list[tuple[str, str, str | None, np.ndarray]] = []  # RoomPlan: kind, name, host wall's name, corners
    sections: list[tuple[str, np.ndarray]] = []  # RoomPlan: label, centre
    it = iter(Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies()))
    for prim in it:  # one step per prim (a RoomPlan stage holds some 200), not per vertex
        if prim.IsA(UsdGeom.Imageable):
            img = UsdGeom.Imageable(prim)
            if img.ComputeVisibility(time) == UsdGeom.Tokens.invisible or img.ComputePurpose() == UsdGeom.Tokens.guide:
                it.PruneChildren()
                continue
        if prim.IsA(UsdGeom.PointInstancer):
            skipped["PointInstancer"] += 1
            it.PruneChildren()  # its prototypes are not where they stand
            continue
        if not prim.IsA(UsdGeom.Gprim):
            parent = prim.GetParent()
            section = _ROOMPLAN_NAME.match(prim.GetName()) if parent and parent.GetName() == _ROOMPLAN_SECTIONS else None
            if section is not None and prim.IsA(UsdGeom.Xformable):
                m = np.array(cache.GetLocalToWorldTransform(prim), dtype=np.float64)
                sections.append((section.group(1), m[3, :3]))
            continue
        geom = _local_geometry(prim, UsdGeom, time)
        if geom is None:
            skipped[str(prim.GetTypeName())] += 1
            continue
        v, f = geom
        m = np.array(cache.GetLocalToWorldTransform(prim), dtype=np.float64)  # row vectors: p' = [p, 1] @ m
        world = v @ m[:3, :3] + m[3, :3]
        if np.linalg.det(m[:3, :3]) < 0:  # a mirroring transform turns the winding
            f = f[:, ::-1]
        verts.append(world)
        faces.append(f + offset)
        offset += len(world)
        n_faces += len(f)
        if max_faces is not None and n_faces > max_faces:
            raise InputError(f"{path}: more than --max-faces {max_faces:,} triangles", "decimate the scan, or raise --max-faces")
        in_roomplan = "/Parametric_grp/" in str(prim.GetPath())
        kind = _roomplan_kind(prim) if in_roomplan else None
        roomplan |= kind is not None
        parts[kind or str(prim.GetTypeName())] += 1
        box = _roomplan_box(prim, kind, world, UsdGeom)
        if box is not None:
            boxes.append(box)
    if not faces:
        found = f" ({', '.join(f'{n} {k}' for k, n in skipped.items())} not read)" if skipped else ""
        raise InputError(f"{path}: the USD stage holds no mesh or solid{found}", "export the scan as a mesh")
    v = np.concatenate(verts)
    if up.upper() == "Z":
        v = v @ Z_UP_TO_Y_UP
    parametric = _roomplan_elements(boxes, sections, up.upper() == "Z") if roomplan and boxes else None
    if roomplan:
        log.info("%s: RoomPlan parametric model: %s", path, ", ".join(f"{n} {k}" for k, n in sorted(parts.items())))
    if skipped:
        log.warning("%s: not read: %s", path, ", ".join(f"{n} {k}" for k, n in skipped.items()))
    return UsdScene(
        v, np.concatenate(faces), objects=sum(parts.values()), meters_per_unit=meters, up_axis=up,
        roomplan=roomplan, parts=dict(parts), skipped=dict(skipped), parametric=parametric,
    )


def _roomplan_box(prim, kind: str | None, world: np.ndarray, UsdGeom) -> tuple[str, str, str | None, np.ndarray] | None:
    """A RoomPlan box as (kind, name, host wall's name, world corners); ``None`` for other prims
    (the floor mesh, prims outside ``Parametric_grp``)."""
    if kind is None or kind == "floor" or not prim.IsA(UsdGeom.Cube):
        return None
    group = _ROOMPLAN_WALL_GROUP.match(prim.GetParent().GetName())
    host = f"Wall{group.group(1)}" if group is not None and kind in ROOMPLAN_OPENINGS else None
    return kind, prim.GetName(), host, world


def _roomplan_elements(boxes: list[tuple[str, str, str | None, np.ndarray]], sections: list[tuple[str, np.ndarray]], z_up: bool) -> RoomPlanElements:
    """The :class:`RoomPlanElements` of the boxes read (kind, name, host wall's name, world
    corners) and the sections (label, world centre), turned Y-up as the vertices are."""
    corners = np.stack([b[3] for b in boxes]).reshape(-1, 8, 3)
    centers = np.array([c for _, c in sections], dtype=np.float64).reshape(-1, 3)
    if z_up:
        corners = corners @ Z_UP_TO_Y_UP
        centers = centers @ Z_UP_TO_Y_UP
    row = {name: i for i, (kind, name, _, _) in enumerate(boxes) if kind == "wall"}
    host = np.array([row.get(h, -1) if h is not None else -1 for _, _, h, _ in boxes], dtype=np.int64)
    return RoomPlanElements(tuple(b[0] for b in boxes), tuple(b[1] for b in boxes), host, corners, tuple(label for label, _ in sections), centers)

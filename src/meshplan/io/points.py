"""Point clouds in: E57, LAS/LAZ, PLY and XYZ/PTS/TXT point files, OBJ with vertices only.

Every stage of meshplan works on oriented surface elements with an area: today the triangles of a
mesh. A point cloud is turned into such elements in three steps, all whole-array numpy and scipy
(no Python loop runs per point):

1. **Subsample on a voxel grid** (:data:`VOXEL_M`, ``point_voxel_m``): one point per occupied
   voxel, at the mean of the points in it (colour and intensity averaged too). Scans range from
   2 mm laser spacing (tens of millions of points) to 5 cm phone spacing with 1 cm noise; the grid
   evens the density to at most one point per voxel, bounds the work whatever the scanner, and
   averages laser noise away.
2. **Surfels**: each point's normal is the least principal axis of its
   :data:`PCA_NEIGHBOURS` nearest neighbours (a k-nearest-neighbour PCA on a
   :class:`scipy.spatial.cKDTree`), and its footprint area is ``pi r_k^2 / k``, ``r_k`` the
   distance, in the tangent plane, of its k-th neighbour (the area each point stands for: the
   estimate is unbiased for a random spread of points and within 2 % of the cell of a grid).
3. **Splats**: each surfel becomes an equilateral triangle in its tangent plane, centred on its
   point, whose area is the footprint area. The result is an ordinary
   :class:`~meshplan.geometry.Mesh`: every stage (gravity, levels, alignment, flat walls, rooms,
   openings), the slicing and the drawings run on it unchanged, and the pen-and-ink plan of a
   cloud is the slices of its splats. The normals are not oriented consistently: the pipeline
   already handles mixed winding (HoloLens meshes mix it too).

The readers share one API, :func:`read_points`, which gives a :class:`PointCloud` in the file's
units with its colours and intensities where the file has them; :func:`load_points` reads,
converts to metres, subsamples and splats, and returns the same
:class:`~meshplan.io.mesh.LoadedMesh` as :func:`~meshplan.io.mesh.load_mesh` (which calls it for
point files). E57 (every scan of the file, each moved by its pose into the file's common frame)
needs the ``pye57`` package and LAS/LAZ ``laspy`` (with ``lazrs`` for LAZ): the ``points`` extra,
``pip install 'meshplan[points]'``.

A LAS/LAZ file's coordinates are in the linear unit its coordinate reference system names
(:func:`las_crs_units`: the OGC WKT record, or the GeoTIFF keys' ``ProjLinearUnitsGeoKey`` and
``VerticalUnitsGeoKey``; the metre, the international foot, the US survey foot), which is then the
scan's unit, exactly (``LoadStats.scale_to_m`` 0.3048006096 for US survey feet), unless
``--units`` names another than the default ``m``. A vertical unit other than the horizontal one
scales z on its own. No ``pyproj`` is needed; a CRS given only as an EPSG code, or geographic (in
degrees), leaves the file in ``--units``.

Why one long module: the point formats' readers, the voxel subsampling, the normal and footprint
estimation and the splats are one path from a file of points to the mesh every stage reads.
"""

from __future__ import annotations

import importlib
import logging
import re
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InputError
from ..geometry import FloatArray, Mesh
from . import readers
from .params import VOXEL_M
from .readers import malformed, truncated

if TYPE_CHECKING:
    from .mesh import LoadedMesh

log = logging.getLogger(__name__)

__all__ = [
    "EPSG_LINEAR_UNITS_M",
    "PCA_NEIGHBOURS",
    "VOXEL_M",
    "CrsUnits",
    "PointCloud",
    "Surfels",
    "estimate_surfels",
    "las_crs_units",
    "load_points",
    "read_points",
    "splat_mesh",
    "voxel_subsample",
    "wkt_units",
]


#: Neighbours of each point in its PCA (the point itself not counted): 16 on a 3 cm grid reach
#: about 7 cm, enough to average 1 cm of phone noise into a normal within a few degrees, small
#: enough to stay on one face of a wall and to blur corners over only about 5 cm.
PCA_NEIGHBOURS = 16

#: Neighbours of each point in the graph along which the normals' signs are made to agree (the
#: nearest of its PCA neighbours): 8 connect a grid through its diagonals, and keep the spanning
#: tree's graph small (8 edges a point).
ORIENT_NEIGHBOURS = 8

#: Largest angle, in degrees, between the normals of two neighbours of one patch when the signs
#: are settled (:func:`orient_normals`): 25 takes in the few degrees of phone noise and a gently
#: curved wall, and stops at corners (90), bevels (45) and a door leaf ajar.
PATCH_ANGLE_DEG = 25.0

#: Rounds in which a point's side, where its rays cannot tell it (both meet a surface: the face
#: of a partition), is taken from its decided neighbours: 20 reach some 60 cm along a surface.
SPREAD_ROUNDS = 20

#: Span of the near rays, metres: from past a point's own surface (its noise and its voxel, some
#: 3 cm) to beyond the thickness of a partition (7 to 30 cm).
NEAR_RAY_M = (0.08, 0.35)

#: Occupancy cell of the near rays, metres: the spacing of a phone scan, so that the other face
#: of a partition shows few holes.
NEAR_RAY_CELL_M = 0.05

#: Occupancy cell of the rays that tell the open side of a patch, metres: 10 cm, coarse enough
#: for a ray to meet a sparse phone scan's wall (points 5 cm apart), fine enough to pass through
#: a door.
RAY_CELL_M = 0.1

#: A ray starts this far from its point, metres: past the thickness of a wall or a slab (the ray
#: out of a partition's face must not meet its other face) and the furniture standing at a wall.
RAY_START_M = 0.5

#: And ends this far, metres: beyond the span of any room (a ray out of an outer wall meets
#: nothing).
RAY_MAX_M = 20.0

#: Points casting rays, at most (a regular stride beyond): 200,000 give every patch of a building
#: its votes in a second or two.
RAY_SAMPLES = 200_000

#: Largest occupancy grid, in cells (bytes): 10 cm cells over 200 x 200 x 25 m; a larger site
#: doubles the cell until it fits.
RAY_GRID_MAX_CELLS = 100_000_000

#: Largest footprint area of one point, in square metres (a point standing for more than 20 x 20
#: cm, four times the spacing of a phone scan, is isolated: a stray return or the edge of a sparse
#: scan, whose k-th neighbour may be metres away; its splat is capped so that it does not draw a
#: metre-wide triangle).
MAX_FOOTPRINT_M2 = 0.04

#: Fewest points a cloud must keep after subsampling to be read as a scan (a room at the grid's
#: density holds tens of thousands; fewer is a fragment, or a mesh file cut short).
MIN_POINTS = 100

#: Points whose neighbourhoods are searched and decomposed at once: bounds the temporary
#: ``(chunk, k, 3)`` arrays to some 100 MB.
SURFEL_CHUNK = 200_000

#: Peak memory per point read, in bytes, to refuse up front a cloud that cannot fit: the whole run
#: of the 10-million-point E57 benchmark (``benchmarks/bench_points.py``) peaked at 1.71 GB, 171
#: bytes a point (the coordinates, colour and intensity, pye57's buffers, the voxel keys and their
#: sort, then the splats of the kept points), rounded up.
BYTES_PER_POINT = 200

#: Text point files are parsed in pieces of about this many bytes (cut at line ends), so that the
#: per-byte temporary arrays stay near 100 MB however large the file.
TEXT_CHUNK_BYTES = 16 * 2**20

#: Fewest bytes of a point line of a text file (``0 0 0`` and a newline), to estimate the points
#: of a text file from its size.
TEXT_MIN_POINT_BYTES = 6

#: What to install for each optional reader.
EXTRA_HINT = "pip install 'meshplan[points]'"

#: Interior angle of the splat's corners about its centre (an equilateral triangle), radians.
_CORNER_ANGLES = np.array([0.0, 2.0 * np.pi / 3.0, 4.0 * np.pi / 3.0])

#: Circumradius of an equilateral triangle of unit area: ``side / sqrt(3)`` with
#: ``side = sqrt(4 / sqrt(3))``.
_UNIT_CIRCUMRADIUS = float(np.sqrt(4.0 / np.sqrt(3.0)) / np.sqrt(3.0))


#: Metres per unit of the linear units a LAS file's GeoTIFF keys name (EPSG unit of measure
#: codes, the values of ``ProjLinearUnitsGeoKey`` and ``VerticalUnitsGeoKey``): the metre, the
#: international foot (0.3048 m exactly), the US survey foot (1200/3937 m: 2 ppm longer, 2 cm
#: over 10 km of state plane coordinates, nothing inside a building, but exact costs nothing),
#: Clarke's foot, the kilometre.
EPSG_LINEAR_UNITS_M = {9001: 1.0, 9002: 0.3048, 9003: 1200.0 / 3937.0, 9005: 0.3047972654, 9036: 1000.0}

#: A CRS's unit is taken for one of ``--units``'s (:data:`meshplan.units.UNITS_M`) when their
#: lengths agree to this relative difference: 1e-4 takes the US survey foot and Clarke's foot
#: (2 and 9 ppm from the international foot) for ``ft``, and tells every named unit apart.
CRS_UNIT_MATCH = 1e-4

#: GeoTIFF keys of a LAS file's GeoKeyDirectoryTag record: the projected CRS's linear unit, the
#: vertical CRS's unit, the geographic CRS's linear unit (geocentric CRSs).
_PROJ_LINEAR_UNITS_KEY, _VERTICAL_UNITS_KEY, _GEOG_LINEAR_UNITS_KEY = 3076, 4099, 2052

#: WKT keywords of a horizontal CRS whose own unit is linear (WKT1 and WKT2), and of a vertical
#: one; a WKT1 ``GEOGCS`` alone has an angular unit (degrees), not used.
_WKT_HORIZONTAL = ("PROJCS", "PROJCRS", "PROJECTEDCRS", "GEOCCS", "LOCAL_CS", "ENGCRS", "ENGINEERINGCRS")
_WKT_VERTICAL = ("VERT_CS", "VERTCRS", "VERTICALCRS")
_WKT_UNITS = ("UNIT", "LENGTHUNIT")


@dataclass(frozen=True)
class CrsUnits:
    """The linear units of a point cloud's coordinate reference system.

    Attributes
    ----------
    horizontal_m, vertical_m
        Metres per unit of x and y, and of z (LAS is z-up); ``vertical_m`` is ``horizontal_m``
        where the CRS names no vertical unit.
    name
        The horizontal unit's name as the file gives it (``US survey foot``, ``metre``, EPSG
        code ``9003``...).
    source
        Where it was read: ``wkt`` (the OGC WKT record) or ``geotiff`` (the GeoKeyDirectoryTag).
    """

    horizontal_m: float
    vertical_m: float
    name: str
    source: str


def _wkt_tree(text: str) -> list:
    """An OGC WKT string (1 or 2) as nested ``[keyword, arg, ...]`` lists, strings unquoted and
    numbers as floats; raises ``ValueError`` where it is not WKT."""
    tokens = re.findall(r'"(?:[^"]|"")*"|[A-Za-z_][A-Za-z0-9_]*|[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|[\[\]\(\),]', text)
    pos = 0

    def node() -> list:
        nonlocal pos
        out: list = [tokens[pos].upper()]
        pos += 1
        if pos < len(tokens) and tokens[pos] in "[(":
            pos += 1
            while tokens[pos] not in "])":
                t = tokens[pos]
                if t == ",":
                    pos += 1
                elif t.startswith('"'):
                    out.append(t[1:-1].replace('""', '"'))
                    pos += 1
                elif t[0].isalpha() or t[0] == "_":
                    out.append(node())
                else:
                    out.append(float(t))
                    pos += 1
            pos += 1
        return out

    try:
        return node()
    except IndexError:
        raise ValueError("unbalanced WKT") from None


def _wkt_unit(crs: list) -> tuple[float, str] | None:
    """The linear unit (metres per unit, name) of one CRS node: its own ``UNIT``/``LENGTHUNIT``
    child, or that of its first axis (WKT2 may put it there)."""
    for child in crs[1:]:
        if isinstance(child, list) and child[0] in _WKT_UNITS and len(child) >= 3 and isinstance(child[2], float):
            return child[2], str(child[1])
    for child in crs[1:]:
        if isinstance(child, list) and child[0] == "AXIS":
            found = _wkt_unit(child)
            if found is not None:
                return found
    return None


def wkt_units(text: str) -> CrsUnits | None:
    """The horizontal and vertical linear units an OGC WKT CRS names (WKT1 ``PROJCS``/
    ``VERT_CS``/``COMPD_CS``, WKT2 ``PROJCRS``/``VERTCRS``/``COMPOUNDCRS``); ``None`` where it
    names no linear horizontal unit (a geographic CRS in degrees, or not WKT)."""
    try:
        tree = _wkt_tree(text)
    except (ValueError, IndexError):
        return None
    horizontal = vertical = None
    stack = [tree]
    while stack:
        n = stack.pop()
        if n[0] in _WKT_HORIZONTAL and horizontal is None:
            horizontal = _wkt_unit(n)
        elif n[0] in _WKT_VERTICAL and vertical is None:
            vertical = _wkt_unit(n)
        elif n[0] not in _WKT_HORIZONTAL + _WKT_VERTICAL:
            stack.extend(c for c in reversed(n[1:]) if isinstance(c, list))
    if horizontal is None or not horizontal[0] > 0:
        return None
    v = vertical[0] if vertical is not None and vertical[0] > 0 else horizontal[0]
    return CrsUnits(horizontal[0], v, horizontal[1], "wkt")


def las_crs_units(header) -> CrsUnits | None:
    """The linear units a LAS/LAZ file's CRS names, from its OGC WKT record (preferred, as LAS
    1.4 asks) or its GeoTIFF keys (``ProjLinearUnitsGeoKey``, ``VerticalUnitsGeoKey``, EPSG unit
    codes :data:`EPSG_LINEAR_UNITS_M`); ``None`` where it names none (no CRS, a geographic CRS in
    degrees, or only an EPSG CRS code: reading what unit that code implies needs the EPSG
    database, which meshplan does not ship; such files are read in ``--units``).

    Parameters
    ----------
    header
        The file's :class:`laspy.LasHeader` (its VLRs and EVLRs are searched).
    """
    records = list(getattr(header, "vlrs", None) or ()) + list(getattr(header, "evlrs", None) or ())
    for rec in records:
        text = getattr(rec, "string", None)
        if type(rec).__name__ == "WktCoordinateSystemVlr" and isinstance(text, str) and text.strip():
            found = wkt_units(text)
            if found is not None:
                return found
    for rec in records:
        keys = getattr(rec, "geo_keys", None)
        if type(rec).__name__ != "GeoKeyDirectoryVlr" or not keys:
            continue
        values = {int(k.id): int(k.value_offset) for k in keys if int(k.tiff_tag_location) == 0}
        code = values.get(_PROJ_LINEAR_UNITS_KEY, values.get(_GEOG_LINEAR_UNITS_KEY))
        if code not in EPSG_LINEAR_UNITS_M:
            if code is not None:
                log.warning("LAS GeoTIFF keys: linear unit code %d not known; the coordinates are read in --units", code)
            continue
        h = EPSG_LINEAR_UNITS_M[code]
        v_code = values.get(_VERTICAL_UNITS_KEY)
        return CrsUnits(h, EPSG_LINEAR_UNITS_M.get(v_code, h) if v_code is not None else h, f"EPSG unit {code}", "geotiff")
    return None


@dataclass(frozen=True, eq=False)
class PointCloud:
    """Points as read from a file.

    Attributes
    ----------
    points
        ``(n, 3)`` float64 coordinates (file units in :func:`read_points`, metres after
        :func:`load_points`).
    colors
        ``(n, 3)`` uint8 RGB, or ``None`` when the file has no colour.
    intensity
        ``(n,)`` float32 return intensity as stored, or ``None``.
    scans
        Number of scans the points came from (E57 files hold several; 1 otherwise).
    float32_extent
        Largest absolute coordinate the file stored as float32 (0 when it stored none).
    crs_units
        The units the file's coordinate reference system names (LAS/LAZ: :func:`las_crs_units`),
        or ``None`` where it names none.
    """

    points: FloatArray
    colors: np.ndarray | None = None
    intensity: np.ndarray | None = None
    scans: int = 1
    float32_extent: float = 0.0
    crs_units: CrsUnits | None = None

    def __len__(self) -> int:
        return int(len(self.points))

    def select(self, keep: np.ndarray) -> PointCloud:
        """The cloud with only the points ``keep`` selects (mask or indices)."""
        return PointCloud(
            self.points[keep],
            None if self.colors is None else self.colors[keep],
            None if self.intensity is None else self.intensity[keep],
            self.scans,
            self.float32_extent,
            self.crs_units,
        )


@dataclass(frozen=True, eq=False)
class Surfels:
    """Oriented surface elements: a point, a unit normal (sign arbitrary) and an area.

    Attributes
    ----------
    points
        ``(n, 3)`` centres, metres.
    normals
        ``(n, 3)`` unit normals of the local tangent plane.
    areas
        ``(n,)`` footprint areas, square metres.
    planarity
        ``(n,)`` share of the neighbourhood's variance off the plane (the smallest eigenvalue
        over their sum): 0 on a flat surface, up to 1/3 for a blob; corners and edges are high.
    """

    points: FloatArray
    normals: FloatArray
    areas: FloatArray
    planarity: FloatArray


# ----------------------------------------------------------------------------------------------
# readers


def require(module: str, what: str, hint: str = EXTRA_HINT) -> ModuleType:
    """Import an optional dependency, or raise a one-line :class:`InputError` saying what to
    install (before any of the file is read).

    Parameters
    ----------
    module
        The module to import (``pye57``, ``laspy``, ``lazrs``, ``pxr``).
    what
        What needs it, e.g. ``"reading E57"``.
    hint
        What to install.
    """
    try:
        return importlib.import_module(module)
    except ImportError:
        raise InputError(f"{what} needs {module.split('.')[0]}", hint) from None


def check_extras(file_type: str) -> None:
    """Refuse, up front, a format whose optional reader is not installed."""
    if file_type == "e57":
        require("pye57", "reading E57")
    elif file_type in ("las", "laz"):
        require("laspy", f"reading {file_type.upper()}")
        if file_type == "laz":
            require("lazrs", "reading LAZ")


def estimate_points(path: Path, file_type: str) -> int:
    """The number of points a file declares (E57, LAS and PLY headers) or could hold (text, from
    its size), without reading the points."""
    if file_type == "e57":
        pye57 = require("pye57", "reading E57")
        try:
            e57 = pye57.E57(str(path))
            try:
                return int(sum(e57.get_header(i).point_count for i in range(e57.scan_count)))
            finally:
                e57.close()
        except Exception as exc:  # libE57 raises its own types for a broken file
            raise _unreadable(path, "E57", exc) from None
    if file_type in ("las", "laz"):
        laspy = require("laspy", f"reading {file_type.upper()}")
        try:
            with laspy.open(str(path)) as fh:
                return int(fh.header.point_count)
        except Exception as exc:
            raise _unreadable(path, file_type.upper(), exc) from None
    if file_type == "ply":
        with open(path, "rb") as fh:
            header = readers.parse_ply_header(path, fh.read(65536))
        vertex = header.element("vertex")
        return vertex.count if vertex is not None else 0
    return path.stat().st_size // TEXT_MIN_POINT_BYTES // 3  # a point line is rarely under ~18 bytes


def _unreadable(path: Path, fmt: str, exc: BaseException) -> InputError:
    reason = " ".join(str(exc).split())[:120] or type(exc).__name__
    return InputError(f"{path}: cannot be read as {fmt} ({reason})", "check that the file is a complete, uncorrupted point cloud export")


def _colors_u8(rgb: np.ndarray) -> np.ndarray:
    """RGB as uint8: 16-bit channels (LAS, some E57) scaled down, 8-bit ones kept."""
    rgb = np.asarray(rgb)
    if rgb.size and float(rgb.max()) > 255:
        rgb = rgb.astype(np.float64) * (255.0 / 65535.0)
    return np.clip(np.rint(rgb), 0, 255).astype(np.uint8)


def _read_e57(path: Path) -> PointCloud:
    """Every scan of an E57 file, each moved by its pose (rotation and translation) into the
    file's common frame; invalid points dropped; intensity and colour where the scan has them."""
    pye57 = require("pye57", "reading E57")
    try:
        e57 = pye57.E57(str(path))
    except Exception as exc:
        raise _unreadable(path, "E57", exc) from None
    parts: list[np.ndarray] = []
    colors: list[np.ndarray | None] = []
    intens: list[np.ndarray | None] = []
    try:
        for i in range(e57.scan_count):  # a handful of scans, each read at once
            fields = set(e57.get_header(i).point_fields)
            has_rgb = {"colorRed", "colorGreen", "colorBlue"} <= fields
            data = e57.read_scan(i, intensity="intensity" in fields, colors=has_rgb, transform=True, ignore_missing_fields=True)
            parts.append(np.stack([data["cartesianX"], data["cartesianY"], data["cartesianZ"]], axis=1).astype(np.float64, copy=False))
            colors.append(_colors_u8(np.stack([data["colorRed"], data["colorGreen"], data["colorBlue"]], axis=1)) if has_rgb else None)
            intens.append(np.asarray(data["intensity"], np.float32) if "intensity" in data else None)
            del data
        scans = e57.scan_count
    except InputError:
        raise
    except Exception as exc:
        raise _unreadable(path, "E57", exc) from None
    finally:
        e57.close()
    if not parts:
        raise InputError(f"{path}: the E57 file holds no scan", "export the point cloud again")
    points = np.concatenate(parts)
    del parts
    # colour and intensity kept only when every scan has them (else they would not line up)
    rgb = [c for c in colors if c is not None]
    its = [t for t in intens if t is not None]
    color = np.concatenate(rgb) if len(rgb) == len(colors) else None
    intensity = np.concatenate(its) if len(its) == len(intens) else None
    return PointCloud(points, color, intensity, scans)


def _read_las(path: Path, file_type: str) -> PointCloud:
    """A LAS or LAZ file (laspy; LAZ through lazrs): scaled coordinates, intensity, RGB when the
    point format has it."""
    laspy = require("laspy", f"reading {file_type.upper()}")
    if file_type == "laz":
        require("lazrs", "reading LAZ")
    try:
        las = laspy.read(str(path))
    except Exception as exc:
        raise _unreadable(path, file_type.upper(), exc) from None
    points = np.stack([np.asarray(las.x, np.float64), np.asarray(las.y, np.float64), np.asarray(las.z, np.float64)], axis=1)
    names = set(las.point_format.dimension_names)
    color = _colors_u8(np.stack([np.asarray(las.red), np.asarray(las.green), np.asarray(las.blue)], axis=1)) if {"red", "green", "blue"} <= names else None
    intensity = np.asarray(las.intensity, np.float32) if "intensity" in names else None
    return PointCloud(points, color, intensity, crs_units=las_crs_units(las.header))


#: Colour property names of PLY vertices (the usual spellings).
_PLY_RGB = (("red", "green", "blue"), ("r", "g", "b"), ("diffuse_red", "diffuse_green", "diffuse_blue"))


def ply_holds_points_only(path: Path) -> bool:
    """Whether a PLY file holds vertices and no faces (a point cloud), from its header."""
    with open(path, "rb") as fh:
        head = fh.read(65536)
    try:
        header = readers.parse_ply_header(path, head)
    except InputError:
        return False  # the mesh reader says what is wrong
    vertex, face = header.element("vertex"), header.element("face")
    return vertex is not None and vertex.count > 0 and (face is None or face.count == 0)


def _read_ply(path: Path) -> PointCloud:
    """The vertices of a PLY point cloud with their colour and intensity (binary or ascii; a
    vertex element with list properties, or after another element, is read without them)."""
    data = path.read_bytes()
    header = readers.parse_ply_header(path, data[:65536])
    vertex = header.element("vertex")
    if vertex is None:
        raise malformed(path, "PLY", "no vertex element")
    names = [p.name for p in vertex.properties]
    if not all(c in names for c in "xyz"):
        raise malformed(path, "PLY", "its vertices have no x, y and z")
    first = header.elements[0] is vertex
    if not first or any(p.is_list for p in vertex.properties):
        raw = readers.read_ply(path)
        return PointCloud(raw.vertices, float32_extent=raw.float32_extent)
    n = vertex.count
    if header.format == "ascii":
        body = np.frombuffer(readers._prepare_text(data[header.data_start :]), np.uint8)
        del data
        counts, values = readers.tokenize_lines(body)
        if not len(values) and counts.sum():
            raise malformed(path, "PLY", "a value is not a number")
        counts = counts[counts > 0]
        held = min(n, readers._first_short(counts[:n] == len(names)))
        if held < n:
            if held < len(counts) - 1:
                raise malformed(path, "PLY", f"vertex {held + 1} has fewer values than the header says")
            raise truncated(path, f"{n:,} vertices", f"{held:,}")
        table = values[: n * len(names)].reshape(n, len(names))
        cols = {name: table[:, i] for i, name in enumerate(names)}
    else:
        endian = "<" if header.format == "binary_little_endian" else ">"
        dt = np.dtype([(p.name, endian + p.dtype) for p in vertex.properties])
        held = min(n, (len(data) - header.data_start) // dt.itemsize)
        if held < n:
            raise truncated(path, f"{n:,} vertices", f"{held:,}")
        rec = np.frombuffer(data, dt, count=n, offset=header.data_start)
        cols = {name: rec[name] for name in names}
    points = np.stack([cols[c].astype(np.float64) for c in "xyz"], axis=1)
    f32 = [i for i, c in enumerate("xyz") if cols[c].dtype == np.float32]
    stored = points[:, f32]
    extent = float(np.abs(stored).max(initial=0.0, where=np.isfinite(stored))) if f32 else 0.0
    rgb = next((t for t in _PLY_RGB if all(c in cols for c in t)), None)
    color = _colors_u8(np.stack([cols[c] for c in rgb], axis=1)) if rgb else None
    key = next((k for k in ("intensity", "scalar_intensity", "scalar_Intensity") if k in cols), None)
    intensity = np.asarray(cols[key], np.float32) if key else None
    return PointCloud(points, color, intensity, 1, extent)


#: Lines of a text point file that do not start with a number (a header naming the columns, a
#: ``//`` comment) are skipped.
_NOT_A_NUMBER_LINE = re.compile(rb"(?m)^[ ]*[^-+.0-9 \n][^\n]*")

#: Separators of text point files besides spaces: tabs, commas (CSV), semicolons.
_TEXT_SEPARATORS = bytes.maketrans(b"\t,;\r", b"    ")


def _text_chunks(path: Path):
    """The file in pieces of about :data:`TEXT_CHUNK_BYTES` that end at a line end."""
    with open(path, "rb") as fh:
        rest = b""
        while True:
            block = fh.read(TEXT_CHUNK_BYTES)
            if not block:
                if rest:
                    yield rest
                return
            data = rest + block
            cut = data.rfind(b"\n") + 1
            if cut <= 0:
                rest = data
                continue
            rest = data[cut:]
            yield data[:cut]


def _colour_like(values: np.ndarray) -> bool:
    """Whether columns hold 0-255 integer colours (not normals or other scalars)."""
    return bool(len(values)) and bool(np.all((values >= 0) & (values <= 255) & (values == np.round(values)))) and float(values.max()) > 1


def _read_text(path: Path, file_type: str) -> PointCloud:
    """XYZ, PTS and TXT point files: one point a line, ``x y z`` then optional columns, separated
    by spaces, tabs, commas or semicolons; lines that do not start with a number (headers, ``//``
    comments) and ``#`` comments are skipped, as is the point count PTS puts first.

    Columns after ``x y z`` are read by their number: 4 is an intensity; 6 gives RGB when the three
    extra columns are 0-255 integers (else normals, ignored); 7 or more is the PTS order ``x y z
    intensity r g b`` when columns 5-7 are colours, else ``x y z r g b ...`` when 4-6 are.
    """
    blocks: list[np.ndarray] = []
    ncol = 0
    dropped = 0
    for chunk in _text_chunks(path):
        text = chunk.translate(_TEXT_SEPARATORS)
        if text.startswith(readers.UTF8_BOM):
            text = text[len(readers.UTF8_BOM) :]
        text = _NOT_A_NUMBER_LINE.sub(b"", readers._prepare_text(text))
        counts, values = readers.tokenize_lines(np.frombuffer(text, np.uint8))
        if not len(values) and counts.sum():
            raise malformed(path, file_type.upper(), "a value is not a number")
        if not ncol:
            full = counts[counts >= 3]
            if not len(full):
                continue
            ncol = int(np.bincount(full).argmax())  # the usual column count of the file
        first = np.cumsum(counts) - counts
        keep = counts == ncol
        dropped += int(np.count_nonzero((counts > 0) & ~keep))
        blocks.append(values[first[keep, None] + np.arange(ncol)])
    if not ncol:
        raise InputError(f"{path}: holds no point (no line of three or more numbers)", f"check that the file is an {file_type.upper()} point cloud")
    table = np.concatenate(blocks)
    del blocks
    if dropped > max(1, len(table) // 100):  # the PTS count line and a stray line or two are fine
        raise malformed(path, file_type.upper(), f"{dropped:,} lines do not have the {ncol} columns of the others")
    color = intensity = None
    if ncol == 4:
        intensity = table[:, 3].astype(np.float32)
    elif ncol == 6 and _colour_like(table[:, 3:6]):
        color = table[:, 3:6]
    elif ncol >= 7 and _colour_like(table[:, 4:7]):
        intensity, color = table[:, 3].astype(np.float32), table[:, 4:7]
    elif ncol >= 7 and _colour_like(table[:, 3:6]):
        color = table[:, 3:6]
    return PointCloud(np.ascontiguousarray(table[:, :3]), None if color is None else _colors_u8(color), intensity)


def read_points(path: str | Path, file_type: str | None = None) -> PointCloud:
    """Read a point cloud file, in the file's units.

    Parameters
    ----------
    path
        E57, LAS, LAZ, PLY (vertices, no faces), XYZ, PTS, TXT or OBJ (``v`` lines only) file.
    file_type
        The format (``e57``, ``las``, ``laz``, ``ply``, ``xyz``, ``pts``, ``txt``, ``obj``);
        ``None`` takes it from the extension.

    Returns
    -------
    PointCloud
        The points with their colour and intensity where the file has them.

    Raises
    ------
    InputError
        When the format's reader is not installed (one line, saying what to install), or the file
        cannot be read.
    """
    p = Path(path)
    ft = (file_type or p.suffix.lower().lstrip(".")).lower()
    check_extras(ft)
    if ft == "e57":
        return _read_e57(p)
    if ft in ("las", "laz"):
        return _read_las(p, ft)
    if ft == "ply":
        return _read_ply(p)
    if ft in ("xyz", "pts", "txt"):
        return _read_text(p, ft)
    if ft in ("obj", "off"):
        raw = readers.read_obj(p) if ft == "obj" else readers.read_off(p)
        return PointCloud(raw.vertices)
    raise InputError(f"{p}: unknown point cloud format {ft!r}", "use E57, LAS, LAZ, PLY, XYZ, PTS or TXT")


# ----------------------------------------------------------------------------------------------
# subsampling, surfels, splats


def voxel_subsample(cloud: PointCloud, voxel_m: float) -> tuple[PointCloud, np.ndarray]:
    """One point per occupied voxel of a grid of ``voxel_m``, at the mean of its points.

    Parameters
    ----------
    cloud
        Points in metres (finite).
    voxel_m
        Edge of the voxels, metres.

    Returns
    -------
    cloud
        The voxels' mean points, colours and intensities, in the order of the voxels' keys.
    counts
        ``(m,)`` number of input points in each voxel.

    Raises
    ------
    InputError
        When the cloud spans more than ``2**21`` voxels along an axis (tens of kilometres at the
        default size: coordinates in the wrong units).
    """
    pts = cloud.points
    if not len(pts):
        return cloud, np.zeros(0, np.int64)
    lo = pts.min(axis=0)
    q = np.floor((pts - lo) / voxel_m).astype(np.int64)
    span = q.max(axis=0)
    if np.any(span >= 2**21):
        extent = (span.max() + 1) * voxel_m
        raise InputError(
            f"the point cloud spans {extent / 1000:,.0f} km, more than a building",
            "check the units (--units) and that the file holds one site",
        )
    key = (q[:, 0] << 42) | (q[:, 1] << 21) | q[:, 2]
    del q
    order = np.argsort(key, kind="stable")
    k = key[order]
    starts = np.flatnonzero(np.r_[True, k[1:] != k[:-1]])
    del k, key
    counts = np.diff(np.r_[starts, len(order)])
    # sums per voxel over the sorted points: reduceat, no per-voxel loop
    mean = np.add.reduceat(pts[order] - lo, starts, axis=0) / counts[:, None] + lo
    colors = intensity = None
    if cloud.colors is not None:
        colors = np.clip(np.rint(np.add.reduceat(cloud.colors[order].astype(np.float64), starts, axis=0) / counts[:, None]), 0, 255).astype(np.uint8)
    if cloud.intensity is not None:
        intensity = (np.add.reduceat(cloud.intensity[order].astype(np.float64), starts) / counts).astype(np.float32)
    return PointCloud(mean, colors, intensity, cloud.scans, cloud.float32_extent), counts


def estimate_surfels(points: FloatArray, k: int = PCA_NEIGHBOURS, orient: bool = True) -> Surfels:
    """Normal and footprint area of every point from its ``k`` nearest neighbours.

    The normal is the eigenvector of the least eigenvalue of the neighbourhood's covariance (its
    sign arbitrary); the footprint area ``pi r_k^2 / k``, with ``r_k`` the largest distance of a
    neighbour from the point within the tangent plane, capped at :data:`MAX_FOOTPRINT_M2`.

    Parameters
    ----------
    points
        ``(n, 3)`` points, metres (subsampled: one a voxel).
    k
        Neighbours, the point itself not counted.
    orient
        Make the normals' signs agree between neighbours (:func:`orient_normals`).

    Returns
    -------
    Surfels
    """
    from scipy.spatial import cKDTree

    pts = np.ascontiguousarray(points, dtype=np.float64)
    n = len(pts)
    normals = np.zeros((n, 3))
    areas = np.zeros(n)
    planarity = np.zeros(n)
    kk = min(k, n - 1)
    if kk < 2:
        return Surfels(pts, normals, areas, planarity)
    tree = cKDTree(pts, balanced_tree=False, compact_nodes=False)  # faster to build, as fast to query
    kg = min(ORIENT_NEIGHBOURS, kk)
    graph = np.empty((n, kg), np.int64)
    for s in range(0, n, SURFEL_CHUNK):  # chunks bound the (chunk, k, 3) temporaries
        e = min(n, s + SURFEL_CHUNK)
        _, idx = tree.query(pts[s:e], k=kk + 1, workers=-1)
        graph[s:e] = idx[:, 1 : kg + 1]
        nb = pts[idx] - pts[s:e, None, :]  # neighbours about the point (the first is the point)
        centred = nb - nb.mean(axis=1, keepdims=True)
        cov = np.einsum("nki,nkj->nij", centred, centred) / (kk + 1)
        w, v = np.linalg.eigh(cov)  # ascending eigenvalues
        nrm = v[:, :, 0]
        normals[s:e] = nrm
        total = w.sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            planarity[s:e] = np.where(total > 0, np.maximum(w[:, 0], 0.0) / total, 0.0)
        along = np.einsum("nki,ni->nk", nb, nrm)
        r2 = np.einsum("nki,nki->nk", nb, nb) - along * along  # squared distances in the tangent plane
        areas[s:e] = np.minimum(np.pi * r2.max(axis=1) / kk, MAX_FOOTPRINT_M2)
    if orient:
        normals = orient_normals(pts, normals, graph)
    return Surfels(pts, normals, areas, planarity)


def orient_normals(points: FloatArray, normals: FloatArray, neighbours: np.ndarray) -> FloatArray:
    """Normals turned to face the open space in front of them, patch by patch.

    The facing stage (:func:`meshplan.orient.facing.inward_flips`) turns each connected patch of
    a mesh by its floors and walls, and a patch that says nothing by the majority of the scan.
    Each splat is a patch of its own, and a wall splat whose floor probes find nothing (a sparse
    phone scan leaves a third of the 5 cm floor cells empty) follows the majority: with random
    signs that is a coin toss, and the walls come out twice, facing both ways (walls F1 0.85
    instead of 0.99 on the synthetic apartment). So the signs are settled here:

    1. *patches*: points joined to neighbours whose normals are within
       :data:`PATCH_ANGLE_DEG` (a wall, a floor, a table top), each patch made to agree with
       itself along a breadth-first tree (each point's sign relative to its patch's first point
       is the product of the signs on its path, for all points at once by pointer doubling);
       no sign is handed round a corner, where it is ambiguous;
    2. *rays*: from every point (a stride of them beyond :data:`RAY_SAMPLES`), a ray along the
       normal and one against it, from :data:`RAY_START_M` (past the wall's own thickness) to
       :data:`RAY_MAX_M`, through an occupancy grid of :data:`RAY_CELL_M` cells: in a room
       scanned from inside, the ray into the room meets the opposite wall and the ray out of it
       meets nothing. Each patch takes the side most of its rays say.

    Parameters
    ----------
    points
        ``(n, 3)`` points, metres.
    normals
        ``(n, 3)`` unit normals, signs arbitrary.
    neighbours
        ``(n, m)`` indices of each point's nearest neighbours.

    Returns
    -------
    FloatArray
        ``(n, 3)`` the normals, some reversed.
    """
    n, m = neighbours.shape
    if n < 2 or m == 0:
        return normals
    votes = _ray_votes(points, normals)
    # each edge between near-parallel neighbours hands a decided vote on, turned by the sign
    # between the two normals; undecided points take their decided neighbours' majority
    rows = np.repeat(np.arange(n), m)
    cols = neighbours.reshape(-1)
    dot = np.einsum("ij,ij->i", normals[rows], normals[cols])
    keep = np.abs(dot) >= np.cos(np.radians(PATCH_ANGLE_DEG))
    rows, cols, turn = rows[keep], cols[keep], np.where(dot[keep] < 0, -1.0, 1.0)
    del dot, keep
    decided = votes.copy()
    for _ in range(SPREAD_ROUNDS):  # each round reaches one neighbour further
        spread = np.bincount(rows, weights=turn * np.sign(decided[cols]), minlength=n)
        undecided = decided == 0
        if not undecided.any():
            break
        decided[undecided] = np.sign(spread[undecided])
    return np.where((decided < 0)[:, None], -normals, normals)


def _occupancy(points: FloatArray, cell: float) -> tuple[np.ndarray, FloatArray, float]:
    """A boolean grid of the cells holding a point, its origin and its cell (doubled until the
    grid has at most :data:`RAY_GRID_MAX_CELLS` cells)."""
    lo = points.min(axis=0) - cell
    while True:
        shape = np.floor((points.max(axis=0) + cell - lo) / cell).astype(np.int64) + 1
        if int(np.prod(shape)) <= RAY_GRID_MAX_CELLS:
            break
        cell *= 2.0
    grid = np.zeros(tuple(shape), dtype=bool)
    c = np.floor((points - lo) / cell).astype(np.int64)
    grid[c[:, 0], c[:, 1], c[:, 2]] = True
    return grid, lo, cell


def _cast(grid: np.ndarray, lo: FloatArray, cell: float, origin: FloatArray, step: FloatArray, start: float, stop: float) -> np.ndarray:
    """Whether each ray ``origin + t step``, ``start <= t < stop``, meets an occupied cell."""
    shape = np.array(grid.shape)
    hits = np.zeros(len(origin), dtype=bool)
    active = np.arange(len(origin))
    for t in np.arange(start, stop, cell):  # some 200 steps at most, each over the rays still going
        q = np.floor((origin[active] + t * step[active] - lo) / cell).astype(np.int64)
        inside = np.all((q >= 0) & (q < shape), axis=1)
        hit = np.zeros(len(active), dtype=bool)
        hit[inside] = grid[q[inside, 0], q[inside, 1], q[inside, 2]]
        hits[active[hit]] = True
        active = active[~hit & inside]
        if not len(active):
            break
    return hits


def _ray_votes(points: FloatArray, normals: FloatArray) -> FloatArray:
    """``(n,)`` +1 where a point's open side is the one its normal points to, -1 where it is
    the other, 0 where its rays cannot tell (or off the stride of :data:`RAY_SAMPLES`).

    Near rays first (:data:`NEAR_RAY_M`): behind the face of a partition, its other face; in
    front, the room. Where they tell nothing (both or neither meet a surface), far rays
    (:data:`RAY_START_M` to :data:`RAY_MAX_M`): in front of an outer wall the opposite wall, behind
    it nothing.
    """
    n = len(points)
    votes = np.zeros(n)
    sample = np.arange(0, n, max(1, n // RAY_SAMPLES))
    o, d = points[sample], normals[sample]
    grid, lo, cell = _occupancy(points, NEAR_RAY_CELL_M)
    front = _cast(grid, lo, cell, o, d, NEAR_RAY_M[0], NEAR_RAY_M[1])
    back = _cast(grid, lo, cell, o, -d, NEAR_RAY_M[0], NEAR_RAY_M[1])
    near = back.astype(np.float64) - front
    del grid
    grid, lo, cell = _occupancy(points, RAY_CELL_M)
    far = _cast(grid, lo, cell, o, d, RAY_START_M, RAY_MAX_M).astype(np.float64) - _cast(grid, lo, cell, o, -d, RAY_START_M, RAY_MAX_M)
    votes[sample] = np.where(near != 0, near, far)
    return votes


def splat_mesh(surfels: Surfels) -> Mesh:
    """One equilateral triangle per surfel, in its tangent plane, centred on its point, of its
    footprint area; its winding follows the surfel's normal. Surfels of zero area are left out.

    Parameters
    ----------
    surfels
        Points, unit normals and areas.

    Returns
    -------
    Mesh
        ``3 n`` vertices (none shared) and ``n`` faces.
    """
    ok = surfels.areas > 0
    p, nrm, area = surfels.points[ok], surfels.normals[ok], surfels.areas[ok]
    # a tangent basis (u, v, n), right-handed: u across the axis the normal is least along
    axis = np.zeros_like(nrm)
    axis[np.arange(len(nrm)), np.argmin(np.abs(nrm), axis=1)] = 1.0
    u = np.cross(nrm, axis)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(nrm, u)
    r = _UNIT_CIRCUMRADIUS * np.sqrt(area)
    cos, sin = np.cos(_CORNER_ANGLES), np.sin(_CORNER_ANGLES)
    corners = p[:, None, :] + r[:, None, None] * (cos[None, :, None] * u[:, None, :] + sin[None, :, None] * v[:, None, :])
    faces = np.arange(3 * len(p), dtype=np.int64).reshape(-1, 3)
    return Mesh(corners.reshape(-1, 3), faces)


def _crs_scale(path: Path, crs: CrsUnits | None, units: str, scale: float, explicit: bool) -> tuple[str, float, FloatArray]:
    """The units a cloud is read in: its CRS's (:class:`CrsUnits`) unless the user named
    ``units`` (``explicit``, ``m`` included). Returns the unit's name, metres per unit of x and y (the scale
    of :attr:`LoadStats.scale_to_m`) and the ``(3,)`` metres per unit of x, y and z (LAS's z is
    vertical, and its CRS may name another unit for it)."""
    from ..units import UNITS_M

    same = np.full(3, scale)
    if crs is None:
        return units, scale, same
    if explicit:
        if abs(crs.horizontal_m - scale) > CRS_UNIT_MATCH * scale:
            log.warning("%s: its CRS says %s (%.10g m), read in --units %s as asked", path, crs.name, crs.horizontal_m, units)
        return units, scale, same
    name = next((u for u, m in UNITS_M.items() if abs(m - crs.horizontal_m) <= CRS_UNIT_MATCH * m), None)
    if name is None:
        log.warning("%s: its CRS's unit %s (%.10g m) is none of --units's; read in metres", path, crs.name, crs.horizontal_m)
        return units, scale, same
    axes = np.array([crs.horizontal_m, crs.horizontal_m, crs.vertical_m])
    log.info(
        "%s: units from its CRS (%s record): %s, %.10g m (vertical %.10g m); --units overrides",
        path, crs.source, crs.name, crs.horizontal_m, crs.vertical_m,
    )
    if crs.vertical_m != crs.horizontal_m:
        log.warning("%s: its CRS's vertical unit (%.10g m) differs from its horizontal one; annotations are scaled by the horizontal", path, crs.vertical_m)
    return name, crs.horizontal_m, axes


def load_points(
    path: str | Path,
    file_type: str | None = None,
    units: str = "m",
    max_faces: int | None = None,
    voxel_m: float = VOXEL_M,
    cloud: PointCloud | None = None,
    units_explicit: bool | None = None,
) -> LoadedMesh:
    """Read a point cloud into metres, subsample it and turn it into splats.

    Parameters
    ----------
    path
        A point cloud file (see :func:`read_points`).
    file_type
        Its format; ``None`` takes it from the extension.
    units
        Unit of the file's coordinates.
    max_faces
        Refuse clouds that keep more points than this after subsampling (one splat a point);
        ``None`` refuses, before reading, only clouds that cannot fit in the available memory.
    voxel_m
        Voxel size of the subsampling grid, metres (:data:`VOXEL_M`).
    cloud
        The points, already read (an OBJ found to hold only vertices); ``None`` reads ``path``.
    units_explicit
        Whether the user named ``units``: then they override the CRS's units, ``m`` too;
        ``None``: named when other than the default ``m``.

    Returns
    -------
    LoadedMesh
        The splats as the mesh, ``stats`` with the points read and kept, and ``cloud``: the
        subsampled points with their colours, intensities, normals and areas.

    Raises
    ------
    InputError
        When a needed reader is not installed, the file cannot be read, it is too large, or it
        holds too few points.
    """
    from .mesh import LoadedMesh, LoadStats, available_memory_bytes, check_units, float32_warning

    scale = check_units(units)
    p = Path(path)
    ft = (file_type or p.suffix.lower().lstrip(".")).lower()
    if cloud is None:
        check_extras(ft)  # before anything is read
        n_est = estimate_points(p, ft)
        avail = available_memory_bytes() if max_faces is None else None
        need = n_est * BYTES_PER_POINT
        if avail is not None and need > avail:
            raise InputError(
                f"{p}: about {n_est:,} points would need about {need / 1e9:.1f} GB of memory and {avail / 1e9:.1f} GB are available",
                f"subsample the point cloud, or pass --max-faces {n_est} to try anyway",
            )
        cloud = read_points(p, ft)
    units, scale, axes = _crs_scale(p, cloud.crs_units, units, scale, units != "m" if units_explicit is None else units_explicit)
    n_read = len(cloud)
    finite = np.all(np.isfinite(cloud.points), axis=1)
    if not finite.all():
        cloud = cloud.select(finite)
    metric = PointCloud(cloud.points * axes, cloud.colors, cloud.intensity, cloud.scans, cloud.float32_extent)
    kept, _ = voxel_subsample(metric, voxel_m)
    del metric
    if len(kept) < MIN_POINTS:
        raise InputError(
            f"{p}: holds points but no triangles, and only {len(kept):,} points at a {voxel_m * 100:g} cm spacing: "
            "too few for a point-cloud scan (or a file cut short)",
            "export the whole point cloud, or mesh the point cloud first (e.g. Poisson reconstruction) or export the scan as a mesh",
        )
    if max_faces is not None and len(kept) > max_faces:
        raise InputError(
            f"{p}: {len(kept):,} points after subsampling to {voxel_m * 100:g} cm, more than --max-faces {max_faces:,}",
            f"subsample the point cloud, or raise --max-faces to {len(kept)}",
        )
    surfels = estimate_surfels(kept.points)
    mesh = splat_mesh(surfels)
    log.info("%s: %d points read, %d kept on a %g m grid, %d splats", p, n_read, len(kept), voxel_m, mesh.n_faces)
    stats = LoadStats(
        path=str(p),
        format=ft,
        units=units,
        scale_to_m=scale,
        objects=cloud.scans,
        vertices_read=n_read,
        faces_read=0,
        dropped_nonfinite=0,
        dropped_degenerate=0,
        dropped_duplicate=0,
        vertices=mesh.n_vertices,
        faces=mesh.n_faces,
        points_read=n_read,
        points=len(kept),
        dropped_nonfinite_points=int(n_read - finite.sum()),
    )
    warnings = tuple(w for w in [float32_warning(p, cloud.float32_extent, scale)] if w)
    return LoadedMesh(mesh=mesh, stats=stats, warnings=warnings, cloud=kept, surfels=surfels)


"""Reading scanned meshes into plain arrays, with the clean-up every scan needs.

OBJ (including the multi-object exports of the HoloLens Device Portal), PLY (ascii and binary)
and OFF are read by meshplan's own readers (:mod:`meshplan.io.readers`: float64, polygons
fan-triangulated, truncation detected); GLB/glTF (the scene graph flattened with its node
transforms) and STL by trimesh. Before anything is read, the file must be a regular file whose
header does not declare more than it holds, and the mesh must fit in the memory left (host and
cgroup limit). Whatever the file holds is flattened into one :class:`~meshplan.geometry.Mesh` in
metres, and the faces that cannot be used are dropped and counted:

* faces touching a vertex with a NaN or infinite coordinate,
* degenerate faces (a repeated vertex, or an area below ``1e-12`` m2),
* duplicate faces (the same three vertices, in any order), keeping the first.

Vertices at exactly the same position are merged, so that faces of one surface are connected
even when an exporter wrote each object with its own vertices.

Why one long module: every format's checks before reading (size, header, memory) and the common
cleaning after it run in one entry point, :func:`load_mesh`, and share the format tables.
"""

from __future__ import annotations

import json
import logging
import os
import stat
import struct
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import InputError, ParameterError
from ..geometry import Mesh
from ..units import UNITS_M
from . import readers
from .readers import REEXPORT, RawMesh, truncated

if TYPE_CHECKING:  # pragma: no cover
    from .usd import RoomPlanElements

log = logging.getLogger(__name__)

#: File extensions meshplan reads, with the trimesh file type for each.
#: The up direction that a mesh format defines (input coordinates): glTF 2.0 is +y up by its
#: specification ("glTF uses a right-handed coordinate system ... +Y is up"), and a USD stage
#: states its ``upAxis``, which :func:`meshplan.io.usd.read_usd` turns to +y. OBJ, PLY, STL and
#: OFF define none. A prior for the up search only (``declared_up`` of
#: :func:`meshplan.orient.gravity.estimate_gravity`), carried in :attr:`LoadStats.declared_up`.
DECLARED_UP = {
    "glb": (0.0, 1.0, 0.0),
    "gltf": (0.0, 1.0, 0.0),
    **{ext.lstrip("."): (0.0, 1.0, 0.0) for ext in (".usd", ".usda", ".usdc", ".usdz")},
}

#: Bytes read from the start of an OBJ file to recognise a HoloLens Device Portal export.
_SNIFF_BYTES = 4096

#: The lines a HoloLens Device Portal export (Windows Device Portal, 3D View, "Save" of the
#: spatial mapping mesh) is made of: one ``o Object.<n>`` per surface, then its ``v``, ``vn``
#: and ``f`` lines, blank lines between the surfaces; no comment, material or group line.
_DEVICE_PORTAL_LINES = (b"v ", b"vn ", b"f ", b"o Object.")


def device_frame_up(path: Path, file_type: str) -> tuple[float, float, float] | None:
    """The up of the device frame a scan file was written in, where its writer is known to
    write one: ``(0, 1, 0)`` for a HoloLens Device Portal OBJ, else ``None``.

    HoloLens spatial mapping meshes are expressed in a stationary frame of reference whose +y
    axis the device aligns against gravity (its inertial sensors), and the Device Portal saves
    them in it as they are. Unlike a file format's convention (:data:`DECLARED_UP`), which an
    exporter may ignore, this up is measured: it outweighs the geometry of a scan fragment
    with more wall than floor (``declared_by="device"`` of
    :func:`meshplan.orient.gravity.estimate_gravity`). Recognised by the export's own layout:
    it begins (after blank lines) with ``o Object.1``, and its first lines hold nothing but
    ``o Object.<n>``, ``v``, ``vn`` and ``f`` statements.
    """
    if file_type != "obj":
        return None
    try:
        with open(path, "rb") as f:
            head = f.read(_SNIFF_BYTES)
    except OSError:
        return None
    lines = head.replace(b"\r", b"").split(b"\n")
    if len(head) == _SNIFF_BYTES:
        lines = lines[:-1]  # the last line may be cut short
    lines = [ln for ln in lines if ln.strip()]
    if not lines or lines[0].rstrip() != b"o Object.1" or len(lines) < 2:
        return None
    if not all(ln.startswith(_DEVICE_PORTAL_LINES) for ln in lines):
        return None
    return (0.0, 1.0, 0.0)


MESH_FORMATS = {".obj": "obj", ".ply": "ply", ".glb": "glb", ".gltf": "gltf", ".stl": "stl", ".off": "off"}

#: Point cloud extensions (:mod:`meshplan.io.points`; E57 and LAS/LAZ need the ``points`` extra).
#: PLY and OBJ files holding vertices and no faces are read as point clouds too.
POINT_FORMATS = {".e57": "e57", ".las": "las", ".laz": "laz", ".xyz": "xyz", ".pts": "pts", ".txt": "txt"}

#: USD stage extensions (:mod:`meshplan.io.usd`; the ``usd`` extra, usd-core).
USD_FORMATS = {".usd": "usd", ".usda": "usda", ".usdc": "usdc", ".usdz": "usdz"}

#: Every extension meshplan reads as a scan, with its format: the one list ``meshplan run`` checks
#: and ``meshplan batch`` discovers (through :func:`is_scan_file`).
SCAN_FORMATS = {**MESH_FORMATS, **POINT_FORMATS, **USD_FORMATS}

#: What a scan may be, for messages.
SCAN_FORMAT_NAMES = "OBJ, PLY, GLB, glTF, STL, OFF, E57, LAS, LAZ, XYZ, PTS, TXT or USD/USDZ"

#: Extensions other files share (notes, logs): such a file is taken as a scan by a batch only
#: when its first line that is not a comment holds three numbers.
AMBIGUOUS_EXTENSIONS = (".txt",)

#: Length units accepted by ``--units``, in metres.

#: Peak memory meshplan needs per input face, measured on the 3-million-face benchmark
#: (about 0.9 kB/face including the plans); used to refuse meshes that cannot fit up front.
BYTES_PER_FACE = 1000

#: Smallest triangle area kept, in square metres (after unit conversion).
MIN_FACE_AREA_M2 = 1e-12

#: A header that declares more than this many times the data its file could hold, even at the
#: most compact encoding, is called corrupt rather than cut short (a copy or download that
#: stopped early keeps most of the file), and is refused before its count feeds the memory check.
LYING_HEADER_FACTOR = 4

#: Precision, in metres, below which float32 storage goes unremarked: a millimetre is finer than
#: any scan's noise; beyond it (float32 keeps 7 digits: 0.25 m at a georeferenced 5e6 m) meshplan
#: warns that the file lost precision before it was read.
FLOAT32_PRECISION_WARN_M = 1e-3

#: Fewest bytes of an ASCII OFF vertex line (``0 0 0`` and a newline) and face line
#: (``3 0 0 0``), to bound what a header may declare.
OFF_MIN_VERTEX_BYTES, OFF_MIN_FACE_BYTES = 6, 8

#: Fewest bytes per triangle in a GLB: three one-byte indices.
GLB_MIN_FACE_BYTES = 3

#: cgroup file system (v2 unified hierarchy, or v1 with a ``memory`` controller directory).
CGROUP_ROOT = Path("/sys/fs/cgroup")

#: cgroup v1 reports "no limit" as a huge number (2**63 rounded down to a page); anything above
#: this many bytes (1 EB) is no limit.
CGROUP_NO_LIMIT_BYTES = 2**60


@dataclass(frozen=True)
class LoadStats:
    """What was read from the input file and what was dropped."""

    path: str
    format: str
    units: str
    scale_to_m: float
    objects: int
    vertices_read: int
    faces_read: int
    dropped_nonfinite: int
    dropped_degenerate: int
    dropped_duplicate: int
    vertices: int
    faces: int
    #: point clouds only (:mod:`meshplan.io.points`): points read, kept after subsampling (one
    #: splat each), and dropped for a NaN or infinite coordinate; 0 for meshes
    points_read: int = 0
    points: int = 0
    dropped_nonfinite_points: int = 0
    #: a RoomPlan export's own elements (:class:`~meshplan.io.usd.RoomPlanElements`: its wall,
    #: door, window, opening and object boxes, input coordinates), which the plan stage uses as
    #: such (:func:`meshplan.plan.parametric.apply_parametric`); ``None`` for any other scan.
    #: Not in :meth:`to_dict` (``plan.json``'s ``input`` counts them).
    parametric: RoomPlanElements | None = field(default=None, compare=False, repr=False)
    #: the up direction the file's format declares (input coordinates, :data:`DECLARED_UP`;
    #: ``None`` for formats that declare none), a prior for the up search. Not in :meth:`to_dict`.
    declared_up: tuple[float, float, float] | None = None
    #: who declares ``declared_up``: ``"format"`` (the format's convention, :data:`DECLARED_UP`)
    #: or ``"device"`` (the gravity-aligned frame the capturing device wrote the mesh in,
    #: :func:`device_frame_up`). Not in :meth:`to_dict`.
    declared_by: str = "format"

    @property
    def dropped_faces(self) -> int:
        return self.dropped_nonfinite + self.dropped_degenerate + self.dropped_duplicate

    def to_dict(self) -> dict:
        d = asdict(self)
        del d["parametric"], d["declared_up"], d["declared_by"]
        d["dropped_faces"] = self.dropped_faces
        if not self.points_read:  # a mesh: plan.json as before
            for key in ("points_read", "points", "dropped_nonfinite_points"):
                del d[key]
        return d


@dataclass(frozen=True, eq=False)
class LoadedMesh:
    """A mesh read from a file, what was read and dropped, and what the user should know.

    Attributes
    ----------
    mesh
        The cleaned mesh, in metres.
    stats
        What was read from the file and what was dropped.
    warnings
        One-line warnings about the file (e.g. coordinates whose float32 storage lost more
        than :data:`FLOAT32_PRECISION_WARN_M`); each is also logged on the ``meshplan`` logger.
    cloud
        A point cloud's points after subsampling, with their colours and intensities where the
        file has them (:class:`meshplan.io.points.PointCloud`); ``None`` for a mesh.
    surfels
        A point cloud's normals and footprint areas (:class:`meshplan.io.points.Surfels`), from
        which the splats of ``mesh`` were made; ``None`` for a mesh.
    """

    mesh: Mesh
    stats: LoadStats
    warnings: tuple[str, ...] = ()
    cloud: Any = None
    surfels: Any = None


def check_units(units: str) -> float:
    """Metres per input unit, or a :class:`ParameterError` naming the accepted units."""
    if units not in UNITS_M:
        raise ParameterError(
            f"unknown unit {units!r}", f"use one of {', '.join(UNITS_M)} with --units"
        )
    return UNITS_M[units]


def check_mesh_path(path: str | os.PathLike) -> tuple[Path, str]:
    """The path and trimesh file type, after checking that the file can be a mesh at all."""
    p = Path(path)
    try:
        # stat, not open: opening a FIFO blocks until something writes to it
        st = p.stat()
    except FileNotFoundError:
        raise InputError(f"{p}: file not found", "check the path of the scan") from None
    except OSError as exc:
        raise InputError(f"{p}: cannot be read ({exc.strerror})", "check the path and the permissions of the scan") from None
    if stat.S_ISDIR(st.st_mode):
        raise InputError(f"{p}: is a directory, not a mesh file", f"give the path of an {SCAN_FORMAT_NAMES} file")
    if not stat.S_ISREG(st.st_mode):
        mode = st.st_mode
        kind = "a FIFO (named pipe)" if stat.S_ISFIFO(mode) else "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "a socket"
        raise InputError(f"{p}: is {kind}, not a mesh file", "save the scan to a regular file and give its path")
    ext = p.suffix.lower()
    if ext not in SCAN_FORMATS:
        raise InputError(
            f"{p}: unknown mesh format {ext or '(no extension)'!r}",
            f"convert the scan to {SCAN_FORMAT_NAMES}",
        )
    try:
        with open(p, "rb"):
            pass
    except OSError as exc:
        raise InputError(f"{p}: cannot be read ({exc.strerror})", "check the file's permissions") from None
    if st.st_size == 0:
        raise InputError(f"{p}: the file is empty", "export the scan again")
    return p, SCAN_FORMATS[ext]


def is_scan_file(path: str | os.PathLike) -> bool:
    """Whether a file found by a batch is a scan: its extension is one of :data:`SCAN_FORMATS`,
    and for one of :data:`AMBIGUOUS_EXTENSIONS` (``.txt``) its first line that is not a comment
    or a column header holds at least three numbers."""
    p = Path(path)
    ext = p.suffix.lower()
    if ext not in SCAN_FORMATS:
        return False
    if ext not in AMBIGUOUS_EXTENSIONS:
        return True
    try:
        with open(p, "rb") as fh:
            head = fh.read(4096)
    except OSError:
        return True  # let the run say what is wrong
    lines = head.splitlines()
    for line in lines[:-1] if len(head) == 4096 else lines:  # the last line of a longer file may be cut
        parts = line.replace(b",", b" ").replace(b";", b" ").split()
        if not parts or parts[0].startswith((b"#", b"//")):
            continue
        try:
            return len(parts) >= 3 and all(np.isfinite(float(x)) for x in parts[:3])
        except ValueError:
            continue  # a header naming the columns
    return False


def estimate_faces(path: Path, file_type: str) -> int | None:
    """The number of faces a file declares, read from its header without loading it.

    ``None`` when the format has no cheap count (OBJ, glTF); OBJ is then estimated from the
    file size by the caller.
    """
    try:
        with open(path, "rb") as fh:
            head = fh.read(65536)
        if file_type == "ply":
            text = head.split(b"end_header", 1)[0].decode("ascii", "replace")
            for line in text.splitlines():
                parts = line.split()
                if len(parts) == 3 and parts[0] == "element" and parts[1] == "face":
                    return int(parts[2])
            return 0
        if file_type == "stl" and len(head) >= 84 and not head[:5].lower().startswith(b"solid"):
            return struct.unpack("<I", head[80:84])[0]
        if file_type == "off":
            counts = readers.off_counts(head)
            return None if counts is None else counts[1]
        if file_type == "glb" and head[:4] == b"glTF":
            length = struct.unpack("<I", head[12:16])[0]
            doc = json.loads(head[20 : 20 + length])
            total = 0
            for mesh in doc.get("meshes", []):
                for prim in mesh.get("primitives", []):
                    if "indices" in prim:
                        total += doc["accessors"][prim["indices"]]["count"] // 3
            return total
    except Exception:
        return None
    return None


def _read_int(path: Path) -> int | None:
    """The integer a cgroup file holds; ``None`` for ``max``, a missing or unreadable file."""
    try:
        text = path.read_text().strip()
        return None if text == "max" else int(text)
    except (OSError, ValueError):
        return None


def _inactive_file(stat_file: Path, key: str) -> int:
    """Page cache the kernel reclaims before hitting the limit (``inactive_file`` of
    ``memory.stat``): counted in the usage, but available, as container runtimes count it."""
    try:
        for line in stat_file.read_text().splitlines():
            name, _, value = line.partition(" ")
            if name == key:
                return int(value)
    except (OSError, ValueError):
        pass
    return 0


def _own_cgroup_dirs(root: Path) -> list[Path]:
    """The cgroup directories of this process (from /proc/self/cgroup) and the root, v2 first."""
    dirs = []
    try:
        for line in Path("/proc/self/cgroup").read_text().splitlines():
            _, controllers, rel = line.split(":", 2)
            if controllers == "":  # v2 unified hierarchy
                dirs.append(root / rel.lstrip("/"))
            elif "memory" in controllers.split(","):  # v1 memory controller
                dirs.append(root / "memory" / rel.lstrip("/"))
    except (OSError, ValueError):
        pass
    return list(dict.fromkeys([*dirs, root, root / "memory"]))  # a hybrid host lists the root twice


def cgroup_available_bytes(root: Path | None = None) -> int | None:
    """Memory left under this process's cgroup limit (v2 ``memory.max`` minus
    ``memory.current``, or v1 ``memory.limit_in_bytes`` minus ``memory.usage_in_bytes``, less
    the reclaimable page cache), or ``None`` when no limit applies."""
    root = CGROUP_ROOT if root is None else root
    best = None
    for d in _own_cgroup_dirs(root):
        for limit_name, usage_name, cache_key in (
            ("memory.max", "memory.current", "inactive_file"),
            ("memory.limit_in_bytes", "memory.usage_in_bytes", "total_inactive_file"),
        ):
            limit = _read_int(d / limit_name)
            if limit is None or limit >= CGROUP_NO_LIMIT_BYTES:
                continue
            usage = _read_int(d / usage_name) or 0
            left = max(0, limit - max(0, usage - _inactive_file(d / "memory.stat", cache_key)))
            best = left if best is None else min(best, left)
    return best


def available_memory_bytes() -> int | None:
    """Memory the process can still use: the least of the host's available memory
    (/proc/meminfo, or sysconf) and what its cgroup limit leaves (a container's limit is far
    below the host's memory, and the kernel kills a process that exceeds it)."""
    host = None
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    host = int(line.split()[1]) * 1024
                    break
    except (OSError, ValueError, IndexError):
        pass
    if host is None:
        try:
            host = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError, AttributeError):
            host = None
    limit = cgroup_available_bytes()
    found = [x for x in (host, limit) if x is not None]
    return min(found) if found else None


#: Bytes of each PLY scalar type.
_PLY_TYPE_BYTES = {
    "char": 1, "uchar": 1, "int8": 1, "uint8": 1, "short": 2, "ushort": 2, "int16": 2, "uint16": 2,
    "int": 4, "uint": 4, "int32": 4, "uint32": 4, "float": 4, "float32": 4, "double": 8, "float64": 8,
}


def _ply_data_needs(head: bytes) -> tuple[dict[str, int], int, int] | None:
    """Element counts, header length and the fewest data bytes a PLY header implies.

    Lower bounds: a binary scalar takes its size, an ASCII one at least two bytes (a digit and
    a separator); a face's vertex list holds at least three indices. ``None`` when ``head`` is
    not a complete, well-formed PLY header (the PLY reader then says what is wrong).
    """
    end = head.find(b"end_header")
    if not head.startswith(b"ply") or end < 0:
        return None
    stop = head.find(b"\n", end)
    if stop < 0:
        return None
    try:
        lines = head[:end].decode("ascii").splitlines()
        fmt = next(ln.split()[1] for ln in lines if ln.startswith("format "))
        ascii_ = fmt == "ascii"
        counts: dict[str, int] = {}
        need, element, per_item = 0, None, 0
        for ln in lines:
            parts = ln.split()
            if parts[:1] == ["element"]:
                if element is not None:
                    need += counts[element] * per_item
                element, per_item = parts[1], 0
                counts[element] = int(parts[2])
                if counts[element] < 0:
                    return None
            elif parts[:1] == ["property"] and element is not None:
                items = 3 if element == "face" and parts[-1] in ("vertex_indices", "vertex_index") else 0
                if parts[1] == "list":
                    per_item += 2 * (1 + items) if ascii_ else _PLY_TYPE_BYTES[parts[2]] + items * _PLY_TYPE_BYTES[parts[3]]
                else:
                    per_item += 2 if ascii_ else _PLY_TYPE_BYTES[parts[1]]
        if element is not None:
            need += counts[element] * per_item
    except (ValueError, IndexError, KeyError, StopIteration, UnicodeDecodeError):
        return None
    return counts, stop + 1, need


def lying_header(path: Path, claimed: int, noun: str, size: int) -> InputError:
    """The refusal of a header that declares far more than its file can hold."""
    return InputError(
        f"{path}: corrupt header: header claims {claimed:,} {noun} but the file is only {size:,} bytes",
        REEXPORT,
    )


def _is_ascii_stl(head: bytes) -> bool:
    """ASCII STL starts with ``solid`` (so do some binary STL headers: they hold no facet)."""
    return head[:5].lower() == b"solid" and (b"facet" in head or b"endsolid" in head)


def check_header(path: Path, file_type: str) -> None:
    """Refuse a file whose header declares more data than the file holds.

    A header declaring more than :data:`LYING_HEADER_FACTOR` times what the file could hold is
    corrupt ("header claims N faces but the file is only X bytes"); one declaring a little more
    was cut short ("is truncated: header says N faces, file holds M"; for the text formats and
    PLY, the readers count M). Either way the count never reaches the memory check.
    """
    size = path.stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(65536)
    if file_type == "ply":
        found = _ply_data_needs(head)
        if found is None:
            return
        counts, header_len, need = found
        if need > LYING_HEADER_FACTOR * max(size - header_len, 1):
            noun, claimed = ("faces", counts["face"]) if counts.get("face") else ("vertices", counts.get("vertex", 0))
            raise lying_header(path, claimed, noun, size)
    elif file_type == "stl" and len(head) >= 84 and not _is_ascii_stl(head):
        n = struct.unpack("<I", head[80:84])[0]
        if size < 84 + 50 * n:
            if 84 + 50 * n > LYING_HEADER_FACTOR * size:
                raise lying_header(path, n, "faces", size)
            raise truncated(path, f"{n:,} faces", f"{(size - 84) // 50:,}")
    elif file_type == "off":
        off = readers.off_counts(head)
        if off is not None and off[0] * OFF_MIN_VERTEX_BYTES + off[1] * OFF_MIN_FACE_BYTES > LYING_HEADER_FACTOR * size:
            noun, claimed = ("faces", off[1]) if off[1] * OFF_MIN_FACE_BYTES > size else ("vertices", off[0])
            raise lying_header(path, claimed, noun, size)
    elif file_type == "glb" and head[:4] == b"glTF" and len(head) >= 20:
        declared = struct.unpack("<I", head[8:12])[0]
        faces = estimate_faces(path, file_type)
        if faces is not None and faces * GLB_MIN_FACE_BYTES > LYING_HEADER_FACTOR * size:
            raise lying_header(path, faces, "faces", size)
        if declared > size:
            raise truncated(path, f"{faces or 0:,} faces in {declared:,} bytes", f"{size:,} bytes")


#: Bytes that text files do not hold (tab, newlines, vertical tab, form feed are allowed).
_CONTROL_BYTES = bytes([*range(0, 9), *range(14, 32)])


def _check_text(path: Path, file_type: str) -> None:
    """OBJ and OFF are text: refuse binary data (a renamed or corrupted file) up front."""
    with open(path, "rb") as fh:
        head = fh.read(65536)
    control = len(head) - len(head.translate(None, _CONTROL_BYTES))
    if control > 0.01 * len(head):
        raise InputError(
            f"{path}: holds binary data, not {file_type.upper()} text",
            f"check that the file really is an {file_type.upper()} export (not another format renamed), or export the scan again",
        )


def check_size(path: Path, file_type: str, max_faces: int | None) -> int:
    """Refuse, before loading, a mesh that cannot fit in memory (or exceeds ``max_faces``).

    The estimated need (:data:`BYTES_PER_FACE` per face declared in the header, or estimated
    from the size of an OBJ) is stated in the message, with ``--max-faces`` to override.
    """
    check_header(path, file_type)
    faces = estimate_faces(path, file_type)
    if faces is None:
        # OBJ and glTF: a face line or index triple takes at least ~20 bytes
        faces = path.stat().st_size // 20 if file_type == "obj" else 0
    need = faces * BYTES_PER_FACE
    if max_faces is None:
        avail = available_memory_bytes()
        if avail is not None and need > avail:
            raise InputError(
                f"{path}: about {faces:,} faces would need about {need / 1e9:.1f} GB of memory "
                f"and {avail / 1e9:.1f} GB are available",
                f"decimate the scan, or pass --max-faces {faces} to try anyway",
            )
    elif faces > max_faces:
        raise InputError(
            f"{path}: about {faces:,} faces, more than --max-faces {max_faces:,} "
            f"(it would need about {need / 1e9:.1f} GB of memory)",
            f"decimate the scan, or raise --max-faces to {faces}",
        )
    return faces


_OBJ_ARITY = {"v": 3, "vn": 3, "vt": 2, "f": 3}


def _check_obj_ending(path: Path) -> None:
    """An OBJ cut short mid-line ends with an incomplete statement; say so instead of reading a
    silently shortened mesh."""
    with open(path, "rb") as fh:
        fh.seek(max(0, path.stat().st_size - 512))
        tail = fh.read().decode("utf-8", "replace")
    last = tail.rsplit("\n", 1)[-1].strip()
    parts = last.split()
    if parts and parts[0] in _OBJ_ARITY:
        numbers = parts[1:]
        ok = len(numbers) >= _OBJ_ARITY[parts[0]]
        if parts[0] != "f":
            try:
                [float(x) for x in numbers]
            except ValueError:
                ok = False
        if not ok:
            raise InputError(f"{path}: the file ends in the middle of a line ({last[:40]!r}): it was cut short", "export or copy the scan again")


def _check_stl_ending(path: Path, head: bytes) -> None:
    """An ASCII STL has no count, but it ends with ``endsolid``: without it, it was cut short."""
    if not _is_ascii_stl(head):
        return
    size = path.stat().st_size
    with open(path, "rb") as fh:
        fh.seek(max(0, size - 1024))
        tail = fh.read()
    if b"endsolid" not in tail.lower():
        facets = path.read_bytes().count(b"endfacet")
        raise InputError(f"{path}: is truncated: an ASCII STL ends with endsolid, this one stops after {facets:,} complete facets", REEXPORT)


def _vertices(geometry: object) -> np.ndarray:
    """The vertices of a trimesh geometry (a mesh, a point cloud; none for a path)."""
    return np.asarray(getattr(geometry, "vertices", np.zeros((0, 3))), dtype=np.float64)


def _read_with_trimesh(path: Path, file_type: str) -> RawMesh:
    """STL, GLB and glTF, read by trimesh (glTF node transforms applied)."""
    import trimesh

    if file_type == "gltf":
        try:
            json.loads(path.read_bytes())
        except (ValueError, UnicodeDecodeError) as exc:
            raise InputError(
                f"{path}: not a glTF file: not valid JSON ({' '.join(str(exc).split())[:80]})",
                "check that the file is a glTF export, or export the scan again (GLB is one self-contained file)",
            ) from None
    with open(path, "rb") as fh:
        head = fh.read(65536)
    if file_type == "stl":
        _check_stl_ending(path, head)
    try:
        loaded = trimesh.load(str(path), file_type=file_type, process=False, force=None)
    except Exception as exc:  # trimesh raises many types for broken files
        reason = str(exc).splitlines()[0][:120] if str(exc) else type(exc).__name__
        if isinstance(exc, KeyError):  # trimesh indexes the file's structures without checking
            reason = f"missing entry {exc}"
        raise InputError(
            f"{path}: cannot be read as {file_type.upper()} ({reason})",
            "check that the file is a complete, uncorrupted mesh export",
        ) from None
    if isinstance(loaded, trimesh.Scene):
        # the stored (float32) positions are those before the node transforms
        stored = [_vertices(g) for g in loaded.geometry.values()]
        geoms = loaded.dump()
    else:
        geoms = [loaded]
        stored = [_vertices(loaded)]
    binary_stl = file_type == "stl" and not _is_ascii_stl(head)
    float32 = file_type in ("glb", "gltf") or binary_stl  # glTF positions are float32; so is binary STL
    extent = max((float(np.abs(v[np.isfinite(v)]).max(initial=0.0)) for v in stored), default=0.0) if float32 else 0.0
    verts, faces, points, offset, objects = [], [], [], 0, 0
    for g in geoms:
        if isinstance(g, trimesh.Trimesh) and len(g.faces):
            v = np.asarray(g.vertices, dtype=np.float64)
            verts.append(v)
            faces.append(np.asarray(g.faces, dtype=np.int64) + offset)
            offset += len(v)
            objects += 1
        elif isinstance(g, (trimesh.PointCloud, trimesh.Trimesh)) and len(getattr(g, "vertices", [])):
            points.append(np.asarray(g.vertices, dtype=np.float64))  # only to say "a point cloud"
    if not faces:
        return RawMesh(np.concatenate(points) if points else np.zeros((0, 3)), np.zeros((0, 3), np.int64), 0, extent)
    return RawMesh(np.concatenate(verts), np.concatenate(faces), objects, extent)


def read_raw(path: Path, file_type: str, points_ok: bool = False) -> RawMesh:
    """The vertices and triangles of a mesh file, as stored (no clean-up), or an
    :class:`InputError` saying why the file cannot be read; with ``points_ok``, vertices without
    faces are returned as they are (a point cloud) instead of refused."""
    if file_type in ("obj", "off"):
        _check_text(path, file_type)
    if file_type == "obj":
        _check_obj_ending(path)
        raw = readers.read_obj(path)
    elif file_type == "off":
        raw = readers.read_off(path)
    elif file_type == "ply":
        raw = readers.read_ply(path)
    else:
        raw = _read_with_trimesh(path, file_type)
    if not len(raw.faces):
        if len(raw.vertices) and points_ok:
            return raw
        if len(raw.vertices):
            raise InputError(
                f"{path}: holds points but no triangles (a point cloud, or a file cut short)",
                "mesh the point cloud first (e.g. Poisson reconstruction) or export the scan as a mesh",
            )
        raise InputError(f"{path}: holds no triangles", "export the scan again as a triangle mesh")
    return raw


def float32_warning(path: Path, extent: float, scale: float) -> str | None:
    """A warning when float32 storage of coordinates up to ``extent`` (file units, times
    ``scale`` to metres) lost more than :data:`FLOAT32_PRECISION_WARN_M`."""
    if not np.isfinite(extent) or extent <= 0:
        return None
    lost_m = float(np.spacing(np.float32(extent))) / 2 * scale  # rounding to the nearest float32
    if lost_m <= FLOAT32_PRECISION_WARN_M:
        return None
    lost = f"{lost_m * 1000:.0f} mm" if lost_m < 1 else f"{lost_m:.2f} m"
    return (
        f"{path}: coordinates are stored as float32 and reach {extent * scale:,.0f} m from the origin "
        f"(a georeferenced offset?), where float32 keeps only about {lost} precision; "
        f"export the scan around a local origin, or as PLY with double coordinates, to keep millimetres"
    )


def _merge_vertices(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unique vertices (exactly equal coordinates) and the index of each input vertex among them.

    The unique vertices come sorted by their coordinates' bit patterns (x, then y, then z, as
    signed integers). One sort of the x patterns (numpy's vectorized quicksort) with the ties
    then ordered by y and z, and one pass to number the runs (:mod:`meshplan._kernels`): at 3M
    faces (1.5M vertices) 0.25 s, where ``np.lexsort`` of the three columns, the comparison of
    neighbours and the scatter took 0.65 s (and ``np.unique(axis=0)`` several times more).
    """
    from .._kernels import lexsort_rows, unique_sorted_rows

    if not len(vertices):
        return vertices, np.zeros(0, dtype=np.int64)
    v = np.ascontiguousarray(vertices + 0.0)  # + 0.0 turns -0.0 into 0.0
    bits = v.view(np.int64)
    order = lexsort_rows(bits, np.argsort(bits[:, 0]))
    first, inverse = unique_sorted_rows(bits, order)
    return v[first], inverse


def clean_mesh(vertices: np.ndarray, faces: np.ndarray) -> tuple[Mesh, dict[str, int]]:
    """Drop unusable faces, merge coincident vertices and count what was dropped.

    Dropped are faces with a non-finite corner, degenerate faces (a repeated vertex once
    coincident vertices are merged, or an area not above :data:`MIN_FACE_AREA_M2`) and repeats
    of an earlier face (the same three vertices in any order; the first is kept). The faces are
    renumbered, their corners gathered, their cross products computed and both tests made in one
    compiled pass (:func:`meshplan._kernels.clean_faces`; repeats without sorting): with the
    merge, 0.8-1.0 s of CPU at 3M faces where a dozen numpy passes and their temporaries took
    2.8-3.7 s. The corners
    and cross products are those the mesh would compute, bit for bit: it keeps them.
    """
    from .._kernels import clean_faces

    counts = {}
    finite_v = np.all(np.isfinite(vertices), axis=1)
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    if finite_v.all():
        counts["dropped_nonfinite"] = 0
    else:
        ok = np.all(finite_v[faces], axis=1)
        counts["dropped_nonfinite"] = int((~ok).sum())
        faces = np.ascontiguousarray(faces[ok])
        vertices = np.where(finite_v[:, None], vertices, 0.0)
    uniq, inverse = _merge_vertices(vertices)
    # the outputs allocated by numpy (huge pages for large arrays: see clean_faces)
    n = len(faces)
    buffers = np.empty((n, 3), np.int64), np.empty((n, 3, 3)), np.empty((n, 3))
    cleaned = clean_faces(uniq, inverse, faces, MIN_FACE_AREA_M2, False, *buffers)
    if not cleaned[-1]:  # a vertex with very many faces: repeats by a hash table instead
        cleaned = clean_faces(uniq, inverse, faces, MIN_FACE_AREA_M2, True, *buffers)
    faces, tri, cross, keep, used, degenerate, repeated, _ = cleaned
    counts["dropped_degenerate"] = int(degenerate)
    counts["dropped_duplicate"] = int(repeated)
    # (the copies only where something is dropped: at 3M faces each costs 0.1-1 s)
    if degenerate or repeated:
        faces, tri, cross = faces[keep], tri[keep], cross[keep]
    if used.all():  # every vertex in a face (the usual case): no renumbering
        # fresh arrays of valid indices: taken as they are (Mesh() would copy and check them)
        return Mesh._adopt(uniq, faces)._seed(triangles=tri, _cross=cross), counts
    remap = np.cumsum(used) - 1
    # the corners and cross products are those the mesh would compute: keep them
    return Mesh._adopt(np.ascontiguousarray(uniq[used]), remap[faces])._seed(triangles=tri, _cross=cross), counts


def _declared(path: Path, file_type: str) -> tuple[tuple[float, float, float] | None, str]:
    """``declared_up`` and ``declared_by`` of :class:`LoadStats` for a mesh file."""
    device = device_frame_up(path, file_type)
    if device is not None:
        return device, "device"
    return DECLARED_UP.get(file_type), "format"


def load_mesh(
    path: str | os.PathLike, units: str = "m", max_faces: int | None = None, point_voxel_m: float | None = None, units_explicit: bool | None = None
) -> LoadedMesh:
    """Read a scan file into metres and drop the faces that cannot be used.

    Meshes are read as they are; point clouds (E57, LAS/LAZ, XYZ/PTS/TXT, and PLY or OBJ files
    with vertices and no faces) are subsampled and turned into splats by
    :func:`meshplan.io.points.load_points`; USD stages (USD, USDA, USDC, USDZ) are flattened into
    world coordinates by :func:`meshplan.io.usd.read_usd`.

    Parameters
    ----------
    path
        OBJ, PLY, GLB, glTF, STL, OFF, E57, LAS, LAZ, XYZ, PTS, TXT, USD, USDA, USDC or USDZ file.
    units
        Unit of the file's coordinates: ``m``, ``cm``, ``mm``, ``ft`` or ``in`` (a USD stage's
        own ``metersPerUnit`` is applied on top).
    max_faces
        Refuse files with more faces (a point cloud: points after subsampling) than this;
        ``None`` refuses only what cannot fit in the available memory.
    point_voxel_m
        Voxel size of a point cloud's subsampling grid, metres; ``None`` for
        :data:`meshplan.io.points.VOXEL_M`.
    units_explicit
        Whether the user named ``units`` (``--units``), so that they override the units a point
        cloud's CRS names, ``m`` too; ``None``: named when other than the default ``m``.

    Raises
    ------
    InputError
        When the file is missing, unreadable, not a mesh, too large, or has no usable face, or
        the optional reader its format needs is not installed.
    """
    from . import points, usd

    scale = check_units(units)
    p, file_type = check_mesh_path(path)
    voxel_m = points.VOXEL_M if point_voxel_m is None else point_voxel_m
    if f".{file_type}" in POINT_FORMATS or (file_type == "ply" and points.ply_holds_points_only(p)):
        if file_type == "ply":
            check_header(p, file_type)  # a header claiming far more vertices than the file holds
        return points.load_points(p, file_type, units, max_faces, voxel_m, units_explicit=units_explicit)
    raw: RawMesh
    parametric = None
    if f".{file_type}" in USD_FORMATS:
        scene = usd.read_usd(p, max_faces)
        scale, raw, parametric = scale * scene.meters_per_unit, scene, scene.parametric
    else:
        check_size(p, file_type, max_faces)
        raw = read_raw(p, file_type, points_ok=file_type in ("obj", "off"))
    if not len(raw.faces):  # an OBJ or OFF with vertices only: a point cloud
        return points.load_points(p, file_type, units, max_faces, voxel_m, cloud=points.PointCloud(raw.vertices), units_explicit=units_explicit)
    vertices, faces, objects = raw.vertices, raw.faces, raw.objects
    n_v, n_f = len(vertices), len(faces)
    if faces.size and (faces.min() < 0 or faces.max() >= n_v):
        raise InputError(f"{p}: faces refer to vertices that do not exist", "export the scan again")
    mesh, counts = clean_mesh(vertices * scale, faces)
    declared_up, declared_by = _declared(p, file_type)
    stats = LoadStats(
        path=str(p),
        format=file_type,
        units=units,
        scale_to_m=scale,
        objects=objects,
        vertices_read=n_v,
        faces_read=n_f,
        vertices=mesh.n_vertices,
        faces=mesh.n_faces,
        **counts,
        parametric=parametric,
        declared_up=declared_up,
        declared_by=declared_by,
    )
    if mesh.n_faces == 0:
        raise InputError(
            f"{p}: none of its {n_f:,} faces is usable ({stats.dropped_nonfinite:,} with NaN or infinite "
            f"coordinates, {stats.dropped_degenerate:,} degenerate, {stats.dropped_duplicate:,} duplicate)",
            "export the scan again",
        )
    # not logged here: the run puts them into Result.warnings, which the command line prints once
    warnings = tuple(w for w in [float32_warning(p, raw.float32_extent, scale)] if w)
    return LoadedMesh(mesh=mesh, stats=stats, warnings=warnings)


def write_mesh(mesh: Mesh, path: str | os.PathLike) -> None:
    """Write a mesh in the format its extension names (OBJ, PLY, GLB, STL, OFF), atomically."""
    import trimesh

    from .atomic import atomic_write_bytes

    p = Path(path)
    ext = p.suffix.lower()
    if ext not in MESH_FORMATS or ext == ".gltf":
        raise ParameterError(f"cannot write mesh format {ext!r}", "use .obj, .ply, .glb, .stl or .off")
    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    data = tm.export(file_type=MESH_FORMATS[ext])
    if isinstance(data, dict):  # only multi-file formats (glTF with buffers) export a dict
        raise ParameterError(f"cannot write mesh format {ext!r} as one file", "use .obj, .ply, .glb, .stl or .off")
    atomic_write_bytes(p, data if isinstance(data, bytes) else data.encode())

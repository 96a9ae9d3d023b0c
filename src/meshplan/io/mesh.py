"""Reading scanned meshes into plain arrays, with the clean-up every scan needs.

Formats are read by trimesh: OBJ (including the multi-object exports of the HoloLens Device
Portal), PLY (ascii and binary), GLB/glTF (the scene graph flattened with its node transforms),
STL and OFF. Whatever the file holds is flattened into one :class:`~meshplan.geometry.Mesh` in
metres, and the faces that cannot be used are dropped and counted:

* faces touching a vertex with a NaN or infinite coordinate,
* degenerate faces (a repeated vertex, or an area below ``1e-12`` m2),
* duplicate faces (the same three vertices, in any order), keeping the first.

Vertices at exactly the same position are merged, so that faces of one surface are connected
even when an exporter wrote each object with its own vertices.
"""

from __future__ import annotations

import json
import os
import struct
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError, ParameterError
from ..geometry import Mesh

#: File extensions meshplan reads, with the trimesh file type for each.
MESH_FORMATS = {".obj": "obj", ".ply": "ply", ".glb": "glb", ".gltf": "gltf", ".stl": "stl", ".off": "off"}

#: Length units accepted by ``--units``, in metres.
UNITS_M = {"m": 1.0, "cm": 0.01, "mm": 0.001, "ft": 0.3048, "in": 0.0254}

#: Peak memory meshplan needs per input face, measured on the 3-million-face benchmark
#: (about 0.9 kB/face including the plans); used to refuse meshes that cannot fit up front.
BYTES_PER_FACE = 1000

#: Smallest triangle area kept, in square metres (after unit conversion).
MIN_FACE_AREA_M2 = 1e-12


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

    @property
    def dropped_faces(self) -> int:
        return self.dropped_nonfinite + self.dropped_degenerate + self.dropped_duplicate

    def to_dict(self) -> dict:
        d = asdict(self)
        d["dropped_faces"] = self.dropped_faces
        return d


@dataclass(frozen=True, eq=False)
class LoadedMesh:
    mesh: Mesh
    stats: LoadStats


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
    if not p.exists():
        raise InputError(f"{p}: file not found", "check the path of the scan")
    if p.is_dir():
        raise InputError(f"{p}: is a directory, not a mesh file", "give the path of an OBJ, PLY, GLB, glTF, STL or OFF file")
    ext = p.suffix.lower()
    if ext not in MESH_FORMATS:
        raise InputError(
            f"{p}: unknown mesh format {ext or '(no extension)'!r}",
            "convert the scan to OBJ, PLY, GLB, glTF, STL or OFF",
        )
    try:
        size = p.stat().st_size
        with open(p, "rb"):
            pass
    except OSError as exc:
        raise InputError(f"{p}: cannot be read ({exc.strerror})", "check the file's permissions") from None
    if size == 0:
        raise InputError(f"{p}: the file is empty", "export the scan again")
    return p, MESH_FORMATS[ext]


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
            lines = [ln for ln in head.decode("ascii", "replace").splitlines() if ln.strip() and not ln.startswith("#")]
            first = lines[0].split()
            counts = first[1:] if first[0].upper().endswith("OFF") and len(first) > 1 else lines[1].split()
            return int(counts[1])
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


def available_memory_bytes() -> int | None:
    """Memory the process can still use, from /proc/meminfo (Linux) or sysconf."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


#: Bytes of each PLY scalar type.
_PLY_TYPE_BYTES = {
    "char": 1, "uchar": 1, "int8": 1, "uint8": 1, "short": 2, "ushort": 2, "int16": 2, "uint16": 2,
    "int": 4, "uint": 4, "int32": 4, "uint32": 4, "float": 4, "float32": 4, "double": 8, "float64": 8,
}


def _ply_data_needs(head: bytes) -> tuple[dict[str, int], int, int] | None:
    """Element counts, header length and the fewest data bytes a PLY header implies.

    Lower bounds: a binary scalar takes its size, an ASCII one at least two bytes (a digit and
    a separator); a face's vertex list holds at least three indices. ``None`` when ``head`` is
    not a complete, well-formed PLY header (trimesh then reports what is wrong).
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


def check_header(path: Path, file_type: str) -> None:
    """Refuse a PLY or binary STL whose header declares more data than the file holds.

    Such a file was cut short, or its header lies; saying so is clearer than the reader's
    error, and it keeps the memory check from trusting an absurd face count.
    """
    size = path.stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(65536)
    if file_type == "ply":
        found = _ply_data_needs(head)
        if found is None:
            return
        counts, header_len, need = found
        if size - header_len < need:
            raise InputError(
                f"{path}: cut short or a wrong header: the PLY header declares {counts.get('vertex', 0):,} vertices "
                f"and {counts.get('face', 0):,} faces, which need at least {need:,} bytes, "
                f"but only {size - header_len:,} follow it",
                "export or copy the scan again",
            )
    elif file_type == "stl" and len(head) >= 84 and not head[:5].lower().startswith(b"solid"):
        n = struct.unpack("<I", head[80:84])[0]
        if size < 84 + 50 * n:
            raise InputError(
                f"{path}: damaged or cut short: its binary STL header declares {n:,} triangles, which need "
                f"{84 + 50 * n:,} bytes, but the file has {size:,}",
                "export or copy the scan again",
            )


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


def _read_with_trimesh(path: Path, file_type: str) -> tuple[np.ndarray, np.ndarray, int]:
    import trimesh

    if file_type in ("obj", "off"):
        _check_text(path, file_type)
    if file_type == "gltf":
        try:
            json.loads(path.read_bytes())
        except (ValueError, UnicodeDecodeError) as exc:
            raise InputError(
                f"{path}: not a glTF file: not valid JSON ({' '.join(str(exc).split())[:80]})",
                "check that the file is a glTF export, or export the scan again (GLB is one self-contained file)",
            ) from None
    if file_type == "obj":
        _check_obj_ending(path)

    try:
        # OBJ: one geometry per object, as HoloLens exports write one object per surface patch
        extra = {"split_objects": True, "group_material": False} if file_type == "obj" else {}
        loaded = trimesh.load(str(path), file_type=file_type, process=False, force=None, **extra)
    except Exception as exc:  # trimesh raises many types for broken files
        reason = str(exc).splitlines()[0][:120] if str(exc) else type(exc).__name__
        if isinstance(exc, KeyError):  # trimesh indexes the file's structures without checking
            reason = f"missing entry {exc}"
        if isinstance(exc, ImportError):  # trimesh guesses the encoding of non-UTF-8 text with an optional package
            reason = "it is not UTF-8 text"
        raise InputError(
            f"{path}: cannot be read as {file_type.upper()} ({reason})",
            "check that the file is a complete, uncorrupted mesh export",
        ) from None
    geoms = loaded.dump() if isinstance(loaded, trimesh.Scene) else [loaded]
    verts, faces, offset, objects = [], [], 0, 0
    points_only = False
    for g in geoms:
        if isinstance(g, trimesh.Trimesh) and len(g.faces):
            v = np.asarray(g.vertices, dtype=np.float64)
            f = np.asarray(g.faces, dtype=np.int64)
            verts.append(v)
            faces.append(f + offset)
            offset += len(v)
            objects += 1
        elif isinstance(g, (trimesh.PointCloud, trimesh.Trimesh)) and len(getattr(g, "vertices", [])):
            points_only = True
    if not faces:
        if points_only:
            raise InputError(
                f"{path}: holds points but no triangles (a point cloud, or a file cut short)",
                "mesh the point cloud first (e.g. Poisson reconstruction) or export the scan as a mesh",
            )
        raise InputError(f"{path}: holds no triangles", "export the scan again as a triangle mesh")
    return np.concatenate(verts), np.concatenate(faces), objects


def _merge_vertices(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unique vertices (exactly equal coordinates) and the index of each input vertex among them.

    Sorts the coordinates' bit patterns with ``lexsort``: several times faster than
    ``np.unique(axis=0)``, which sorts opaque byte strings.
    """
    if not len(vertices):
        return vertices, np.zeros(0, dtype=np.int64)
    v = np.ascontiguousarray(vertices + 0.0)  # + 0.0 turns -0.0 into 0.0
    bits = v.view(np.int64)
    order = np.lexsort((bits[:, 2], bits[:, 1], bits[:, 0]))
    b = bits[order]
    new = np.r_[True, np.any(b[1:] != b[:-1], axis=1)]
    rank = np.cumsum(new) - 1
    inverse = np.empty(len(v), dtype=np.int64)
    inverse[order] = rank
    return v[order[new]], inverse


def clean_mesh(vertices: np.ndarray, faces: np.ndarray) -> tuple[Mesh, dict[str, int]]:
    """Drop unusable faces, merge coincident vertices and count what was dropped."""
    counts = {}
    finite_v = np.all(np.isfinite(vertices), axis=1)
    ok = np.all(finite_v[faces], axis=1)
    counts["dropped_nonfinite"] = int((~ok).sum())
    faces = faces[ok]
    vertices = np.where(finite_v[:, None], vertices, 0.0)
    uniq, inverse = _merge_vertices(vertices)
    faces = inverse[faces]
    tri = uniq[faces]
    a, b = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    cross = np.stack([a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1], a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2], a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]], axis=1)
    area = 0.5 * np.sqrt(np.einsum("ij,ij->i", cross, cross))
    repeated = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 0] == faces[:, 2])
    degenerate = repeated | ~(area > MIN_FACE_AREA_M2)
    counts["dropped_degenerate"] = int(degenerate.sum())
    faces, tri, cross = faces[~degenerate], tri[~degenerate], cross[~degenerate]
    # duplicates: the same three vertices in any order; keep the first occurrence
    keep = np.zeros(len(faces), dtype=bool)
    if len(faces):
        s3 = np.sort(faces, axis=1)
        if len(uniq) < 2**21:  # one integer key per face: a fast sort
            key = (s3[:, 0] << 42) | (s3[:, 1] << 21) | s3[:, 2]
            order = np.argsort(key)
            k = key[order]
            starts = np.flatnonzero(np.r_[True, k[1:] != k[:-1]])
        else:
            order = np.lexsort((s3[:, 2], s3[:, 1], s3[:, 0]))
            k = s3[order]
            starts = np.flatnonzero(np.r_[True, np.any(k[1:] != k[:-1], axis=1)])
        keep[np.minimum.reduceat(order, starts)] = True
    counts["dropped_duplicate"] = int(len(faces) - keep.sum())
    faces = faces[keep]
    used = np.zeros(len(uniq), dtype=bool)
    used[faces.reshape(-1)] = True
    remap = np.cumsum(used) - 1
    # the corners and cross products are those the mesh would compute: keep them
    return Mesh(uniq[used], remap[faces])._seed(triangles=tri[keep], _cross=cross[keep]), counts


def load_mesh(path: str | os.PathLike, units: str = "m", max_faces: int | None = None) -> LoadedMesh:
    """Read a mesh file into metres and drop the faces that cannot be used.

    Parameters
    ----------
    path
        OBJ, PLY, GLB, glTF, STL or OFF file.
    units
        Unit of the file's coordinates: ``m``, ``cm``, ``mm``, ``ft`` or ``in``.
    max_faces
        Refuse files with more faces than this; ``None`` refuses only what cannot fit in the
        available memory.

    Raises
    ------
    InputError
        When the file is missing, unreadable, not a mesh, too large, or has no usable face.
    """
    scale = check_units(units)
    p, file_type = check_mesh_path(path)
    check_size(p, file_type, max_faces)
    vertices, faces, objects = _read_with_trimesh(p, file_type)
    n_v, n_f = len(vertices), len(faces)
    if faces.size and (faces.min() < 0 or faces.max() >= n_v):
        raise InputError(f"{p}: faces refer to vertices that do not exist", "export the scan again")
    mesh, counts = clean_mesh(vertices * scale, faces)
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
    )
    if mesh.n_faces == 0:
        raise InputError(
            f"{p}: none of its {n_f:,} faces is usable ({stats.dropped_nonfinite:,} with NaN or infinite "
            f"coordinates, {stats.dropped_degenerate:,} degenerate, {stats.dropped_duplicate:,} duplicate)",
            "export the scan again",
        )
    return LoadedMesh(mesh=mesh, stats=stats)


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
    atomic_write_bytes(p, data if isinstance(data, bytes) else data.encode())

"""meshplan's own vectorised readers for the text and PLY mesh formats (OBJ, OFF, PLY).

trimesh reads these formats too, but not always right for scans: it resolves an OBJ's relative
(negative) face indices against each object's own vertices instead of the whole file's, stops at
a UTF-8 byte-order mark, refuses a Latin-1 comment, cannot read a binary PLY that mixes quads
and triangles, and reads a cut-short OFF as a smaller mesh without a word. These readers:

* keep the coordinates in float64 (and say when the file stored them as float32, see
  :attr:`RawMesh.float32_extent`),
* fan-triangulate polygons (a face ``a b c d`` gives ``a b c`` and ``a c d``),
* compare what a header declares with what the file holds and refuse a file cut short with
  ``<file>: is truncated: header says N faces, file holds M``,
* raise only :class:`~meshplan.errors.InputError` for bad input.

Everything is done with whole-array numpy operations on the file's bytes; no Python loop runs
per line, vertex or face (OBJ is read in chunks of :data:`OBJ_CHUNK_BYTES` to bound memory).

Why one long module: three formats, each a header parser and a vectorised body reader sharing
the chunked-bytes helpers and the truncation checks; trimesh resolves negative OBJ indices per
object (wrongly) and cannot read mixed-polygon binary PLY, which is why these readers exist at
all.
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError

#: OBJ files are parsed in pieces of about this many bytes (cut at line ends), so that the
#: temporary per-byte arrays (a few bytes per file byte) stay near 100 MB however large the scan.
OBJ_CHUNK_BYTES = 16 * 2**20

#: UTF-8 byte-order mark, which Windows tools put at the start of text files.
UTF8_BOM = b"\xef\xbb\xbf"

#: Hint given with every refusal of a damaged file.
REEXPORT = "re-export the scan (or copy it again if it was cut short in transfer)"

# byte values used by the tokenisers
_SP, _NL, _SLASH = 32, 10, 47

#: Whitespace other than space and newline, turned into spaces before tokenising.
_TO_SPACE = bytes.maketrans(b"\t\r\v\f", b"    ")

#: Byte positions whose record length is computed at once when following the records of a PLY
#: that mixes polygon sizes: bounds the temporary arrays to some 200 MB.
WALK_BLOCK_BYTES = 4 * 2**20

_COMMENT = re.compile(rb"#[^\n]*")
_LEADING_SPACE = re.compile(rb"(?m)^ +")
_CONTINUATION = re.compile(rb"\\ *\n")  # a backslash ending a line continues it (OBJ)


@dataclass(frozen=True, eq=False)
class RawMesh:
    """Vertices and triangles as read from a file, before any clean-up.

    Attributes
    ----------
    vertices
        ``(n, 3)`` float64 coordinates in the file's units.
    faces
        ``(m, 3)`` int64 vertex indices (0-based; not yet checked against ``n``).
    objects
        Number of objects (OBJ ``o`` sections, glTF meshes) that hold faces.
    float32_extent
        Largest absolute coordinate the file stored as float32 (0 when it stored none): its
        float32 spacing is the precision lost in storage.
    """

    vertices: np.ndarray
    faces: np.ndarray
    objects: int = 1
    float32_extent: float = 0.0


def truncated(path: Path, declared: str, held: str) -> InputError:
    """The refusal of a file that holds less than its header declares."""
    return InputError(f"{path}: is truncated: header says {declared}, file holds {held}", REEXPORT)


def malformed(path: Path, fmt: str, what: str) -> InputError:
    """The refusal of a file whose data does not follow its format."""
    return InputError(f"{path}: cannot be read as {fmt} ({what})", "check that the file is a complete, uncorrupted mesh export")


def _strict_floats(data: bytes) -> np.ndarray | None:
    """All whitespace-separated numbers of ``data`` as float64; ``None`` if a token is not a number."""
    with warnings.catch_warnings():
        # numpy stops at the first token that is not a number and only warns; make it an error
        warnings.simplefilter("error", DeprecationWarning)
        try:
            return np.fromstring(data, dtype=np.float64, sep=" ")
        except (ValueError, DeprecationWarning):
            return None


def tokenize_lines(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-line token counts and all tokens as float64 of whitespace-separated text.

    Parameters
    ----------
    a
        ``uint8`` bytes holding only spaces, newlines and numbers, ending with a newline.

    Returns
    -------
    counts
        Number of tokens on each line (one entry per newline).
    values
        The tokens, in file order, or an empty array with ``counts.sum() > 0`` when one is not
        a number (the caller says which kind of line it was).
    """
    if not len(a):
        return np.zeros(0, np.int64), np.zeros(0)
    ws = (a == _SP) | (a == _NL)
    start = ~ws
    start[1:] &= ws[:-1]
    newlines = np.flatnonzero(a == _NL)
    line = np.searchsorted(newlines, np.flatnonzero(start))
    counts = np.bincount(line, minlength=len(newlines)).astype(np.int64)
    values = _strict_floats(a.tobytes())
    if values is None or len(values) != counts.sum():
        return counts, np.zeros(0)
    return counts, values


def _line_bounds(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start of each line and its length including the newline (``a`` ends with a newline)."""
    ends = np.flatnonzero(a == _NL) + 1
    starts = np.r_[0, ends[:-1]]
    return starts, ends - starts


def _select_lines(a: np.ndarray, starts: np.ndarray, lengths: np.ndarray, keep: np.ndarray, blank_first: int) -> np.ndarray:
    """The bytes of the kept lines, with their first ``blank_first`` bytes (a keyword) blanked."""
    out = a[np.repeat(keep, lengths)]
    kept_len = lengths[keep]
    first = np.cumsum(kept_len) - kept_len
    for i in range(blank_first):  # the keyword's length: one or two bytes, not per line
        out[first + i] = _SP
    return out


def fan(counts: np.ndarray, indices: np.ndarray, first: np.ndarray) -> np.ndarray:
    """Fan-triangulate polygons: the polygon starting at ``indices[first[i]]`` with
    ``counts[i]`` corners gives ``counts[i] - 2`` triangles sharing its first corner."""
    if len(indices) == 3 * len(counts) and np.all(counts == 3) and np.array_equal(first, np.arange(0, len(indices), 3)):
        return indices.reshape(-1, 3)  # triangles one after the other (the usual file): the items as they are
    n_tri = counts - 2
    total = int(n_tri.sum())
    base = np.repeat(first, n_tri)
    j = np.arange(total) - np.repeat(np.cumsum(n_tri) - n_tri, n_tri)
    return np.stack([indices[base], indices[base + j + 1], indices[base + j + 2]], axis=1)


def _as_index(path: Path, fmt: str, values: np.ndarray) -> np.ndarray:
    """Float tokens that must be integer indices, as int64."""
    if len(values) and not np.all(np.isfinite(values) & (values == np.round(values))):
        raise malformed(path, fmt, "a face index is not an integer")
    return values.astype(np.int64)


def _prepare_text(data: bytes) -> bytes:
    """Text normalised for the tokenisers: no comments, tabs or CR, no leading spaces, ending
    with a newline. Works on bytes, so that a comment in any encoding (Latin-1, UTF-8 with a
    byte-order mark) is simply dropped: the numbers are ASCII in every encoding meshes use."""
    data = _COMMENT.sub(b"", data.translate(_TO_SPACE))
    data = _LEADING_SPACE.sub(b"", _CONTINUATION.sub(b" ", data))
    return data if data.endswith(b"\n") else data + b"\n"


# ----------------------------------------------------------------------------------------------
# OBJ


def _obj_chunks(path: Path):
    """The file in pieces that end at a line end (and not inside a continued line)."""
    with open(path, "rb") as fh:
        rest = b""
        first = True
        while True:
            block = fh.read(OBJ_CHUNK_BYTES)
            data = rest + block
            if first and data.startswith(UTF8_BOM):
                data = data[len(UTF8_BOM):]
            first = False
            if not block:
                if data:
                    yield data
                return
            cut = data.rfind(b"\n") + 1
            while cut > 0 and data[max(0, cut - 64) : cut].rstrip().endswith(b"\\"):  # a continued line: cut before it
                cut = data.rfind(b"\n", 0, cut - 1) + 1
            if cut <= 0:
                rest = data
                continue
            rest = data[cut:]
            yield data[:cut]


def read_obj(path: Path) -> RawMesh:
    """Read a Wavefront OBJ: ``v`` and ``f`` statements (``f`` with ``v/vt/vn`` references,
    polygons fan-triangulated); everything else (normals, texture coordinates, materials,
    groups) is ignored.

    Relative (negative) indices count back from the last vertex read so far in the whole file,
    as the OBJ specification says, whatever objects (``o``) and groups (``g``) came before.
    """
    verts, faces, face_obj = [], [], []
    n_v = n_o = 0  # vertices and objects read in the previous chunks
    for chunk in _obj_chunks(path):
        a = np.frombuffer(_prepare_text(chunk), np.uint8).copy()
        starts, lengths = _line_bounds(a)
        c0 = a[starts]
        c1 = np.where(lengths > 1, a[np.minimum(starts + 1, len(a) - 1)], _NL)
        after_kw = (c1 == _SP) | (c1 == _NL)
        is_v = (c0 == ord("v")) & after_kw
        is_f = (c0 == ord("f")) & after_kw
        is_o = (c0 == ord("o")) & after_kw
        # vertices read before each line, in the whole file: what a relative index counts from
        v_before = n_v + np.cumsum(is_v) - is_v
        obj_of_line = n_o + np.cumsum(is_o)

        if is_v.any():
            counts, values = tokenize_lines(_select_lines(a, starts, lengths, is_v, 1))
            if not len(values) and counts.sum() or np.any(counts < 3):
                raise malformed(path, "OBJ", "a vertex line does not hold three numbers")
            first = np.cumsum(counts) - counts
            verts.append(values[first[:, None] + np.arange(3)])  # x y z; a w or a colour is ignored
            n_v += len(counts)
        if is_f.any():
            fb = _select_lines(a, starts, lengths, is_f, 1)
            # keep only the vertex of each v/vt/vn reference: blank from a slash to the token's end
            pos = np.arange(len(fb), dtype=np.int32)  # a chunk is far below 2**31 bytes
            last_slash = np.maximum.accumulate(np.where(fb == _SLASH, pos, -1))
            last_sep = np.maximum.accumulate(np.where((fb == _SP) | (fb == _NL), pos, -1))
            fb[last_slash > last_sep] = _SP
            del pos, last_slash, last_sep
            counts, values = tokenize_lines(fb)
            if not len(values) and counts.sum():
                raise malformed(path, "OBJ", "a face refers to a vertex that is not a number")
            if np.any(counts < 3):
                raise malformed(path, "OBJ", "a face has fewer than three vertices")
            idx = _as_index(path, "OBJ", values)
            if np.any(idx == 0):
                raise malformed(path, "OBJ", "a face refers to vertex 0; OBJ counts vertices from 1")
            rel = np.repeat(v_before[is_f], counts)
            idx = np.where(idx < 0, rel + idx, idx - 1)
            first = np.cumsum(counts) - counts
            faces.append(fan(counts, idx, first))
            face_obj.append(np.repeat(obj_of_line[is_f], counts - 2))
        n_o = int(obj_of_line[-1]) if len(obj_of_line) else n_o
    v = np.concatenate(verts) if verts else np.zeros((0, 3))
    f = np.concatenate(faces) if faces else np.zeros((0, 3), np.int64)
    objects = len(np.unique(np.concatenate(face_obj))) if face_obj else 0
    return RawMesh(v, f, objects)


# ----------------------------------------------------------------------------------------------
# OFF

_OFF_KEYWORD = re.compile(rb"\A\s*(ST)?C?N?4?OFF\b")


def off_counts(head: bytes) -> tuple[int, int] | None:
    """Vertex and face counts of an OFF header, or ``None`` when ``head`` does not start one."""
    text = _COMMENT.sub(b"", head.translate(_TO_SPACE))
    if text.startswith(UTF8_BOM):
        text = text[len(UTF8_BOM):]
    m = _OFF_KEYWORD.match(text)
    tokens = text[m.end() if m else 0 :].split(None, 3)
    try:
        return int(tokens[0]), int(tokens[1])
    except (IndexError, ValueError):
        return None


def read_off(path: Path) -> RawMesh:
    """Read an ASCII OFF (``OFF``, ``COFF``, ``NOFF``...: extra per-vertex or per-face values
    such as colours are ignored); polygons are fan-triangulated."""
    data = path.read_bytes()
    if data.startswith(UTF8_BOM):
        data = data[len(UTF8_BOM):]
    text = _prepare_text(data)
    m = _OFF_KEYWORD.match(text)
    if m is None and not re.match(rb"\s*\d", text):
        raise malformed(path, "OFF", "it does not start with OFF")
    if re.match(rb"[ \t]*BINARY", text[m.end() :] if m else b""):
        raise InputError(f"{path}: is a binary OFF, which meshplan does not read", "export the scan as ASCII OFF, PLY or OBJ")
    body = np.frombuffer(text[m.end() if m else 0 :], np.uint8)
    if not len(body) or body[-1] != _NL:
        body = np.r_[body, np.uint8(_NL)]
    counts, values = tokenize_lines(body)
    if not len(values) and counts.sum():
        raise malformed(path, "OFF", "a value is not a number")
    counts = counts[counts > 0]  # blank lines (and lines that held only comments)
    first = np.cumsum(counts) - counts
    if not len(counts) or counts[0] < 2:
        raise malformed(path, "OFF", "no vertex and face counts after OFF")
    nv, nf = values[0], values[1]
    if not (np.isfinite(nv) and np.isfinite(nf) and nv == int(nv) >= 0 and nf == int(nf) >= 0):
        raise malformed(path, "OFF", "the vertex and face counts are not counts")
    nv, nf = int(nv), int(nf)
    last = len(counts) - 1  # the file's last line: where a cut shows
    held = _first_short(counts[1 : 1 + nv] >= 3)
    if held < nv:
        if 1 + held < last:
            raise malformed(path, "OFF", f"vertex {held + 1} does not have three coordinates")
        raise truncated(path, f"{nv:,} vertices and {nf:,} faces", f"{held:,} vertices and no face")
    vertices = values[first[1 : 1 + nv, None] + np.arange(3)]
    f_lines = counts[1 + nv : 1 + nv + nf]
    f_first = first[1 + nv : 1 + nv + nf]
    k = _as_index(path, "OFF", values[f_first])
    held = _first_short(f_lines >= 1 + np.maximum(k, 0))
    if held < nf:
        if 1 + nv + held < last:
            raise malformed(path, "OFF", f"face {held + 1} has fewer vertex indices than its count")
        raise truncated(path, f"{nf:,} faces", f"{held:,}")
    if np.any(k < 3):
        raise malformed(path, "OFF", "a face has fewer than three vertices")
    corners = np.repeat(f_first + 1, k) + (np.arange(int(k.sum())) - np.repeat(np.cumsum(k) - k, k))
    idx = _as_index(path, "OFF", values[corners])
    return RawMesh(vertices, fan(k, idx, np.cumsum(k) - k), 1)


# ----------------------------------------------------------------------------------------------
# PLY

#: numpy type of each PLY scalar type.
PLY_TYPES = {
    "char": "i1", "uchar": "u1", "int8": "i1", "uint8": "u1", "short": "i2", "ushort": "u2",
    "int16": "i2", "uint16": "u2", "int": "i4", "uint": "u4", "int32": "i4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}

#: Names of the face property that lists a face's vertices.
_FACE_LIST = ("vertex_indices", "vertex_index")


@dataclass(frozen=True)
class PlyProperty:
    name: str
    dtype: str  # the scalar's numpy type, or the list's item type
    count_dtype: str = ""  # the list's count type; empty for a scalar

    @property
    def is_list(self) -> bool:
        return bool(self.count_dtype)


@dataclass(frozen=True)
class PlyElement:
    name: str
    count: int
    properties: tuple[PlyProperty, ...]


@dataclass(frozen=True)
class PlyHeader:
    format: str  # "ascii", "binary_little_endian" or "binary_big_endian"
    elements: tuple[PlyElement, ...]
    data_start: int

    def element(self, name: str) -> PlyElement | None:
        return next((e for e in self.elements if e.name == name), None)


def parse_ply_header(path: Path, head: bytes) -> PlyHeader:
    """The header of a PLY file, from its first bytes; :class:`InputError` if it is malformed."""
    if not head.startswith(b"ply"):
        raise malformed(path, "PLY", "it does not start with ply")
    end = re.search(rb"(?m)^end_header[ \t]*\r?\n", head)
    if end is None:
        raise malformed(path, "PLY", "no end_header line in its first 64 kB")
    fmt: str | None = None
    elements: list[tuple[str, int, list[PlyProperty]]] = []
    current: tuple[str, int, list[PlyProperty]] | None = None
    raw = ""
    try:
        for raw in head[: end.start()].decode("latin-1").splitlines()[1:]:  # a few header lines
            parts = raw.split()
            if not parts or parts[0] in ("comment", "obj_info"):
                continue
            if parts[0] == "format":
                fmt = parts[1]
            elif parts[0] == "element":
                current = (parts[1], int(parts[2]), [])
                if current[1] < 0:
                    raise ValueError
                elements.append(current)
            elif parts[0] == "property" and current is not None:
                if parts[1] == "list":
                    current[2].append(PlyProperty(parts[4], PLY_TYPES[parts[3]], PLY_TYPES[parts[2]]))
                else:
                    current[2].append(PlyProperty(parts[2], PLY_TYPES[parts[1]]))
            else:
                raise ValueError
    except (ValueError, IndexError, KeyError):
        raise malformed(path, "PLY", f"bad header line {raw.strip()[:60]!r}") from None
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise malformed(path, "PLY", f"unknown format {fmt!r}")
    return PlyHeader(str(fmt), tuple(PlyElement(n, c, tuple(p)) for n, c, p in elements), end.end())


def _vertex_columns(path: Path, element: PlyElement) -> list[int]:
    names = [p.name for p in element.properties]
    if not all(c in names for c in "xyz"):
        raise malformed(path, "PLY", "its vertices have no x, y and z")
    if any(element.properties[names.index(c)].is_list for c in "xyz"):
        raise malformed(path, "PLY", "its vertex coordinates are lists")
    return [names.index(c) for c in "xyz"]


def _face_list(path: Path, element: PlyElement | None) -> int | None:
    if element is None:
        return None
    names = [p.name for p in element.properties]
    i = next((names.index(n) for n in _FACE_LIST if n in names), None)
    if i is None or not element.properties[i].is_list:
        raise malformed(path, "PLY", "its faces have no vertex_indices list")
    return i


def _ply_truncated(path: Path, header: PlyHeader, element: str, held: int, vertices: int) -> InputError:
    """The refusal of a PLY whose ``element`` holds only ``held`` of its records."""
    vertex = header.element("vertex")
    nv = vertex.count if vertex is not None else 0
    face = header.element("face")
    nf = face.count if face is not None else 0
    if element == "face" and vertices >= nv:
        return truncated(path, f"{nf:,} faces", f"{held:,}")
    return truncated(path, f"{nv:,} vertices and {nf:,} faces", f"{held if element == 'vertex' else vertices:,} vertices and no face")


def _first_short(ok: np.ndarray) -> int:
    """Index of the first ``False`` of ``ok``, or its length."""
    return int(np.argmin(ok)) if not ok.all() else len(ok)


def read_ply(path: Path) -> RawMesh:
    """Read a PLY file (ascii, binary little- or big-endian), polygons fan-triangulated; the
    vertices keep the file's precision (``double`` stays float64)."""
    data = path.read_bytes()
    header = parse_ply_header(path, data[:65536])
    vertex = header.element("vertex")
    if vertex is None:
        raise malformed(path, "PLY", "no vertex element")
    xyz = _vertex_columns(path, vertex)
    face = header.element("face")
    list_i = _face_list(path, face)
    reader = _read_ply_ascii if header.format == "ascii" else _read_ply_binary
    vertices, counts, indices = reader(path, header, data, xyz, list_i)
    f32 = [vertex.properties[i].dtype == "f4" for i in xyz]
    extent = float(np.abs(vertices[:, f32]).max(initial=0.0, where=np.isfinite(vertices[:, f32]))) if any(f32) else 0.0
    if counts is None or not len(counts):
        return RawMesh(vertices, np.zeros((0, 3), np.int64), 0, extent)
    if np.any(counts < 3):
        raise malformed(path, "PLY", "a face has fewer than three vertices")
    return RawMesh(vertices, fan(counts, indices, np.cumsum(counts) - counts), 1, extent)


def _read_ply_ascii(path, header, data, xyz, list_i):
    body = np.frombuffer(_prepare_text(data[header.data_start :]), np.uint8)
    counts, values = tokenize_lines(body)
    if not len(values) and counts.sum():
        raise malformed(path, "PLY", "a value is not a number")
    counts = counts[counts > 0]
    first = np.cumsum(counts) - counts
    line = 0
    vertices = face_counts = face_idx = None
    for el in header.elements:  # a handful of elements
        n_tok, line_first = counts[line : line + el.count], first[line : line + el.count]
        # the token of each property on each line, in property order (lists have a count first)
        rel = np.zeros(len(n_tok), np.int64)
        col = {}
        for p in el.properties:  # a handful of properties
            col[p.name] = line_first + rel
            if p.is_list:
                inside = rel < n_tok
                cnt = np.where(inside, values[np.minimum(line_first + rel, len(values) - 1)], 0)
                rel = rel + 1 + np.clip(np.nan_to_num(cnt), 0, len(values)).astype(np.int64)
            else:
                rel = rel + 1
        held = _first_short(rel <= n_tok)
        if held < el.count:
            if line + held < len(counts) - 1:  # a short line that is not the file's last: not a cut
                raise malformed(path, "PLY", f"{el.name} {held + 1} has fewer values than the header says")
            raise _ply_truncated(path, header, el.name, held, len(vertices) if vertices is not None else 0)
        if el.name == "vertex":
            vertices = np.stack([values[col[el.properties[i].name]] for i in xyz], axis=1)
        elif el.name == "face":
            start = col[el.properties[list_i].name]
            face_counts = _as_index(path, "PLY", values[start])
            corner = np.arange(int(face_counts.sum())) - np.repeat(np.cumsum(face_counts) - face_counts, face_counts)
            face_idx = _as_index(path, "PLY", values[np.repeat(start + 1, face_counts) + corner])
        line += el.count
    return vertices, face_counts, face_idx


def _read_at(a: np.ndarray, pos: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """Scalars of ``dtype`` at arbitrary (unaligned) byte positions of ``a``; positions past
    the end read as 0 (the caller checks the bounds)."""
    if len(a) < dtype.itemsize:
        return np.zeros(len(pos), dtype)
    raw = np.empty((len(pos), dtype.itemsize), np.uint8)
    pos = np.clip(pos, 0, len(a) - dtype.itemsize)
    for j in range(dtype.itemsize):  # one gather per byte of the scalar (1 to 8)
        raw[:, j] = a[pos + j]
    return raw.view(dtype).reshape(-1)


def _uniform_lists(data: bytes, start: int, n: int, el: PlyElement, endian: str, list_name: str) -> tuple[np.ndarray, np.ndarray, int] | None:
    """The counts and items of a list property, and the end of the element, when every record
    has the first one's list lengths (the usual all-triangle file): one structured read, no
    gathers. ``None`` otherwise (mixed polygon sizes, or a file cut short)."""
    a = np.frombuffer(data, np.uint8, offset=min(start, len(data)))  # a view, not a copy
    fields, off = [], 0
    for i, p in enumerate(el.properties):  # a handful of properties
        if p.is_list:
            cnt = int(_read_at(a, np.array([off]), np.dtype(endian + p.count_dtype))[0])
            if cnt < 0 or off + cnt * np.dtype(p.dtype).itemsize > len(a):  # the first record does not fit
                return None
            fields += [(f"c{i}", endian + p.count_dtype), (f"l{i}", endian + p.dtype, (cnt,))]
            off += np.dtype(p.count_dtype).itemsize + cnt * np.dtype(p.dtype).itemsize
        else:
            fields.append((f"s{i}", endian + p.dtype))
            off += np.dtype(p.dtype).itemsize
    dt = np.dtype(fields)
    if start + n * dt.itemsize > len(data):
        return None
    rec = np.frombuffer(data, dt, count=n, offset=start)
    # if every count is the first one's, each record starts where this layout says
    if any(p.is_list and n and np.any(rec[f"c{i}"] != rec[f"c{i}"][0]) for i, p in enumerate(el.properties)):
        return None
    i = [p.name for p in el.properties].index(list_name)
    return rec[f"c{i}"].astype(np.int64), rec[f"l{i}"].reshape(-1).astype(np.int64), start + n * dt.itemsize


def _record_lengths(a: np.ndarray, pos: np.ndarray, el: PlyElement, endian: str) -> tuple[np.ndarray, dict[str, tuple[np.ndarray, np.ndarray]]]:
    """Length of a record of ``el`` starting at each position, and for each list property the
    byte position of its items and its count. A count that is negative makes the length huge,
    so that such a record never fits."""
    off = np.zeros(len(pos), np.int64)
    lists = {}
    for p in el.properties:  # a handful of properties
        if p.is_list:
            cnt = _read_at(a, pos + off, np.dtype(endian + p.count_dtype)).astype(np.int64)
            cnt = np.where(cnt < 0, len(a) + 1, cnt)
            lists[p.name] = (pos + off + np.dtype(p.count_dtype).itemsize, cnt)
            off = off + np.dtype(p.count_dtype).itemsize + cnt * np.dtype(p.dtype).itemsize
        else:
            off = off + np.dtype(p.dtype).itemsize
    return off, lists


def _walk(a: np.ndarray, start: int, el: PlyElement, endian: str) -> np.ndarray:
    """Start positions of the complete records of ``el`` (at most ``el.count``) from ``start``,
    followed by the position after the last one.

    Records with lists have lengths that depend on their counts. When all have the length of
    the first (the usual all-triangle file) one strided read proves it. Otherwise the chain of
    records is followed by pointer doubling: the next record's position is computed for every
    byte position at once, then composed with itself ``log2(count)`` times.
    """
    n, end = el.count, len(a)
    if n == 0:
        return np.array([start], np.int64)
    first_len, _ = _record_lengths(a, np.array([start]), el, endian)
    stride = int(first_len[0])
    if 0 < stride <= end:
        if start + n * stride <= end:  # (else the file is cut short, or the records differ)
            pos = start + stride * np.arange(n + 1, dtype=np.int64)
            lengths, _ = _record_lengths(a, pos[:-1], el, endian)
            if np.all(lengths == stride):
                return pos
    region = end - start
    # int32 positions when they fit: the doubling holds two arrays of one position per byte
    itype = np.int32 if region < 2**31 - 2 else np.int64
    nxt = np.empty(region + 2, itype)
    for b0 in range(0, region, WALK_BLOCK_BYTES):  # blocks bound the temporary arrays
        local = np.arange(b0, min(region, b0 + WALK_BLOCK_BYTES), dtype=np.int64)
        lengths, _ = _record_lengths(a, start + local, el, endian)
        nxt[local] = np.where(local + lengths <= region, local + lengths, region + 1)
    nxt[region] = region + 1  # no record starts at the end of the file
    nxt[region + 1] = region + 1  # past the end: stays there
    chain = np.array([0], itype)
    while len(chain) < n + 1 and chain[-1] <= region:
        chain = np.concatenate([chain, nxt[chain]])
        nxt = nxt[nxt]
    chain = chain[: n + 1]
    chain = chain[np.asarray(chain) <= region]
    return start + chain.astype(np.int64)


def _read_ply_binary(path, header, data, xyz, list_i):
    endian = "<" if header.format == "binary_little_endian" else ">"
    a = np.frombuffer(data, np.uint8)
    pos = header.data_start
    vertices = face_counts = face_idx = None
    for el in header.elements:  # a handful of elements
        if not any(p.is_list for p in el.properties):
            dt = np.dtype([(f"p{i}", endian + p.dtype) for i, p in enumerate(el.properties)])
            held = min(el.count, (len(a) - pos) // dt.itemsize) if dt.itemsize else el.count
            if el.name == "vertex":
                rec = np.frombuffer(data, dt, count=held, offset=pos)
                vertices = np.stack([rec[f"p{i}"].astype(np.float64) for i in xyz], axis=1)
            starts_end = pos + dt.itemsize * held
        elif el.name == "face" and (fast := _uniform_lists(data, pos, el.count, el, endian, el.properties[list_i].name)) is not None:
            face_counts, face_idx, starts_end = fast
            held = el.count
        else:
            chain = _walk(a, pos, el, endian)
            held = len(chain) - 1
            starts_end = int(chain[-1])
            if el.name == "face":
                _, lists = _record_lengths(a, chain[:-1], el, endian)
                items, face_counts = lists[el.properties[list_i].name]
                p = el.properties[list_i]
                size = np.dtype(p.dtype).itemsize
                corner = np.arange(int(face_counts.sum())) - np.repeat(np.cumsum(face_counts) - face_counts, face_counts)
                face_idx = _read_at(a, np.repeat(items, face_counts) + corner * size, np.dtype(endian + p.dtype)).astype(np.int64)
            elif el.name == "vertex":
                raise malformed(path, "PLY", "its vertices have list properties")
        if held < el.count:
            raise _ply_truncated(path, header, el.name, held, len(vertices) if vertices is not None else 0)
        pos = starts_end
    return vertices, face_counts, face_idx

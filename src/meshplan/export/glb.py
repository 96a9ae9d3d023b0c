"""Binary glTF (GLB) models for viewers: the oriented mesh, each story without its ceiling, the
flat walls, and the annotations as small coloured markers with their probes."""

from __future__ import annotations

import numpy as np

from ..geometry import ANNOTATION_PROBE_M, Annotations, Mesh

#: RGBA colour of each annotation kind.
KIND_RGBA = {
    "sensor": (214, 39, 40, 255),
    "thermostat": (255, 127, 14, 255),
    "door": (140, 86, 75, 255),
    "window": (31, 119, 180, 255),
    "other": (148, 103, 189, 255),
}
MESH_RGBA = (200, 200, 200, 255)
WALL_RGBA = (230, 225, 210, 255)


def submesh(mesh: Mesh, faces: np.ndarray) -> Mesh:
    """``mesh.submesh(faces)``, the same arrays, in linear time: the vertices used are marked in
    a table of all vertices rather than found by sorting the corners (``np.unique``), a third
    of the cost of a story's model on the benchmark apartment."""
    sel = mesh.faces[np.asarray(faces)]
    used = np.zeros(mesh.n_vertices, dtype=bool)
    used[sel.ravel()] = True
    index = np.flatnonzero(used)
    remap = np.zeros(mesh.n_vertices, dtype=np.int64)
    remap[index] = np.arange(len(index))
    # fresh arrays, valid indices: taken as they are (Mesh() would copy and check them)
    return Mesh._adopt(mesh.vertices[index], remap[sel].reshape(-1, 3))


#: glTF accessor component types (GL enums) and bufferView alignment (bytes).
_UBYTE, _UINT, _FLOAT = 5121, 5125, 5126
_ALIGN = 4
#: Marker shapes: an icosphere subdivided twice (162 vertices, 320 faces, as trimesh's
#: ``icosphere(subdivisions=2)``) and a capped cylinder of 8 sides along the probe.
MARKER_SUBDIVISIONS = 2
PROBE_SIDES = 8


def _icosphere(subdivisions: int) -> tuple[np.ndarray, np.ndarray]:
    """A unit icosphere: the icosahedron with each triangle split in four ``subdivisions``
    times, the new vertices pushed out to the sphere."""
    t = (1.0 + 5.0**0.5) / 2.0
    v = np.array(
        [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]],
        dtype=np.float64,
    )
    f = np.array(
        [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
         [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]],
        dtype=np.int64,
    )  # fmt: skip
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    for _ in range(subdivisions):
        edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        unique, inverse = np.unique(edges, axis=0, return_inverse=True)
        mid = v[unique].mean(axis=1)
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        m = inverse.reshape(3, -1).T + len(v)  # the midpoints of edges 01, 12, 20 of each face
        v = np.concatenate([v, mid])
        f = np.concatenate([np.c_[f[:, 0], m[:, 0], m[:, 2]], np.c_[m[:, 0], f[:, 1], m[:, 1]], np.c_[m[:, 2], m[:, 1], f[:, 2]], m])
    return v, f


def _cylinder(a: np.ndarray, b: np.ndarray, radius: float, sides: int) -> tuple[np.ndarray, np.ndarray]:
    """A capped cylinder of ``sides`` sides from ``a`` to ``b``, faces turned outwards."""
    axis = b - a
    axis = axis / (np.linalg.norm(axis) or 1.0)
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(axis, helper)
    u /= np.linalg.norm(u)
    w = np.cross(axis, u)
    ang = 2.0 * np.pi * np.arange(sides) / sides
    ring = radius * (np.cos(ang)[:, None] * u + np.sin(ang)[:, None] * w)
    v = np.concatenate([a + ring, b + ring, [a, b]])
    i = np.arange(sides)
    j = (i + 1) % sides
    ca, cb = 2 * sides, 2 * sides + 1
    caps = [np.c_[np.full(sides, ca), j, i], np.c_[np.full(sides, cb), sides + i, sides + j]]
    f = np.concatenate([np.c_[i, j, sides + j], np.c_[i, sides + j, sides + i], *caps])
    return v, f


#: The markers of the last annotations drawn, by their content: a run's models hold the same
#: annotations (each story's and the whole scan's).
_MARKERS: dict[tuple, list] = {}


def annotation_markers(annotations: Annotations, radius_m: float = 0.06, probe_m: float = ANNOTATION_PROBE_M):
    """``(name, vertices, faces, rgba)`` markers: a sphere per annotation and a thin cylinder
    along its probe direction. The arrays are shared between calls with the same annotations:
    treat them as read-only."""
    key = (
        tuple(annotations.labels),
        tuple(annotations.kinds),
        np.asarray(annotations.positions, dtype=np.float64).tobytes(),
        np.asarray(annotations.directions, dtype=np.float64).tobytes(),
        radius_m,
        probe_m,
    )
    if key not in _MARKERS:
        _MARKERS.clear()  # one set at a time: a batch's next scan has other annotations
        _MARKERS[key] = _make_markers(annotations, radius_m, probe_m)
    return list(_MARKERS[key])


def _make_markers(annotations: Annotations, radius_m: float, probe_m: float) -> list:
    sphere_v, sphere_f = _icosphere(MARKER_SUBDIVISIONS)
    out = []
    for i, (label, kind) in enumerate(zip(annotations.labels, annotations.kinds)):
        p = np.asarray(annotations.positions[i], dtype=np.float64)
        verts, faces = [sphere_v * radius_m + p], [sphere_f]
        d = np.asarray(annotations.directions[i], dtype=np.float64)
        if np.all(np.isfinite(d)):
            cv, cf = _cylinder(p, p + probe_m * d, radius_m / 4, PROBE_SIDES)
            verts.append(cv)
            faces.append(cf + len(sphere_v))
        out.append((f"{label} ({kind})", np.concatenate(verts), np.concatenate(faces), KIND_RGBA.get(kind, KIND_RGBA["other"])))
    return out


def glb_bytes(mesh: Mesh, annotations: Annotations | None = None, name: str = "scan", rgba=MESH_RGBA) -> bytes:
    """A GLB scene holding ``mesh`` and the annotation markers (plan frame, y up as glTF wants):
    a node and a mesh for each, positions as float32, one colour on every vertex (COLOR_0).

    Written directly (:func:`_glb`): trimesh's exporter, which wrote them before, took 0.2 s to
    import on the run's critical path and wrote the same accessors."""
    parts = []
    if mesh.n_faces:
        parts.append((name, mesh.vertices, mesh.faces, rgba))
    parts += annotation_markers(annotations or Annotations())
    if not parts:  # e.g. the flat walls of a story where none was found
        return empty_glb()
    return _glb(parts)


def _glb(parts: list) -> bytes:
    """The GLB of ``parts`` ``(name, vertices, faces, rgba)``, identical accessors shared.

    The binary chunk is gathered once, from the arrays themselves, in the final join: a
    3M-face scan's buffers (60 MB) were copied four times and hashed whole to look for a twin
    (0.1 s per model). Accessors of the same type and size are compared byte for byte, as
    before: the markers' repeated shapes are still shared."""
    import json
    import struct

    pieces: list = []  # the binary chunk: the buffers and their alignment padding, in order
    size = 0
    views: list[dict] = []
    accessors: list[dict] = []
    seen: dict[tuple, list[tuple[np.ndarray, int]]] = {}

    def accessor(data: np.ndarray, ctype: int, kind: str, extra: dict) -> int:
        nonlocal size
        raw = np.ascontiguousarray(data).reshape(-1).view(np.uint8)
        twins = seen.setdefault((ctype, kind, raw.nbytes), [])
        for other, index in twins:
            if np.array_equal(other, raw):
                return index
        pad = -size % _ALIGN
        if pad:
            pieces.append(b"\0" * pad)
            size += pad
        views.append({"buffer": 0, "byteOffset": size, "byteLength": int(raw.nbytes)})
        pieces.append(raw)
        size += raw.nbytes
        accessors.append({"bufferView": len(views) - 1, "componentType": ctype, "count": int(len(data)), "type": kind, **extra})
        twins.append((raw, len(accessors) - 1))
        return len(accessors) - 1

    meshes, nodes = [], []
    for name, vertices, faces, rgba in parts:
        v = np.asarray(vertices, dtype=np.float32)
        f = np.asarray(faces, dtype=np.uint32).reshape(-1)
        colour = np.tile(np.asarray(rgba, dtype=np.uint8), (len(v), 1))
        idx = accessor(f, _UINT, "SCALAR", {"max": [int(f.max())], "min": [int(f.min())]})
        pos = accessor(v, _FLOAT, "VEC3", {"max": v.max(axis=0).tolist(), "min": v.min(axis=0).tolist()})
        col = accessor(colour, _UBYTE, "VEC4", {"normalized": True, "max": list(map(int, rgba)), "min": list(map(int, rgba))})
        meshes.append({"name": name, "primitives": [{"attributes": {"POSITION": pos, "COLOR_0": col}, "indices": idx, "mode": 4}]})
        nodes.append({"name": name, "mesh": len(meshes) - 1})
    pad = -size % _ALIGN
    if pad:
        pieces.append(b"\0" * pad)
        size += pad
    doc = {
        "asset": {"version": "2.0", "generator": "meshplan"},
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "meshes": meshes,
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": size}],
    }
    chunk = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    chunk += b" " * (-len(chunk) % _ALIGN)  # chunks are 4-byte aligned, JSON padded with spaces
    total = 12 + 8 + len(chunk) + 8 + size
    return b"".join([struct.pack("<4sII", b"glTF", 2, total), struct.pack("<I4s", len(chunk), b"JSON"), chunk, struct.pack("<I4s", size, b"BIN\0"), *pieces])


def empty_glb() -> bytes:
    """A valid GLB holding one empty scene."""
    import json
    import struct

    doc = json.dumps({"asset": {"version": "2.0", "generator": "meshplan"}, "scene": 0, "scenes": [{"nodes": []}]}, separators=(",", ":"))
    chunk = doc.encode("ascii")
    chunk += b" " * (-len(chunk) % 4)  # chunks are 4-byte aligned, JSON padded with spaces
    return struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(chunk)) + struct.pack("<I4s", len(chunk), b"JSON") + chunk

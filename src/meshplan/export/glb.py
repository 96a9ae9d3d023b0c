"""Binary glTF (GLB) models for viewers: the oriented mesh, each story without its ceiling, the
flat walls, and the annotations as small coloured markers with their probes."""

from __future__ import annotations

from typing import cast

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
    return Mesh(mesh.vertices[index], remap[sel].reshape(-1, 3))


def _trimesh(mesh: Mesh, rgba):
    import trimesh

    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    colour = np.array(rgba, dtype=np.uint8)
    used = np.zeros(mesh.n_vertices, dtype=bool)
    used[mesh.faces.ravel()] = True
    if used.all():
        # one colour on every vertex: what the glTF exporter would derive from the face colours
        # (averaging them around each vertex through a sparse matrix, a third of the export)
        tm.visual = trimesh.visual.ColorVisuals(tm, vertex_colors=np.tile(colour, (mesh.n_vertices, 1)))
    else:  # a vertex of no face: its colour is the exporter's to choose, as before
        tm.visual = trimesh.visual.ColorVisuals(tm, face_colors=np.tile(colour, (mesh.n_faces, 1)))
    return tm


#: The markers of the last annotations drawn, by their content: a run's models hold the same
#: annotations (each story's and the whole scan's), and building the markers (subdivided
#: spheres, cylinders) cost a third of writing the models' GLB files.
_MARKERS: dict[tuple, list] = {}


def annotation_markers(annotations: Annotations, radius_m: float = 0.06, probe_m: float = ANNOTATION_PROBE_M):
    """``(name, trimesh.Trimesh)`` markers: a sphere per annotation and a thin cylinder along
    its probe direction. The meshes are shared between calls with the same annotations: treat
    them as read-only."""
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
    import trimesh

    out = []
    for i, (label, kind) in enumerate(zip(annotations.labels, annotations.kinds)):
        p = annotations.positions[i]
        parts = [trimesh.creation.icosphere(subdivisions=2, radius=radius_m).apply_translation(p)]
        d = annotations.directions[i]
        if np.all(np.isfinite(d)):
            seg = np.array([p, p + probe_m * d])
            parts.append(trimesh.creation.cylinder(radius=radius_m / 4, segment=seg, sections=8))
        m = cast(trimesh.Trimesh, trimesh.util.concatenate(parts))  # meshes in, one mesh out
        m.visual = trimesh.visual.ColorVisuals(m, face_colors=np.tile(np.array(KIND_RGBA.get(kind, KIND_RGBA["other"]), dtype=np.uint8), (len(m.faces), 1)))
        out.append((f"{label} ({kind})", m))
    return out


def glb_bytes(mesh: Mesh, annotations: Annotations | None = None, name: str = "scan", rgba=MESH_RGBA) -> bytes:
    """A GLB scene holding ``mesh`` and the annotation markers (plan frame, y up as glTF wants)."""
    import trimesh

    scene = trimesh.Scene()
    if mesh.n_faces:
        scene.add_geometry(_trimesh(mesh, rgba), node_name=name, geom_name=name)
    for marker_name, marker in annotation_markers(annotations or Annotations()):
        scene.add_geometry(marker, node_name=marker_name, geom_name=marker_name)
    if not scene.geometry:  # e.g. the flat walls of a story where none was found
        return empty_glb()
    return scene.export(file_type="glb")


def empty_glb() -> bytes:
    """A valid GLB holding one empty scene (trimesh refuses to export one)."""
    import json
    import struct

    doc = json.dumps({"asset": {"version": "2.0", "generator": "meshplan"}, "scene": 0, "scenes": [{"nodes": []}]}, separators=(",", ":"))
    chunk = doc.encode("ascii")
    chunk += b" " * (-len(chunk) % 4)  # chunks are 4-byte aligned, JSON padded with spaces
    return struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(chunk)) + struct.pack("<I4s", len(chunk), b"JSON") + chunk

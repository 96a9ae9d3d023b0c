"""Writing a synthetic scan: the mesh, its annotations and its ground truth."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import ParameterError
from ..io import staged_directory
from ..io.annotations import annotations_document
from ..io.atomic import KIND_SYNTHETIC

SCAN_FORMATS = ("obj", "ply", "glb", "stl", "off")


def obj_text(vertices: np.ndarray, faces: np.ndarray, groups: np.ndarray | None = None, names: tuple[str, ...] = ()) -> str:
    """Wavefront OBJ with one object (``o``) per group, each with its own vertices, as the
    HoloLens Device Portal writes them."""
    lines = ["# meshplan synthetic scan"]
    if groups is None or not len(names):
        groups = np.zeros(len(faces), dtype=np.int64)
        names = ("scan",)
    offset = 0
    for g, name in enumerate(names):
        f = faces[groups == g]
        if not len(f):
            continue
        used, inv = np.unique(f, return_inverse=True)
        v = vertices[used]
        lines.append(f"o {name.replace(' ', '_')}")
        lines.append("\n".join(f"v {a:.6f} {b:.6f} {c:.6f}" for a, b, c in v))
        idx = inv.reshape(-1, 3) + 1 + offset
        lines.append("\n".join(f"f {a} {b} {c}" for a, b, c in idx))
        offset += len(v)
    return "\n".join(lines) + "\n"


def write_synthetic(scan, output: Path, fmt: str = "obj", force: bool = False) -> Path:
    """Write ``scan.<fmt>``, ``annotations.json`` and ``truth.json`` into ``output`` (atomically).

    Returns the path of the scan file.
    """
    import trimesh

    if fmt not in SCAN_FORMATS:
        raise ParameterError(f"unknown scan format {fmt!r}", f"use one of {', '.join(SCAN_FORMATS)}")
    with staged_directory(output, force=force, kind=KIND_SYNTHETIC) as tmp:
        name = f"scan.{fmt}"
        if fmt == "obj":
            (tmp / name).write_text(obj_text(scan.mesh.vertices, scan.mesh.faces, scan.face_groups, scan.group_names))
        else:
            tm = trimesh.Trimesh(scan.mesh.vertices, scan.mesh.faces, process=False)
            data = tm.export(file_type=fmt)
            assert isinstance(data, (bytes, str))  # single-file formats: only multi-file exports give a dict
            (tmp / name).write_bytes(data if isinstance(data, bytes) else data.encode())
        (tmp / "annotations.json").write_text(json.dumps(annotations_document(scan.annotations), indent=2) + "\n")
        (tmp / "truth.json").write_text(json.dumps(scan.truth, indent=1) + "\n")
    return Path(output) / name

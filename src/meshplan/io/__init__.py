"""Reading meshes and annotations, and writing files atomically (the only stage besides
:mod:`meshplan.export` and :mod:`meshplan.cli` that touches the file system)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:  # pragma: no cover
    from .annotations import annotations_document, load_annotations, parse_annotations
    from .atomic import atomic_write_bytes, atomic_write_text, check_output_dir, staged_directory
    from .mesh import MESH_FORMATS, POINT_FORMATS, SCAN_FORMATS, UNITS_M, USD_FORMATS, LoadedMesh, LoadStats, is_scan_file, load_mesh, write_mesh
    from .points import PointCloud, read_points
    from .usd import RoomPlanElements

#: Where each public name lives (loaded when first used, :mod:`meshplan._lazy`).
_EXPORTS = {
    "LoadStats": "mesh",
    "LoadedMesh": "mesh",
    "MESH_FORMATS": "mesh",
    "POINT_FORMATS": "mesh",
    "PointCloud": "points",
    "RoomPlanElements": "usd",
    "SCAN_FORMATS": "mesh",
    "UNITS_M": "mesh",
    "USD_FORMATS": "mesh",
    "annotations_document": "annotations",
    "atomic_write_bytes": "atomic",
    "atomic_write_text": "atomic",
    "check_output_dir": "atomic",
    "is_scan_file": "mesh",
    "load_annotations": "annotations",
    "load_mesh": "mesh",
    "parse_annotations": "annotations",
    "read_points": "points",
    "staged_directory": "atomic",
    "write_mesh": "mesh",
}

__all__ = [
    "LoadStats",
    "LoadedMesh",
    "MESH_FORMATS",
    "POINT_FORMATS",
    "PointCloud",
    "RoomPlanElements",
    "SCAN_FORMATS",
    "UNITS_M",
    "USD_FORMATS",
    "annotations_document",
    "atomic_write_bytes",
    "atomic_write_text",
    "check_output_dir",
    "is_scan_file",
    "load_annotations",
    "load_mesh",
    "parse_annotations",
    "read_points",
    "staged_directory",
    "write_mesh",
]
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())

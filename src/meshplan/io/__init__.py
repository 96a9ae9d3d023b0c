"""Reading meshes and annotations, and writing files atomically (the only stage besides
:mod:`meshplan.export` and :mod:`meshplan.cli` that touches the file system)."""

from .annotations import annotations_document, load_annotations, parse_annotations
from .atomic import atomic_write_bytes, atomic_write_text, check_output_dir, staged_directory
from .mesh import MESH_FORMATS, POINT_FORMATS, SCAN_FORMATS, UNITS_M, USD_FORMATS, LoadedMesh, LoadStats, is_scan_file, load_mesh, write_mesh
from .points import PointCloud, read_points
from .usd import RoomPlanElements

__all__ = [
    "MESH_FORMATS",
    "POINT_FORMATS",
    "SCAN_FORMATS",
    "UNITS_M",
    "USD_FORMATS",
    "LoadStats",
    "LoadedMesh",
    "annotations_document",
    "atomic_write_bytes",
    "atomic_write_text",
    "PointCloud",
    "RoomPlanElements",
    "check_output_dir",
    "is_scan_file",
    "load_annotations",
    "load_mesh",
    "parse_annotations",
    "read_points",
    "staged_directory",
    "write_mesh",
]

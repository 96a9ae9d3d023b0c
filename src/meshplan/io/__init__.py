"""Reading meshes and annotations, and writing files atomically (the only stage besides
:mod:`meshplan.export` and :mod:`meshplan.cli` that touches the file system)."""

from .annotations import annotations_document, load_annotations, parse_annotations
from .atomic import atomic_write_bytes, atomic_write_text, check_output_dir, staged_directory
from .mesh import MESH_FORMATS, UNITS_M, LoadedMesh, LoadStats, load_mesh, write_mesh

__all__ = [
    "MESH_FORMATS",
    "UNITS_M",
    "LoadStats",
    "LoadedMesh",
    "annotations_document",
    "atomic_write_bytes",
    "atomic_write_text",
    "check_output_dir",
    "load_annotations",
    "load_mesh",
    "parse_annotations",
    "staged_directory",
    "write_mesh",
]

"""Reading and writing annotation files.

An annotation file is JSON::

    {"annotations": [
        {"label": "S1", "kind": "sensor", "position": [x, y, z], "direction": [x, y, z]}
    ]}

in the coordinates (and units) of the scan it belongs to. ``kind`` is one of sensor, thermostat,
window, door, other; ``direction`` (the paper's "probe") is optional. Labels must be unique and
non-empty. Every problem is reported with the item and field it concerns.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np

from ..errors import AnnotationError
from ..geometry import ANNOTATION_KINDS, Annotations


def _vector(value, where: str, field: str, path: Path) -> list[float]:
    if not isinstance(value, list) or len(value) != 3 or not all(
        isinstance(c, (int, float)) and not isinstance(c, bool) for c in value
    ):
        raise AnnotationError(
            f"{path}: {where}: {field!r} must be a list of three numbers, got {json.dumps(value)[:60]}",
            "fix the annotation file",
        )
    if not all(math.isfinite(c) for c in value):
        raise AnnotationError(
            f"{path}: {where}: {field!r} has a NaN or infinite coordinate", "fix the annotation file"
        )
    return [float(c) for c in value]


def parse_annotations(doc: object, path: str | os.PathLike = "annotations", scale_to_m: float = 1.0) -> Annotations:
    """Validate a decoded annotation document and return it as :class:`Annotations` in metres."""
    p = Path(path)
    if not isinstance(doc, dict) or "annotations" not in doc:
        raise AnnotationError(
            f"{p}: expected an object with an \"annotations\" list", 'write {"annotations": [...]}'
        )
    items = doc["annotations"]
    if not isinstance(items, list):
        raise AnnotationError(f"{p}: \"annotations\" must be a list", 'write {"annotations": [...]}')
    labels, kinds, positions, directions = [], [], [], []
    seen: set[str] = set()
    for i, item in enumerate(items):
        where = f"annotation {i + 1}"
        if not isinstance(item, dict):
            raise AnnotationError(f"{p}: {where} is not an object", "each annotation is {\"label\", \"kind\", \"position\"}")
        for field in ("label", "kind", "position"):
            if field not in item:
                raise AnnotationError(f"{p}: {where} has no {field!r}", f"add {field!r} to every annotation")
        label = item["label"]
        if not isinstance(label, str) or not label.strip():
            raise AnnotationError(f"{p}: {where}: 'label' must be a non-empty string", "fix the annotation file")
        where = f"annotation {i + 1} ({label!r})"
        if label in seen:
            raise AnnotationError(f"{p}: {where}: duplicate label", "give every annotation its own label")
        seen.add(label)
        kind = item["kind"]
        if kind not in ANNOTATION_KINDS:
            raise AnnotationError(
                f"{p}: {where}: unknown kind {json.dumps(kind)[:40]}",
                f"use one of {', '.join(ANNOTATION_KINDS)}",
            )
        pos = _vector(item["position"], where, "position", p)
        direction = [math.nan] * 3
        if item.get("direction") is not None:
            direction = _vector(item["direction"], where, "direction", p)
            if math.hypot(*direction) == 0:
                raise AnnotationError(f"{p}: {where}: 'direction' is the zero vector", "give a non-zero direction or leave it out")
        labels.append(label)
        kinds.append(kind)
        positions.append(pos)
        directions.append(direction)
    return Annotations(
        tuple(labels),
        tuple(kinds),
        np.array(positions, dtype=np.float64).reshape(-1, 3) * scale_to_m,
        np.array(directions, dtype=np.float64).reshape(-1, 3),
    )


def load_annotations(path: str | os.PathLike, scale_to_m: float = 1.0) -> Annotations:
    """Read and validate an annotation file (see the module docstring for the format).

    Raises
    ------
    AnnotationError
        With the file, the annotation and the field that is wrong.
    """
    p = Path(path)
    if not p.is_file():
        raise AnnotationError(
            f"{p}: annotation file not found" if not p.exists() else f"{p}: is not a file",
            "check the path given to --annotations",
        )
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise AnnotationError(f"{p}: cannot be read ({exc})", "save it as UTF-8 JSON") from None
    try:
        doc = json.loads(text, parse_constant=lambda c: float(c))
    except json.JSONDecodeError as exc:
        raise AnnotationError(
            f"{p}: not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})", "fix the JSON syntax"
        ) from None
    return parse_annotations(doc, p, scale_to_m)


def annotations_document(annotations: Annotations, ndigits: int = 6) -> dict:
    """The JSON document for ``annotations`` (the inverse of :func:`parse_annotations`)."""
    return {"annotations": annotations.to_list(ndigits)}

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

import difflib
import json
import math
import os
from fractions import Fraction
from pathlib import Path

import numpy as np

from ..errors import AnnotationError
from ..geometry import ANNOTATION_KINDS, Annotations
from ..validation import MAX_LABEL_CHARS, describe, label_problem

#: Most annotations one file may hold: each is a marker and a label on every plan, an entity in
#: the DXF and IFC files and a row of the report; ten thousand already cover a large floor with
#: one object per square metre, more is a generated or broken file (and minutes of drawing).
MAX_ANNOTATIONS = 10_000

#: Largest annotation file read, in bytes: 10,000 annotations of a 200-character label and
#: two vectors take about 3 MB; 16 MB leaves room for pretty-printing and unknown fields while
#: a file of gigabytes is refused before it is read into memory.
MAX_ANNOTATION_FILE_BYTES = 16 * 2**20

#: Largest coordinate, in metres once the scan's unit is applied: 10,000 km holds georeferenced
#: scans (UTM northings reach 10,000 km) and anything beyond is not a place on Earth; it also
#: keeps every later product of coordinates (squared distances) far below float overflow.
MAX_COORDINATE_M = 1e7

#: The fields of an annotation; others are ignored (the report may add its own).
_FIELDS = ("label", "kind", "position", "direction")

_FIX = "fix the annotation file"


def _vector(value: object, where: str, field: str, path: Path, scale_to_m: float | None) -> list[float]:
    """Three finite numbers; with ``scale_to_m``, a position within :data:`MAX_COORDINATE_M`."""
    if not isinstance(value, list) or len(value) != 3 or not all(
        isinstance(c, (int, float)) and not isinstance(c, bool) for c in value
    ):
        raise AnnotationError(f"{path}: {where}: {field!r} must be a list of three numbers, got {describe(value)}", _FIX)
    # integers are compared exactly before float() would overflow (JSON integers are unbounded)
    if not all(isinstance(c, int) or math.isfinite(c) for c in value):
        raise AnnotationError(f"{path}: {where}: {field!r} has a NaN or infinite coordinate, got {describe(value)}", _FIX)
    if scale_to_m is not None:
        limit = MAX_COORDINATE_M / scale_to_m  # in the file's unit
        if not all(abs(c) <= limit for c in value):
            raise AnnotationError(
                f"{path}: {where}: {field!r} has a coordinate beyond {limit:g} (10,000 km), got {describe(value)}",
                "give coordinates in the scan's unit and coordinate system",
            )
        return [float(c) for c in value]
    # a direction: only its way matters, so divide by its largest component, exactly (JSON
    # integers are unbounded, and 1e308 or 1e-320 components still give a unit vector)
    exact = [Fraction(c) for c in value]
    big = max(abs(c) for c in exact)
    if big == 0:
        raise AnnotationError(f"{path}: {where}: 'direction' is the zero vector", "give a non-zero direction or leave it out")
    return [float(c / big) for c in exact]


def parse_annotations(doc: object, path: str | os.PathLike = "annotations", scale_to_m: float = 1.0) -> Annotations:
    """Validate a decoded annotation document and return it as :class:`Annotations` in metres.

    Every field is checked for type, shape, range and finiteness before any work: at most
    :data:`MAX_ANNOTATIONS` annotations; labels non-empty, unique, at most
    :data:`~meshplan.validation.MAX_LABEL_CHARS` characters and free of control characters and
    lone surrogates (refused rather than removed, so that a label is never silently changed into
    another one, or into a duplicate); kinds from :data:`ANNOTATION_KINDS`; positions three finite
    numbers within :data:`MAX_COORDINATE_M`; directions three finite numbers, not all zero.

    Raises
    ------
    AnnotationError
        With the file, the annotation and the field that is wrong, in one line.
    """
    p = Path(path)
    if not isinstance(doc, dict) or "annotations" not in doc:
        raise AnnotationError(f"{p}: expected an object with an \"annotations\" list", 'write {"annotations": [...]}')
    items = doc["annotations"]
    if not isinstance(items, list):
        raise AnnotationError(f"{p}: \"annotations\" must be a list, got {describe(items)}", 'write {"annotations": [...]}')
    if len(items) > MAX_ANNOTATIONS:
        raise AnnotationError(
            f"{p}: {len(items):,} annotations, more than the {MAX_ANNOTATIONS:,} allowed", "split the file or remove annotations"
        )
    labels, kinds, positions, directions = [], [], [], []
    seen: set[str] = set()
    for i, item in enumerate(items):
        where = f"annotation {i + 1}"
        if not isinstance(item, dict):
            raise AnnotationError(f"{p}: {where} is not an object, got {describe(item)}", "each annotation is {\"label\", \"kind\", \"position\"}")
        for field in ("label", "kind", "position"):
            if field not in item:
                typo = difflib.get_close_matches(field, [k for k in item if isinstance(k, str) and k not in _FIELDS], n=1)
                hint = f"did you mean {field!r} for {typo[0]!r}?" if typo else f"add {field!r} to every annotation"
                raise AnnotationError(f"{p}: {where} has no {field!r}", hint)
        label = item["label"]
        if not isinstance(label, str):
            raise AnnotationError(f"{p}: {where}: 'label' must be a non-empty string, got {describe(label)}", _FIX)
        problem = label_problem(label)
        if problem is not None:
            hint = f"shorten it to {MAX_LABEL_CHARS} characters" if len(label) > MAX_LABEL_CHARS else _FIX
            raise AnnotationError(f"{p}: {where}: {problem}", hint)
        where = f"annotation {i + 1} ({describe(label)})"
        if label in seen:
            raise AnnotationError(f"{p}: {where}: duplicate label", "give every annotation its own label")
        seen.add(label)
        kind = item["kind"]
        if not isinstance(kind, str) or kind not in ANNOTATION_KINDS:
            close = difflib.get_close_matches(kind, ANNOTATION_KINDS, n=1) if isinstance(kind, str) else []
            shown = json.dumps(kind[:40]) if isinstance(kind, str) else describe(kind)
            raise AnnotationError(
                f"{p}: {where}: unknown kind {shown}",
                f"use one of {', '.join(ANNOTATION_KINDS)}" + (f" (did you mean {close[0]!r}?)" if close else ""),
            )
        pos = _vector(item["position"], where, "position", p, scale_to_m)
        direction = [math.nan] * 3
        if item.get("direction") is not None:
            direction = _vector(item["direction"], where, "direction", p, None)
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
        size = p.stat().st_size
        if size > MAX_ANNOTATION_FILE_BYTES:
            raise AnnotationError(
                f"{p}: {size / 2**20:.0f} MB, larger than the {MAX_ANNOTATION_FILE_BYTES // 2**20} MB an annotation file may have",
                f"an annotation file holds at most {MAX_ANNOTATIONS:,} annotations; check the path given to --annotations",
            )
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise AnnotationError(f"{p}: cannot be read ({exc})", "save it as UTF-8 JSON") from None
    try:
        doc = json.loads(text, parse_constant=lambda c: float(c))
    except json.JSONDecodeError as exc:
        raise AnnotationError(
            f"{p}: not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})", "fix the JSON syntax"
        ) from None
    except RecursionError:  # json's decoder recurses once per nested list or object
        raise AnnotationError(f"{p}: JSON nested too deeply", "an annotation file nests three levels deep; fix the file") from None
    except ValueError:  # an integer of more than 4300 digits (Python refuses to parse it)
        raise AnnotationError(f"{p}: not valid JSON (a number of more than 4,300 digits)", "fix the number") from None
    return parse_annotations(doc, p, scale_to_m)


def annotations_document(annotations: Annotations, ndigits: int = 6) -> dict:
    """The JSON document for ``annotations`` (the inverse of :func:`parse_annotations`)."""
    return {"annotations": annotations.to_list(ndigits)}

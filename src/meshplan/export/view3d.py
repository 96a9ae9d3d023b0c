"""The report's 3D view: which faces it shows (:func:`view_meshes`) and the data its script
draws them from (:func:`page_data`, the page's ``meshplan-data`` JSON).

Large scans are shown as a deterministic subsample of whole faces (:func:`subsample_faces`,
fixed seed), so that the page stays responsive and the same result gives the same page.
Annotations are given in the plan frame (to draw) and in the scan file's coordinates (to export
unchanged, as the page's annotation editor does).
"""

from __future__ import annotations

import base64
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .._version import __version__
from ..geometry import ANNOTATION_KINDS, ANNOTATION_PROBE_M, Mesh, transform_directions, transform_points
from .glb import KIND_RGBA, MESH_RGBA, WALL_RGBA, submesh

if TYPE_CHECKING:  # pragma: no cover
    from ..result import Result

__all__ = ["KIND_PREFIX", "MAX_FACES", "PROBE_M", "SUBSAMPLE_SEED", "ViewMesh", "ViewMeshes", "page_data", "subsample_faces", "view_meshes"]

#: Most faces the 3D view shows. Measured in Chromium: plotly builds a 120k-face scene in about
#: 1 s and keeps rotating it smoothly, and the page stays under 7 MB (plotly's 3D bundle is
#: 1.75 MB of it); past this the scan is shown as a subsample of its faces.
MAX_FACES = 120_000

#: Seed of the face subsample (fixed, so that the page is the same for the same result).
SUBSAMPLE_SEED = 0

#: Length of the probe drawn from each annotation along its direction, metres.
PROBE_M = ANNOTATION_PROBE_M

#: Label prefix suggested for a new annotation of each kind.
KIND_PREFIX = {"sensor": "S", "thermostat": "T", "window": "W", "door": "D", "other": "O"}

_WALL_VIEW_RGB = WALL_RGBA[:3]


@dataclass(frozen=True, eq=False)
class ViewMesh:
    """One mesh layer of the 3D view.

    Attributes
    ----------
    name
        Legend entry.
    role
        ``"scan"`` (a story without its ceiling) or ``"walls"`` (its flat walls).
    story
        Story index.
    mesh
        The faces shown (plan frame); a subset of whole faces of the scan, never merged ones.
    faces_total
        Faces of the layer before the subsample.
    """

    name: str
    role: str
    story: int
    mesh: Mesh
    faces_total: int

    @property
    def faces_shown(self) -> int:
        return self.mesh.n_faces


@dataclass(frozen=True, eq=False)
class ViewMeshes:
    """The layers of the 3D view and how much of the scan they show."""

    layers: tuple[ViewMesh, ...]
    max_faces: int

    @property
    def faces_shown(self) -> int:
        return sum(layer.faces_shown for layer in self.layers)

    @property
    def faces_total(self) -> int:
        return sum(layer.faces_total for layer in self.layers)

    @property
    def fraction(self) -> float:
        """Fraction of the scan faces shown (1 when nothing was left out)."""
        scan = [layer for layer in self.layers if layer.role == "scan"]
        total = sum(layer.faces_total for layer in scan)
        return sum(layer.faces_shown for layer in scan) / total if total else 1.0

    @property
    def decimated(self) -> bool:
        return self.faces_shown < self.faces_total


def subsample_faces(areas: np.ndarray, m: int, seed: int = SUBSAMPLE_SEED) -> np.ndarray:
    """``m`` of the faces with these ``areas``, as sorted indices: a random choice with a fixed
    seed, each face weighted by its area.

    Random rather than strided: scans list faces surface by surface in grid order, so a stride
    leaves regular stripes (moiré) where a random choice leaves an even, fine-grained dither.
    Weighted by area (Efraimidis and Spirakis' exponential keys, vectorized) so that the faces
    kept cover more of the surface: on a 300k-face scan showing 48 % of the faces covers 59 %
    of the area instead of 48 %.
    """
    n = len(areas)
    if m >= n:
        return np.arange(n)
    if m <= 0:
        return np.zeros(0, dtype=np.int64)
    rng = np.random.default_rng(seed)
    with np.errstate(divide="ignore"):
        keys = -np.log(rng.random(n)) / np.asarray(areas, dtype=np.float64)
    return np.sort(np.argpartition(keys, m - 1)[:m])


def view_meshes(result: Result, max_faces: int = MAX_FACES) -> ViewMeshes:
    """The 3D view's layers: each story without its ceiling and its flat walls.

    When the stories hold more than ``max_faces`` faces in all (flat walls included), the same
    fraction of every story's faces is kept (:func:`subsample_faces`), so that the page stays
    responsive; the flat walls (two faces a wall) are always whole.
    """
    mesh = result.mesh
    scan_faces = [sp.model_faces for sp in result.stories]
    walls = [result.walls.mesh(sp.story.index) for sp in result.stories]
    n_scan = sum(len(f) for f in scan_faces)
    budget = max(max_faces - sum(w.n_faces for w in walls), 0)
    frac = 1.0 if n_scan <= budget else budget / n_scan
    layers = []
    for sp, faces, wall_mesh in zip(result.stories, scan_faces, walls):
        i = sp.story.index
        pick = faces[subsample_faces(mesh.face_areas[faces], int(math.floor(frac * len(faces))), SUBSAMPLE_SEED + i)]
        layers.append(ViewMesh(f"story {i}: scan", "scan", i, submesh(mesh, pick), len(faces)))
        layers.append(ViewMesh(f"story {i}: flat walls", "walls", i, wall_mesh, wall_mesh.n_faces))
    return ViewMeshes(tuple(layers), max_faces)


# --------------------------------------------------------------------------------------------
# The page's data


def _b64(a: np.ndarray, dtype: str) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype=dtype).tobytes()).decode("ascii")


def _hex(rgba) -> str:
    return "#{:02x}{:02x}{:02x}".format(*rgba[:3])


def _finite_or_none(a: np.ndarray, nd: int = 9) -> list[float] | None:
    a = np.asarray(a, dtype=np.float64)
    if not np.all(np.isfinite(a)):
        return None
    return (np.round(a, nd) + 0.0).tolist()


def _layer_data(layer: ViewMesh, slack: float) -> dict[str, Any]:
    """A layer for the page: vertices as x, y and z blocks of float32 (plotly wants them apart)
    and faces as i, j and k blocks of uint32, each base64."""
    m = layer.mesh
    return {
        "name": layer.name,
        "role": layer.role,
        "story": layer.story,
        "color": _hex(MESH_RGBA if layer.role == "scan" else _WALL_VIEW_RGB),
        "visible": layer.role == "scan",
        "n_vertices": m.n_vertices,
        "n_faces": m.n_faces,
        "positions": _b64(m.vertices.T, "<f4"),
        "faces": _b64(m.faces.T, "<u4"),
        # How far (in barycentric units) a click may miss a shown face and still take its
        # plane: a subsample leaves gaps between the faces it keeps.
        "slack": slack if layer.role == "scan" else 0.0,
    }


def _annotation_data(result: Result) -> list[dict[str, Any]]:
    """The scan's annotations in the plan frame (to draw) and in the file's coordinates (to
    export unchanged)."""
    ann = result.annotations
    if not len(ann):
        return []
    inv = np.linalg.inv(result.transform)
    scale = float(result.input.scale_to_m)
    pos_in = transform_points(inv, ann.positions) / scale
    dir_in = transform_directions(inv, ann.directions)
    story = result.annotation_story
    return [
        {
            "label": label,
            "kind": kind,
            "story": int(story[i]) if i < len(story) else None,
            "position": _finite_or_none(ann.positions[i]),
            "direction": _finite_or_none(ann.directions[i]),
            "input_position": _finite_or_none(pos_in[i]),
            "input_direction": _finite_or_none(dir_in[i]),
        }
        for i, (label, kind) in enumerate(zip(ann.labels, ann.kinds))
    ]


def page_data(result: Result, view: ViewMeshes) -> dict[str, Any]:
    """What the page's script reads (the ``meshplan-data`` JSON): the layers, the annotations,
    the transform back to the file's coordinates and the stories."""
    slack = 0.0 if not view.decimated else min(1.0, 1.2 * (1.0 / math.sqrt(max(view.fraction, 1e-6)) - 1.0))
    return {
        "meshplan_version": __version__,
        "meshes": [_layer_data(layer, slack) for layer in view.layers],
        "faces_shown": view.faces_shown,
        "faces_total": view.faces_total,
        "annotations": _annotation_data(result),
        "kinds": list(ANNOTATION_KINDS),
        "kind_colors": {k: _hex(KIND_RGBA.get(k, KIND_RGBA["other"])) for k in ANNOTATION_KINDS},
        "kind_prefix": KIND_PREFIX,
        "to_input": np.linalg.inv(result.transform).tolist(),
        "scale_to_m": float(result.input.scale_to_m),
        "units": result.input.units,
        "stories": [
            {
                "index": s.index,
                "floor": s.floor,
                "ceiling": s.ceiling,
                "bottom": s.bottom if math.isfinite(s.bottom) else None,
                "top": s.top if math.isfinite(s.top) else None,
            }
            for s in result.orientation.stories
        ],
        "probe_m": PROBE_M,
    }

"""The report's 3D view: which faces it shows (:func:`view_meshes`) and the data its script
draws them from (:func:`page_data`, the page's ``meshplan-data`` JSON).

Large scans are shown as a deterministic subsample of whole faces (:func:`subsample_faces`,
fixed seed), so that the page stays responsive and the same result gives the same page.
Annotations are given in the plan frame (to draw) and in the scan file's coordinates (to export
unchanged, as the page's annotation editor does).

The meshes are packed to keep the page small (:func:`_layer_data`): coordinates as uint16 across
each layer's box (:func:`quantize_positions`, under 0.1 mm off on a 10 m story) and as
differences from vertex to vertex (:func:`pack_positions`), faces as small back-references to
the vertices in first-use order (:func:`first_use_order`, :func:`encode_faces`), each block
deflated (zlib) and base64. The page's script inflates them with the browser's own
``DecompressionStream`` (nothing to load) and decodes them as :func:`unpack_positions`,
:func:`decode_positions` and :func:`decode_faces` do.
"""

from __future__ import annotations

import base64
import math
import zlib
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .._version import __version__
from ..geometry import ANNOTATION_KINDS, ANNOTATION_PROBE_M, Mesh, transform_directions, transform_points
from .glb import KIND_RGBA, MESH_RGBA, WALL_RGBA, submesh

if TYPE_CHECKING:  # pragma: no cover
    from ..result import Result

__all__ = [
    "KIND_PREFIX", "MAX_FACES", "POSITION_LEVELS", "PROBE_M", "SUBSAMPLE_SEED", "ViewMesh", "ViewMeshes", "ZLIB_LEVEL",
    "decode_faces", "decode_positions", "encode_faces", "first_use_order", "pack_positions", "page_data", "quantize_positions",
    "subsample_faces", "unpack_positions", "view_meshes",
]

#: Most faces the 3D view shows. Measured in Chromium: plotly builds a 120k-face scene in about
#: 1 s and keeps rotating it smoothly; past this the scan is shown as a subsample of its faces.
#: The meshes take about 1.2 MB of the page at this many faces (see :func:`_layer_data`; the
#: benchmark's 300k-face apartment makes a 3.7 MB page, plotly's 3D bundle is 1.75 MB of it).
MAX_FACES = 120_000

#: Steps of the uint16 grid a layer's vertex coordinates are rounded to, per axis, across the
#: layer's bounding box (65535 steps, 65536 levels: the most a uint16 holds). See
#: :func:`quantize_positions` for the error.
POSITION_LEVELS = 65535

#: zlib (deflate) level of the page's mesh blocks. Measured on the benchmark's 300k-face
#: apartment (120k faces shown, 129k vertices): levels 1, 4 and 6 take 22, 28 and 91 ms of
#: CPU and leave 1.00, 0.94 and 0.92 MB (base64); 9 takes 0.7 s for 0.92 MB. Level 4 is
#: nearly level 6's size at a third of its time (the report is made during the run).
ZLIB_LEVEL = 4

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


def _hex(rgba) -> str:
    return "#{:02x}{:02x}{:02x}".format(*rgba[:3])


def _finite_or_none(a: np.ndarray, nd: int = 9) -> list[float] | None:
    a = np.asarray(a, dtype=np.float64)
    if not np.all(np.isfinite(a)):
        return None
    return (np.round(a, nd) + 0.0).tolist()


def quantize_positions(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertex coordinates rounded to a uint16 grid across their bounding box.

    Parameters
    ----------
    vertices
        ``(n, 3)`` finite coordinates, metres (the plan frame).

    Returns
    -------
    q : numpy.ndarray
        ``(n, 3)`` uint16: ``vertices ~= origin + q * step``.
    origin : numpy.ndarray
        ``(3,)`` float64, the box's low corner (zeros when there is no vertex).
    step : numpy.ndarray
        ``(3,)`` float64, the box's extent over :data:`POSITION_LEVELS` per axis (0 on an axis
        where the box is flat: every coordinate is then the origin's, exactly).

    Notes
    -----
    The error of a coordinate decoded as the page does (:func:`decode_positions`) is at most
    half a step, ``extent / 131070``, plus the float32 rounding of the decoded value
    (``|x| * 2**-24``, 6 micrometres at 100 m from the plan's origin). A layer is one story
    (or its flat walls), so the extent is that story's: 0.076 mm on the benchmark apartment's
    9.9 m, 0.5 mm for a 65 m story, 1 mm would take a 131 m one. Shared vertices are rounded
    once, so faces that meet still meet (no cracks), and a click cast against the decoded
    faces lands within that error of the scanned surface.
    """
    # axis by axis (x, y and z each contiguous): numpy loops over an (n, 3) array's rows of 3
    # several times slower
    vt = np.ascontiguousarray(np.asarray(vertices, dtype=np.float64).reshape(-1, 3).T)
    if not vt.shape[1]:
        return np.zeros((0, 3), dtype=np.uint16), np.zeros(3), np.zeros(3)
    origin = vt.min(axis=1)
    step = (vt.max(axis=1) - origin) / POSITION_LEVELS
    scale = np.divide(1.0, step, out=np.zeros(3), where=step > 0)
    # (v - origin) * scale lies in [0, 65535] (a hair over at most): + 0.5, truncated, rounds
    # it to the nearest level
    qt = ((vt - origin[:, None]) * scale[:, None] + 0.5).astype(np.uint16)
    return qt.T, origin, step


def decode_positions(q: np.ndarray, origin: np.ndarray, step: np.ndarray) -> np.ndarray:
    """The coordinates the page decodes from :func:`quantize_positions`: ``origin + q * step``
    in double precision, stored as float32 (the page's ``Float32Array``), bit for bit."""
    return (np.asarray(origin, dtype=np.float64) + np.asarray(q, dtype=np.float64) * np.asarray(step, dtype=np.float64)).astype(np.float32)


def pack_positions(q: np.ndarray) -> np.ndarray:
    """Quantized coordinates (:func:`quantize_positions`) as the page's bytes: per axis (x, y,
    then z), the differences from the previous vertex modulo 65536 (the first from 0), their
    low bytes and then their high bytes.

    In first-use order (:func:`first_use_order`) a vertex is mostly near the one before it
    (the corners of one face, then of the next face of the same surface), so the differences
    are small: their high bytes mostly 0 or 255, which deflate packs, and their low bytes
    repeat more. Measured (deflated, base64) on the benchmark's apartments: 0.94 -> 0.70 MB for
    the 129k vertices shown of the 300k-face one, 2.23 -> 1.63 MB for the 312k of the
    3M-face one (whose subsample keeps 1 face in 20: few shared vertices).

    Returns
    -------
    numpy.ndarray
        ``6 n`` uint8; :func:`unpack_positions` undoes it.
    """
    d = np.mod(np.diff(np.asarray(q).reshape(-1, 3).T.astype(np.int64), axis=1, prepend=0), 65536)
    return np.stack([d & 0xFF, d >> 8], axis=1).astype(np.uint8).ravel()  # x low, x high, y low, ...


def unpack_positions(b: np.ndarray, n: int) -> np.ndarray:
    """The ``(n, 3)`` uint16 coordinates :func:`pack_positions` packed, as the page unpacks
    them (a running sum of the differences, modulo 65536)."""
    planes = np.asarray(b, dtype=np.int64).reshape(3, 2, n)
    d = planes[:, 0] | (planes[:, 1] << 8)
    return (np.cumsum(d, axis=1) % 65536).astype(np.uint16).T


def first_use_order(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """The vertices the faces use, in the order the faces first name them.

    Parameters
    ----------
    faces
        ``(m, 3)`` vertex indices.
    n_vertices
        Number of vertices they index.

    Returns
    -------
    order : numpy.ndarray
        The used vertices (old indices) in order of first use, reading the faces row by row;
        vertices of no face are left out.
    faces : numpy.ndarray
        ``(m, 3)`` int64, the faces renumbered: vertex ``order[n]`` becomes ``n``.
    """
    flat = np.asarray(faces, dtype=np.int64).ravel()
    first = np.full(n_vertices, len(flat), dtype=np.int64)
    np.minimum.at(first, flat, np.arange(len(flat)))
    is_first = np.zeros(len(flat), dtype=bool)
    is_first[first[first < len(flat)]] = True
    order = flat[is_first]  # linear time: the corners where a vertex first appears, in order
    renumber = np.zeros(n_vertices, dtype=np.int64)
    renumber[order] = np.arange(len(order))
    return order, renumber[flat].reshape(-1, 3)


def encode_faces(faces: np.ndarray) -> np.ndarray:
    """Faces numbered in first-use order (:func:`first_use_order`) as back-reference codes.

    Read row by row, a corner either names the next vertex not seen yet (code 0) or one seen
    before, ``code`` vertices back from it: ``code = next - index``. A scan lists its faces
    surface by surface, so the codes are 0 or small (at most 313 on the benchmark apartment,
    against indices up to 129k), which deflate packs into a third of what it makes of the
    indices themselves: 0.23 MB, base64, for its 120k faces shown, against 0.64 MB for the
    renumbered indices and 0.96 MB for the indices in their former order (uint32).

    Returns
    -------
    numpy.ndarray
        ``3 m`` codes, int64, in ``[0, n_vertices]``: :func:`decode_faces` undoes them.
    """
    flat = np.asarray(faces, dtype=np.int64).ravel()
    if not len(flat):
        return flat
    seen = np.maximum.accumulate(flat) + 1  # vertices seen once each corner is read
    nxt = np.concatenate([[0], seen[:-1]])
    return nxt - flat


def decode_faces(codes: np.ndarray) -> np.ndarray:
    """The ``(m, 3)`` faces :func:`encode_faces` coded, as the page decodes them.

    The page reads the codes in turn (``index = next - code``, ``next`` one on after a 0);
    here the same, vectorized: the next new vertex at a corner is the number of 0 codes before
    it.
    """
    c = np.asarray(codes, dtype=np.int64).ravel()
    nxt = np.concatenate([[0], np.cumsum(c == 0)[:-1]]) if len(c) else c
    return (nxt - c).reshape(-1, 3)


def _block(a: np.ndarray, dtype: str) -> str:
    """Little-endian ``dtype`` bytes of ``a``, deflated (zlib), base64: what the page inflates
    with the browser's ``DecompressionStream("deflate")``."""
    return base64.b64encode(zlib.compress(np.ascontiguousarray(a, dtype=dtype).tobytes(), ZLIB_LEVEL)).decode("ascii")


def _layer_data(layer: ViewMesh, slack: float) -> dict[str, Any]:
    """A layer for the page.

    The vertices are those of the faces, in first-use order (:func:`first_use_order`); their
    coordinates rounded to uint16 across the layer's box (:func:`quantize_positions`), with
    the box's ``position_origin`` and ``position_step`` per axis, and packed as differences
    from vertex to vertex, x, y and z apart (:func:`pack_positions`; plotly wants the axes
    apart too); the faces as back-reference codes read row by row (:func:`encode_faces`),
    uint16 when every code fits (always with fewer than 65536 vertices) and uint32 otherwise
    (``face_dtype``). Both blocks are deflated (zlib), then base64.

    On the benchmark's 300k-face apartment (120k faces and 129k vertices shown) the meshes
    take 0.93 MB of the page where float32 coordinates and uint32 indices in base64 took
    3.98 MB: uint16 coordinates take half (2.06 -> 1.03 MB), packed and deflated 0.70 MB, and
    deflate packs the face codes into 0.23 MB (1.92 MB as uint32 indices). The page's 3D view
    waits for the browser to inflate and decode them: about 0.1 s in Chromium there (0.03 s
    before), where plotly then takes 1 to 2 s to build the scene. Making them takes about
    50 ms here (4 ms before).
    """
    m = layer.mesh
    order, faces = first_use_order(m.faces, m.n_vertices)
    q, origin, step = quantize_positions(m.vertices[order])
    codes = encode_faces(faces)
    face_dtype = "uint16" if not len(codes) or int(codes.max()) <= np.iinfo(np.uint16).max else "uint32"
    return {
        "name": layer.name,
        "role": layer.role,
        "story": layer.story,
        "color": _hex(MESH_RGBA if layer.role == "scan" else _WALL_VIEW_RGB),
        "visible": layer.role == "scan",
        "n_vertices": len(order),
        "n_faces": m.n_faces,
        "positions": _block(pack_positions(q), "u1"),
        "position_origin": origin.tolist(),
        "position_step": step.tolist(),
        "faces": _block(codes, "<u2" if face_dtype == "uint16" else "<u4"),
        "face_dtype": face_dtype,
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

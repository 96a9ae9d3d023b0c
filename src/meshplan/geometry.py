"""Core geometric data: triangle meshes, annotations and rigid transforms.

Like trimesh, meshplan keeps plain numpy arrays at its core and derives per-face quantities
(normals, areas, centroids) lazily, once. Unlike trimesh, a :class:`Mesh` is immutable: every
stage returns a new mesh, so a stage can never change what another stage sees.

Conventions
-----------
* Coordinates are float64 metres. The *plan frame* has +y up (against gravity) and the dominant
  walls along x and z.
* Transforms are 4x4 homogeneous matrices acting on column vectors: ``p' = M @ [p, 1]``.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from functools import cached_property
from typing import TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import ParameterError

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
#: What a part of :func:`in_threads` gives.
T = TypeVar("T")

#: The kinds of annotated object meshplan knows about.
ANNOTATION_KINDS = ("sensor", "thermostat", "window", "door", "other")


def _frozen(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


@dataclass(frozen=True, eq=False)
class Mesh:
    """An immutable triangle mesh with lazily computed per-face quantities.

    Parameters
    ----------
    vertices
        ``(V, 3)`` vertex positions.
    faces
        ``(F, 3)`` vertex indices of each triangle, counter-clockwise seen from the side the
        normal points to.
    """

    vertices: FloatArray
    faces: IntArray

    def __post_init__(self) -> None:
        v = np.array(self.vertices, dtype=np.float64, copy=True).reshape(-1, 3)
        f = np.array(self.faces, dtype=np.int64, copy=True).reshape(-1, 3)
        if len(f) and (f.min() < 0 or f.max() >= len(v)):
            raise ValueError("face index out of range")
        object.__setattr__(self, "vertices", _frozen(v))
        object.__setattr__(self, "faces", _frozen(f))

    def _seed(self, **cached: np.ndarray) -> Mesh:
        """Store derived arrays computed elsewhere (``triangles``, ``_cross``) in the cache, so
        that they are not computed twice; returns ``self``."""
        for name, value in cached.items():
            self.__dict__[name] = _frozen(np.asarray(value, dtype=np.float64))
        return self

    def release_derived(self) -> None:
        """Forget the derived arrays computed so far (corners, cross products, normals, areas,
        centroids): they are computed again if asked for. For a caller done with a large mesh
        that it cannot drop (its own caller holds it)."""
        for name, attr in vars(Mesh).items():
            if isinstance(attr, cached_property):
                self.__dict__.pop(name, None)

    @property
    def n_faces(self) -> int:
        return int(len(self.faces))

    @property
    def n_vertices(self) -> int:
        return int(len(self.vertices))

    @cached_property
    def triangles(self) -> FloatArray:
        """``(F, 3, 3)`` corner positions of every face."""
        return _frozen(self.vertices[self.faces])

    @cached_property
    def _cross(self) -> FloatArray:
        t = self.triangles
        a = t[:, 1] - t[:, 0]
        b = t[:, 2] - t[:, 0]
        # written out: np.cross is several times slower on (F, 3) arrays
        c = np.empty_like(a)
        c[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
        c[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
        c[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
        return _frozen(c)

    @cached_property
    def face_areas(self) -> FloatArray:
        """``(F,)`` triangle areas."""
        return _frozen(0.5 * np.sqrt(np.einsum("ij,ij->i", self._cross, self._cross)))

    @cached_property
    def face_normals(self) -> FloatArray:
        """``(F, 3)`` unit normals (right-hand rule); zero for degenerate faces."""
        norm = 2.0 * self.face_areas
        with np.errstate(invalid="ignore", divide="ignore"):
            n = self._cross / norm[:, None]
        n[~(norm > 0)] = 0.0
        return _frozen(n)

    @cached_property
    def face_centroids(self) -> FloatArray:
        """``(F, 3)`` triangle centroids."""
        t = self.triangles
        return _frozen((t[:, 0] + t[:, 1] + t[:, 2]) / 3.0)

    @cached_property
    def face_roots(self) -> IntArray:
        """``(F,)`` the connected piece of every face (faces sharing a vertex are connected),
        named by the piece's lowest vertex (:func:`meshplan._kernels.face_components`). It
        depends on the faces' vertices only, so a transformed mesh (:meth:`transformed`) takes
        its source's: the orientation's facing test and the walls' box test share one pass
        (0.3 s at 3M faces)."""
        from ._kernels import face_components  # numba: loaded when first needed

        return _frozen(face_components(np.ascontiguousarray(self.faces, dtype=np.int64), self.n_vertices))

    @property
    def area(self) -> float:
        return float(self.face_areas.sum())

    def bounds(self) -> FloatArray:
        """``(2, 3)`` axis-aligned bounds of the referenced vertices."""
        if not len(self.faces):
            return np.zeros((2, 3))
        used = self.vertices[np.unique(self.faces)]
        return np.stack([used.min(axis=0), used.max(axis=0)])

    @classmethod
    def _adopt(cls, vertices: FloatArray, faces: IntArray) -> Mesh:
        """A mesh of arrays made for it (float64 and int64, valid indices, referred to by
        nothing else), taken as they are: the copies and the index check of the constructor
        cost 0.1-0.3 s at 3M faces, for arrays derived from a mesh that was checked."""
        out = object.__new__(cls)
        object.__setattr__(out, "vertices", _frozen(vertices))
        object.__setattr__(out, "faces", _frozen(faces))
        return out

    def transformed(self, matrix: ArrayLike, flip: ArrayLike | None = None, *, reuse: bool = False) -> Mesh:
        """The mesh with ``matrix`` (4x4, rigid or not) applied to its vertices, and the
        winding of the faces selected by ``flip`` (a boolean mask) reversed: the two steps of
        turning a scan into the plan frame, in one pass (``transformed(m).with_flipped(f)``
        makes each array twice, 1-2 s at 3M faces).

        Corners and cross products already computed are carried over (mapped, not computed
        again from the vertices: at 3M faces the gather and the products took 1-2 s): an affine
        map ``A`` sends a face's cross product ``c`` to ``det(A) A^-T c``, and where ``det(A) <
        0`` the winding is reversed to keep the normals pointing the same way, which negates it.

        With ``reuse``, this mesh gives its corners and cross products to the result and
        forgets them (as :meth:`release_derived`; they are computed again if asked for): the
        mapped ones are written over them, instead of into fresh arrays, where nothing else
        refers to them (:func:`_unshared`). For a caller done with this mesh's derived arrays:
        at 3M faces they are 0.29 GB, whose fresh pages cost a fresh process 0.2 s (the
        3M-face apartment end to end 9.6 s against 9.8 s, medians of 9 alternated runs).
        """
        m = np.asarray(matrix, dtype=np.float64)
        a3 = m[:3, :3]
        det = float(np.linalg.det(a3))
        mirror = det < 0  # keep normals pointing the same way
        sel = None if flip is None else np.asarray(flip, dtype=bool).reshape(-1)
        if sel is not None and not sel.any():
            sel = None
        faces = np.array(self.faces[:, ::-1] if mirror else self.faces, dtype=np.int64, order="C")
        if sel is not None:
            faces[sel] = faces[sel][:, ::-1]
        out = Mesh._adopt(np.ascontiguousarray(transform_points(m, self.vertices), dtype=np.float64), faces)
        cached = self.__dict__
        if "face_roots" in cached:  # the same vertices in every face (the winding aside): the same pieces
            out.__dict__["face_roots"] = cached["face_roots"]
        if "triangles" in cached and "_cross" in cached and det != 0:
            tri_in, cross_in = cached["triangles"], cached["_cross"]
            # written over only when they are this mesh's alone, and the corners keep their order
            own = reuse and not mirror and _unshared(tri_in) and _unshared(cross_in)
            if reuse:
                self.release_derived()
            owners = (tri_in, cross_in) if own else ()
            for a in owners:
                a.flags.writeable = True
            # as (3F, 3) and (F, 3) rows: one product each (a stack of 3x3 products is slower)
            corners = tri_in.reshape(-1, 3)
            tri = _affine_rows(corners, a3.T, m[:3, 3], corners if own else np.empty_like(corners)).reshape(-1, 3, 3)
            if mirror:
                tri = tri[:, ::-1].copy()
            # rows: (|det| A^-T c)^T
            cross = _affine_rows(cross_in, abs(det) * np.linalg.inv(a3), None, cross_in if own else np.empty_like(cross_in))
            del tri_in, cross_in, corners  # this mesh's, when not reused: freed here if it forgot them
            if sel is not None:  # arrays of the result's own: reversed and negated in place
                tri[sel] = tri[sel][:, ::-1]
                cross[sel] *= -1.0
            out._seed(triangles=tri, _cross=cross)
            for a in owners:
                a.flags.writeable = False
        return out

    def submesh(self, faces: ArrayLike) -> Mesh:
        """A compact mesh made of the selected faces (boolean mask or indices)."""
        sel = self.faces[np.asarray(faces)]
        used, inverse = np.unique(sel, return_inverse=True)
        return Mesh(self.vertices[used], inverse.reshape(-1, 3))

    def with_flipped(self, flip: ArrayLike) -> Mesh:
        """The mesh with the winding (and so the normal) of the selected faces reversed (their
        corners and cross products, when computed, carried over: reversed and negated):
        :meth:`transformed` by the identity."""
        return self.transformed(np.eye(4), flip)

    @staticmethod
    def concatenate(meshes: list[Mesh]) -> Mesh:
        """One mesh made of several."""
        if not meshes:
            return Mesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64))
        offsets = np.cumsum([0] + [m.n_vertices for m in meshes[:-1]])
        return Mesh(
            np.concatenate([m.vertices for m in meshes]),
            np.concatenate([m.faces + o for m, o in zip(meshes, offsets)]),
        )


#: The input axes a user can name as up (``--up``), as unit vectors.
AXIS_VECTORS = {
    "+x": (1.0, 0.0, 0.0),
    "-x": (-1.0, 0.0, 0.0),
    "+y": (0.0, 1.0, 0.0),
    "-y": (0.0, -1.0, 0.0),
    "+z": (0.0, 0.0, 1.0),
    "-z": (0.0, 0.0, -1.0),
}

#: The 8 corners of the cube of side 1 centred on the origin, indexed by their (x, y, z) bits,
#: and its 12 triangles wound outward: the box of parametric models (RoomPlan, synthetic).
BOX_CORNERS = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
BOX_FACES = np.array(
    [
        [0, 1, 3], [0, 3, 2],  # -x
        [4, 6, 7], [4, 7, 5],  # +x
        [0, 4, 5], [0, 5, 1],  # -y
        [2, 3, 7], [2, 7, 6],  # +y
        [0, 2, 6], [0, 6, 4],  # -z
        [1, 5, 7], [1, 7, 3],  # +z
    ],
    dtype=np.int64,
)

#: Length (m) of the probe drawn from an annotated object along its direction, in every plan,
#: model and CAD file: long enough to read the direction at 1:50-1:100 (4-8 mm on paper), short
#: enough not to cross a 1 m wide corridor.
ANNOTATION_PROBE_M = 0.4


@dataclass(frozen=True, eq=False)
class Annotations:
    """Objects placed by the user in the scan: sensors, thermostats, doors, windows.

    Parameters
    ----------
    labels, kinds
        One entry per object; ``kinds`` are from :data:`ANNOTATION_KINDS`.
    positions
        ``(N, 3)`` positions.
    directions
        ``(N, 3)`` unit "probe" directions, NaN where the object has none.
    """

    labels: tuple[str, ...] = ()
    kinds: tuple[str, ...] = ()
    positions: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    directions: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))

    def __post_init__(self) -> None:
        p = np.array(self.positions, dtype=np.float64, copy=True).reshape(-1, 3)
        d = np.array(self.directions, dtype=np.float64, copy=True).reshape(-1, 3)
        n = len(self.labels)
        if not (len(self.kinds) == len(p) == len(d) == n):
            raise ValueError("annotation arrays differ in length")
        bad = [k for k in self.kinds if k not in ANNOTATION_KINDS]
        if bad:
            raise ValueError(f"unknown annotation kind {bad[0]!r}")
        with np.errstate(invalid="ignore", divide="ignore"):
            d = d / np.linalg.norm(d, axis=1, keepdims=True)
        object.__setattr__(self, "labels", tuple(self.labels))
        object.__setattr__(self, "kinds", tuple(self.kinds))
        object.__setattr__(self, "positions", _frozen(p))
        object.__setattr__(self, "directions", _frozen(d))

    def __len__(self) -> int:
        return len(self.labels)

    def transformed(self, matrix: ArrayLike) -> Annotations:
        """The annotations with a rigid ``matrix`` applied (positions moved, directions turned)."""
        m = np.asarray(matrix, dtype=np.float64)
        return Annotations(
            self.labels,
            self.kinds,
            transform_points(m, self.positions),
            transform_directions(m, self.directions),
        )

    def to_list(self, ndigits: int = 6) -> list[dict]:
        """JSON-ready list: ``label``, ``kind``, ``position`` and, where given, ``direction``."""
        out = []
        for i, (label, kind) in enumerate(zip(self.labels, self.kinds)):
            item = {"label": label, "kind": kind, "position": _round_list(self.positions[i], ndigits)}
            if np.all(np.isfinite(self.directions[i])):
                item["direction"] = _round_list(self.directions[i], ndigits)
            out.append(item)
        return out


def _round_list(a: ArrayLike, ndigits: int) -> list:
    return np.round(np.asarray(a, dtype=np.float64), ndigits).tolist()


# --------------------------------------------------------------------------------------------
# Rigid transforms


def max3(a: FloatArray) -> FloatArray:
    """``a.max(axis=1)`` of an ``(n, 3)`` array (a triangle's three corners' heights, say), the
    same numbers: numpy's reduction over a short last axis is several times slower."""
    return np.maximum(np.maximum(a[:, 0], a[:, 1]), a[:, 2])


def min3(a: FloatArray) -> FloatArray:
    """``a.min(axis=1)`` of an ``(n, 3)`` array, the same numbers (see :func:`max3`)."""
    return np.minimum(np.minimum(a[:, 0], a[:, 1]), a[:, 2])


def homogeneous(rotation: ArrayLike | None = None, translation: ArrayLike | None = None) -> FloatArray:
    """A 4x4 matrix from a 3x3 rotation and a translation."""
    m = np.eye(4)
    if rotation is not None:
        m[:3, :3] = rotation
    if translation is not None:
        m[:3, 3] = translation
    return m


#: BLAS threads for meshplan's products. They are thin (``(F, 3)`` points, normals or triangles
#: by ``(3,)`` or ``(3, 3)``): a second thread has no work worth sharing and only waits for the
#: first. Single-threaded, OpenBLAS computes the same bits in about half the median time on this
#: project's 2-core machine, and when the other core is busy (the drawing workers beside the
#: run, another job) a product no longer stalls for up to 0.25 s while one thread waits for the
#: other (the openings stage of a 300k-face scan: 0.68 s with two threads, 0.30 s with one).
BLAS_THREADS = 1

#: Rows from which :func:`thin_product` sets :data:`BLAS_THREADS`: below, OpenBLAS uses one
#: thread anyway, and the limit's own cost (0.3 ms) would be most of the product's.
_THIN_PRODUCT_MIN_ROWS = 10_000


#: Threads a stage searches its independent parts in at once (:func:`search_threads`): a
#: story's wall directions (:func:`meshplan.walls.find_flat_walls`), the walls' openings
#: (:func:`meshplan.plan.find_openings`), the openings' elements
#: (:func:`meshplan.plan.elements.opening_elements`), runs of a large story's faces
#: (:func:`meshplan.slicing.slice_mesh`). Each part is compiled code or numpy's work on arrays
#: of thousands of faces and more, much of it without the interpreter's lock, and the parts'
#: results are taken in their order: the same result as one thread's. On this project's 2-core
#: machine (one BLAS thread, as in a run) the 3M-face apartment's openings were searched in
#: 1.03-1.12 s by two threads against 1.53-1.58 s by one, the 300k-face apartment's in
#: 0.19-0.21 s against 0.24-0.25 s; a large scan's drawing worker is idle meanwhile.
SEARCH_THREADS = 2


def search_threads(parts: int) -> int:
    """How many threads search ``parts`` independent parts: :data:`SEARCH_THREADS`, no more
    than the parts or the cores, at least one."""
    return max(1, min(SEARCH_THREADS, parts, os.cpu_count() or 1))


def in_threads(search: Callable[[int], T], parts: int) -> list[T]:
    """``[search(0), ..., search(parts - 1)]``, the parts searched in :func:`search_threads`
    threads (in the caller's thread when that is one)."""
    threads = search_threads(parts)
    if threads == 1:
        return [search(i) for i in range(parts)]
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(threads) as pool:
        return list(pool.map(search, range(parts)))


def few_blas_threads() -> AbstractContextManager[object]:
    """A context in which BLAS runs :data:`BLAS_THREADS` threads (threadpoolctl), for a stage
    made of thin products."""
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=BLAS_THREADS, user_api="blas")


def thin_product(a: FloatArray, b: FloatArray) -> FloatArray:
    """``a @ b`` for a tall ``a`` of 3 columns (points, normals) and a small ``b`` (3 x 3), with
    :data:`BLAS_THREADS` threads (see there)."""
    if len(a) < _THIN_PRODUCT_MIN_ROWS:
        return a @ b
    with few_blas_threads():
        return a @ b


#: Rows taken at a time by the passes over per-face arrays done a block at a time
#: (:func:`_affine_rows`): a block's temporaries (1.5 MB for three float64 columns) come from
#: the heap's reused memory instead of fresh pages of the whole array's size.
BLOCK_ROWS = 1 << 16


def _affine_rows(rows: FloatArray, linear: np.ndarray, shift: np.ndarray | None, out: FloatArray) -> FloatArray:
    """``rows @ linear + shift`` into ``out`` (which may be ``rows`` itself), a block of rows at
    a time (each row's product is the same as in one product of the whole array)."""
    for i in range(0, len(rows), BLOCK_ROWS):
        block = rows[i : i + BLOCK_ROWS] @ linear
        if shift is not None:
            block += shift
        out[i : i + BLOCK_ROWS] = block
    return out


def _unshared(a: np.ndarray) -> bool:
    """Whether ``a`` holds its own memory and nothing refers to it but its holder and the
    caller's name for it: no view of it exists anywhere (a view refers to the array owning
    its memory). CPython's reference count, as numpy's own reuse of temporaries reads it,
    against that of an array held the same way (:func:`_held_refs`)."""
    return a.base is None and sys.getrefcount(a) <= _HELD_REFS


def _count_refs(a: np.ndarray) -> int:
    """``a``'s reference count, read as :func:`_unshared` reads it (one call down)."""
    return sys.getrefcount(a)


def _held_refs() -> int:
    """The reference count :func:`_unshared` reads for an array held by one cache entry and
    one variable of its caller, nothing else: measured, since what the interpreter counts for
    an argument differs between Python versions."""
    cache = {"array": np.empty(0)}
    array = cache["array"]
    return _count_refs(array)


#: What :func:`_unshared` reads for an array nothing else refers to.
_HELD_REFS = _held_refs()


def transform_points(matrix: ArrayLike, points: ArrayLike) -> FloatArray:
    m = np.asarray(matrix, dtype=np.float64)
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    return thin_product(p, m[:3, :3].T) + m[:3, 3]


def transform_directions(matrix: ArrayLike, directions: ArrayLike) -> FloatArray:
    m = np.asarray(matrix, dtype=np.float64)
    return thin_product(np.asarray(directions, dtype=np.float64).reshape(-1, 3), m[:3, :3].T)


def rotation_between(a: ArrayLike, b: ArrayLike) -> FloatArray:
    """The smallest rotation (3x3) turning unit vector ``a`` onto unit vector ``b``."""
    a = np.asarray(a, dtype=np.float64) / np.linalg.norm(a)
    b = np.asarray(b, dtype=np.float64) / np.linalg.norm(b)
    axis = np.cross(a, b)
    s, c = np.linalg.norm(axis), float(np.dot(a, b))
    if s < 1e-12:
        if c > 0:
            return np.eye(3)
        # half turn about any axis perpendicular to a
        perp = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        return rotation_about_axis(perp, np.pi)
    return rotation_about_axis(axis, np.arctan2(s, c))


def rotation_about_axis(axis: ArrayLike, angle: float) -> FloatArray:
    """Rodrigues' rotation matrix for ``angle`` radians about ``axis`` (right-hand rule)."""
    k = np.asarray(axis, dtype=np.float64)
    k = k / np.linalg.norm(k)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * kx + (1 - np.cos(angle)) * (kx @ kx)


def rotation_about_y(angle: float) -> FloatArray:
    """Rotation (3x3) by ``angle`` radians about +y; turns +x towards -z."""
    return rotation_about_axis([0.0, 1.0, 0.0], angle)


def is_rigid(matrix: ArrayLike, tol: float = 1e-6) -> bool:
    """True when ``matrix`` is a proper rigid transform (rotation with det +1, translation)."""
    m = np.asarray(matrix, dtype=np.float64)
    if m.shape != (4, 4) or not np.all(np.isfinite(m)):
        return False
    r = m[:3, :3]
    return (
        np.allclose(r @ r.T, np.eye(3), atol=tol)
        and abs(np.linalg.det(r) - 1) < tol
        and np.allclose(m[3], [0, 0, 0, 1], atol=tol)
    )


def azimuth_deg(nx: ArrayLike, nz: ArrayLike) -> FloatArray:
    """Angle of the plan direction ``(nx, nz)`` from +x towards +z, in [0, 360) degrees."""
    return np.degrees(np.arctan2(nz, nx)) % 360.0


def unit(v: ArrayLike, axis: int = -1) -> FloatArray:
    v = np.asarray(v, dtype=np.float64)
    n = np.linalg.norm(v, axis=axis, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, v / n, 0.0)


def check_positive(name: str, value: float, allow_zero: bool = False) -> None:
    """Raise :class:`ParameterError` unless ``value`` is a finite positive number."""
    ok = np.isfinite(value) and (value >= 0 if allow_zero else value > 0)
    if not ok:
        raise ParameterError(
            f"{name} must be {'non-negative' if allow_zero else 'positive'}, got {value!r}",
            f"pass a {'non-negative' if allow_zero else 'positive'} number",
        )

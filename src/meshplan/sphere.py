"""Directions on the unit sphere: spherical coordinates, peak finding and trimmed spherical k-means.

These are the clustering tools of the paper's "Mesh orientation" section, shared by the gravity
estimate (k = 1), the wall alignment (k = 4 or 6) and the wall-direction search of the drafting plan.
All functions are vectorized over the directions; nothing loops over triangles in Python.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from .geometry import FloatArray, IntArray, unit

if TYPE_CHECKING:  # pragma: no cover
    from scipy.sparse import csr_matrix
    from scipy.spatial import cKDTree


def to_spherical(directions: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Spherical coordinates of unit vectors with +y as the pole, as in the paper's heat map.

    Returns
    -------
    theta
        Angle around the y axis, from +x towards +z, in [0, 360) degrees.
    phi
        Angle from the south pole (-y) to the north pole (+y), in [0, 180] degrees.
    """
    d = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    theta = np.degrees(np.arctan2(d[:, 2], d[:, 0])) % 360.0
    phi = np.degrees(np.arccos(np.clip(-d[:, 1], -1.0, 1.0)))
    return theta, phi


@dataclass(frozen=True)
class KMeansResult:
    """Outcome of :func:`trimmed_spherical_kmeans`.

    Attributes
    ----------
    centers
        ``(k, 3)`` unit cluster centres.
    labels
        ``(N,)`` cluster of each input direction, -1 for the outliers discarded by the trimming.
    weights
        ``(k,)`` total weight (area) of the directions kept in each cluster.
    iterations
        Total number of assignment/update rounds.
    """

    centers: FloatArray
    labels: IntArray
    weights: FloatArray
    iterations: int


def _kmeans_rounds(
    x: FloatArray, w: FloatArray, centers: FloatArray, idx: IntArray, max_iter: int, tol_rad: float
) -> tuple[FloatArray, IntArray, FloatArray, FloatArray, int]:
    """Lloyd rounds over ``x[idx]`` until no centre moves by more than ``tol_rad``.

    Labels of directions on a cluster boundary may flip back and forth forever, so centre
    movement, not label change, is the stopping rule. Returns the centres, and the labels,
    similarities and cluster weights of the last assignment.
    """
    from ._kernels import kmeans_round

    cos_tol = np.cos(tol_rad)
    it = 0
    for it in range(1, max_iter + 1):  # noqa: B007 (the count of rounds is returned)
        labels, sim, sums, cw = kmeans_round(x, w, centers, idx)
        norms = np.linalg.norm(sums, axis=1)
        moved = norms > 0
        new = centers.copy()
        new[moved] = sums[moved] / norms[moved, None]
        settled = bool(np.all(np.einsum("ij,ij->i", new, centers) >= cos_tol))
        centers = new
        if settled:
            break
    labels, sim, _, cw = kmeans_round(x, w, centers, idx)
    return centers, labels, sim, cw, it


def trimmed_spherical_kmeans(
    directions: ArrayLike,
    weights: ArrayLike | None,
    initial_centers: ArrayLike,
    schedule_deg: tuple[float, ...],
    max_iter: int = 100,
    tol_deg: float = 1e-3,
) -> KMeansResult:
    """Spherical k-means that discards outliers with a shrinking angle, as in the paper.

    After an ordinary spherical k-means run, every direction more than ``schedule_deg[0]`` from
    its cluster centre is discarded and the clustering is run again on the rest; then with
    ``schedule_deg[1]``, and so on. Discarded directions stay discarded. Centres are the
    normalized weighted sums of their members (the spherical mean).

    Parameters
    ----------
    directions
        ``(N, 3)`` unit vectors.
    weights
        ``(N,)`` non-negative weights (triangle areas); ``None`` for equal weights.
    initial_centers
        ``(k, 3)`` starting centres. Giving them makes the result deterministic.
    schedule_deg
        Decreasing outlier angles in degrees; empty for plain spherical k-means. The paper's
        is :data:`meshplan.orient.params.PAPER_TRIM_SCHEDULE_DEG` (the orientation's
        parameters hold it: this module knows no stage).
    max_iter
        Maximum rounds of assignment and update per stage.
    tol_deg
        A stage ends when no centre moves by more than this angle in a round.
    """
    x = np.ascontiguousarray(directions, dtype=np.float64).reshape(-1, 3)
    w = np.ones(len(x)) if weights is None else np.ascontiguousarray(weights, dtype=np.float64)
    centers = unit(np.asarray(initial_centers, dtype=np.float64).reshape(-1, 3))
    tol = np.radians(tol_deg)
    keep = np.arange(len(x), dtype=np.int64)
    centers, lab, sim, cw, total = _kmeans_rounds(x, w, centers, keep, max_iter, tol)
    for angle in schedule_deg:
        inside = sim >= np.cos(np.radians(angle))
        keep = keep[inside]
        if not len(keep):
            lab, cw = lab[:0], np.zeros(len(centers))
            break
        centers, lab, sim, cw, it = _kmeans_rounds(x, w, centers, keep, max_iter, tol)
        total += it
    labels = np.full(len(x), -1, dtype=np.int64)
    labels[keep] = lab
    return KMeansResult(centers=centers, labels=labels, weights=cw, iterations=total)


def fibonacci_sphere(n: int) -> FloatArray:
    """``n`` nearly uniformly spread unit vectors (deterministic)."""
    i = np.arange(n) + 0.5
    polar = np.arccos(1.0 - 2.0 * i / n)
    azim = np.pi * (1.0 + 5**0.5) * i
    return np.c_[np.cos(azim) * np.sin(polar), np.cos(polar), np.sin(azim) * np.sin(polar)]


_HEMI_CACHE: dict[tuple[int, float], tuple[FloatArray, cKDTree, csr_matrix]] = {}


def _hemisphere_bins(n: int, radius_deg: float) -> tuple[FloatArray, cKDTree, csr_matrix]:
    """Bin centres on the upper (+y) hemisphere, a tree over them and their antipodes, and the
    sparse matrix summing each bin's axial neighbours within ``radius_deg``."""
    key = (n, radius_deg)
    if key not in _HEMI_CACHE:
        # scipy loaded here, not at import: the parameter classes (and ``--help``) need only
        # this module's constants
        from scipy.sparse import csr_matrix
        from scipy.spatial import cKDTree

        b = fibonacci_sphere(2 * n)
        b = b[b[:, 1] >= 0]
        tree = cKDTree(np.r_[b, -b])
        # |b . b'| >= cos(r): b' or -b' within the chord 2 sin(r / 2) of b
        pairs = tree.query_ball_point(b, 2.0 * np.sin(np.radians(radius_deg) / 2.0), return_sorted=True)
        rows = np.repeat(np.arange(len(b)), [len(p) for p in pairs])
        cols = np.concatenate(pairs).astype(np.int64) % len(b)
        near = csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(b), len(b)))
        near.data[:] = 1.0  # a bin and its antipode's twin counted once
        _HEMI_CACHE[key] = (b, tree, near)
    return _HEMI_CACHE[key]


#: Rounds of :func:`_cap_mode` at most. Over the peaks of the 18 real scans and three synthetic
#: presets, 75 of 121 caps stopped moving by :data:`CAP_MODE_SETTLED_DEG` within 2-7 rounds; the
#: others creep along a broad mode (a noisy scan's walls), where the up search refines the axis
#: it takes anyway (:func:`meshplan.orient.gravity._refine_kmeans`).
CAP_MODE_ROUNDS = 8
#: The cap's mean has settled when a round moves it less than this (degrees).
CAP_MODE_SETTLED_DEG = 0.01


def _bin_spacing_rad(bins: int) -> float:
    """Typical angle (radians) between neighbouring centres of ``2 * bins`` Fibonacci points on
    the sphere: the side of a square of the sphere's area shared among them."""
    return float(np.sqrt(4.0 * np.pi / (2 * bins)))


def _cap_mode(d: FloatArray, w: FloatArray, start: FloatArray, cos_r: float, cos_first: float | None = None) -> FloatArray:
    """The weighted mean axis of the sign-aligned directions ``d`` in the cap of angular radius
    ``arccos(cos_r)`` around it (a mean shift from ``start``; the first cap ``arccos(cos_first)``
    when given).

    A bin's weight counts the directions binned within the cap's radius of it, which lie up to
    half a bin further than that from its centre; of several bins that hold the same
    directions (a parametric model's floor, every normal exactly up) the first in order wins,
    up to that far off the axis. The mean of the cap around its centre alone then missed them
    and the bin's centre was kept: on a RoomPlan room turned at random, the floor's candidate
    stayed 7.9 degrees off its normal in 6 turns of 20 (and lost to a wall pair); on six exact
    directions, a peak stayed 8-10 degrees off in 133 turns of 200. The first mean takes every
    direction the bin counted, and re-centring the cap on its mean until it stays puts it on
    the mode, whatever the turn."""
    widest = cos_r if cos_first is None else min(cos_r, cos_first)
    # the rounds look at the directions near the cap only: those within twice its reach of
    # where the subset was taken, taken again when the cap has moved further than its reach
    reach = float(np.arccos(np.clip(widest, -1.0, 1.0)))
    cos_subset = np.cos(min(2.0 * reach, np.pi / 2))
    axis = centre = start
    dots = d @ start
    near = np.abs(dots) >= cos_subset
    dn, wn = d[near], w[near]
    for round_ in range(CAP_MODE_ROUNDS):
        if axis @ centre < np.cos(reach):
            centre = axis
            near = np.abs(d @ centre) >= cos_subset
            dn, wn = d[near], w[near]
        dots = dn @ axis
        cap = np.abs(dots) >= (cos_first if round_ == 0 and cos_first is not None else cos_r)
        if not cap.any():
            return axis
        s = np.sign(dots[cap])[:, None]
        new = unit((dn[cap] * s * wn[cap, None]).sum(axis=0))
        if new @ axis >= np.cos(np.radians(CAP_MODE_SETTLED_DEG)):
            return new
        axis = new
    return axis


@dataclass(frozen=True)
class AxialPeak:
    """A dominant axis (sign ignored) among a set of directions."""

    axis: FloatArray
    weight: float  # weight within ``radius_deg`` of the axis


def axial_peaks(
    directions: ArrayLike,
    weights: ArrayLike,
    *,
    count: int = 6,
    radius_deg: float = 8.0,
    separation_deg: float = 25.0,
    bins: int = 2000,
    max_samples: int = 60_000,
) -> list[AxialPeak]:
    """The dominant axes of a set of directions, treating ``d`` and ``-d`` as the same axis.

    Directions are binned on a hemisphere, the weights summed over a cap of ``radius_deg``,
    and the heaviest caps at least ``separation_deg`` apart are returned, heaviest first, each
    refined to the weighted mean axis of its cap. Used to propose gravity candidates without
    trusting the sign of the normals. At most ``max_samples`` evenly strided directions are
    used, which changes the proposals (not the final estimates) by a negligible amount.
    """
    d = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    w = np.asarray(weights, dtype=np.float64).reshape(-1)
    if len(d) > max_samples:
        step = int(np.ceil(len(d) / max_samples))
        d, w = d[::step], w[::step]
    ok = (w > 0) & np.all(np.isfinite(d), axis=1)
    d, w = d[ok], w[ok]
    if not len(d):
        return []
    b, tree, near = _hemisphere_bins(bins, radius_deg)
    nb = len(b)
    _, idx = tree.query(d)
    hist = np.bincount(idx % nb, weights=w, minlength=nb)
    cos_r = np.cos(np.radians(radius_deg))
    # a bin's weight counts every direction binned within radius_deg of it, up to half a bin
    # further from its centre: the first mean of its cap takes them all (:func:`_cap_mode`)
    cos_first = np.cos(np.radians(radius_deg) + _bin_spacing_rad(bins))
    smooth = near @ hist
    order = np.argsort(-smooth, kind="stable")
    cos_sep = np.cos(np.radians(separation_deg))
    peaks: list[AxialPeak] = []
    for j in order:
        if smooth[j] <= 0:
            break
        cand = b[j]
        if any(abs(float(cand @ p.axis)) >= cos_sep for p in peaks):
            continue
        peaks.append(AxialPeak(axis=_cap_mode(d, w, cand, cos_r, cos_first), weight=float(smooth[j])))
        if len(peaks) >= count:
            break
    return peaks

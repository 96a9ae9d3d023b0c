"""Turning the dominant walls onto the axes (paper, "Rotate mesh and associated annotations").

On the levelled mesh, faces near-horizontal (floors, ceilings) and faces below the lowest floor
or above the highest ceiling are left out; the normals of the rest are clustered by the trimmed
spherical k-means with the outlier schedule 50, 40, 30, 20, 10, 5, 3 degrees. The largest cluster
is turned onto +x about the vertical axis.

Choices beyond the paper, all deterministic:

* The k-means starts from the four principal directions of the azimuth histogram (the circular
  mean of four times the azimuth), so it never depends on a random start.
* With ``wall_clusters=0`` the number of directions is found: after the four principal ones, any
  direction that still holds ``extra_direction_fraction`` of the wall area among the discarded
  normals is added and the clustering re-run (non-Manhattan buildings).
* The right-angle lattice is the one most of the wall area agrees with: each cluster proposes
  the lattice of its direction, and the clusters within :data:`LATTICE_DEG` of it vote with
  their area. The largest cluster of the winning lattice goes onto +x (the paper's largest
  cluster, unless that one is a wall bent off the others by the drift of the scanner), and the
  yaw is refined with every cluster of the lattice (weighted circular mean of four times their
  azimuths), which halves the noise of a single cluster. A cluster a few degrees off is a wall
  at its own angle (see :mod:`meshplan.walls.flat`): it neither turns the frame nor is
  principal.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import FloatArray, unit
from ..sphere import trimmed_spherical_kmeans
from .params import ALIGN_VERTICAL_DEG, NEW_DIRECTION_DEG, OrientParams

#: Clusters whose directions lie within this angle (degrees) of one right-angle lattice are
#: the square walls of one building, seen with noise: the centres of clusters of square walls
#: agree within a degree on headset and phone scans. A cluster farther off is a wall at its own
#: angle (3-8 degrees for the drift of a headset, more for a wall built at an angle), which
#: must not pull the frame off the square walls.
LATTICE_DEG = 2.0


@dataclass(frozen=True)
class WallDirection:
    """A wall direction found by the clustering, as a horizontal unit normal."""

    normal: FloatArray  # (3,) in the frame the clustering ran in (y up)
    weight: float  # area of the faces in the cluster (m2)
    principal: bool  # one of the four right-angle directions of the dominant walls


@dataclass(frozen=True)
class WallAlignment:
    """The yaw that turns the dominant walls onto the axes, and the wall directions."""

    yaw: float  # radians about +y; rotation_about_y(yaw) turns the largest cluster onto +x
    directions: tuple[WallDirection, ...]  # in the levelled frame, largest first
    centers: FloatArray  # (k, 3) raw cluster centres (including floor/ceiling with keep_horizontal)
    weights: FloatArray  # (k,)
    faces_used: int


def _azimuth(n: FloatArray) -> FloatArray:
    return np.arctan2(n[..., 2], n[..., 0])


def _manhattan_angle(normals: FloatArray, weights: FloatArray) -> float:
    """The azimuth (radians, in [0, pi/2)) of the dominant right-angle frame of the normals."""
    a = 4.0 * _azimuth(normals)
    s, c = (weights * np.sin(a)).sum(), (weights * np.cos(a)).sum()
    return float(np.arctan2(s, c) / 4.0) % (np.pi / 2)


def _azimuth_peak(normals: FloatArray, weights: FloatArray) -> tuple[float, float]:
    """The heaviest azimuth (radians) of the normals and its weight within +-5 degrees."""
    az = np.degrees(_azimuth(normals)) % 360.0
    hist = np.bincount(np.floor(az).astype(np.int64) % 360, weights=weights, minlength=360)
    smooth = np.roll(hist, -5)
    for k in range(-4, 6):
        smooth = smooth + np.roll(hist, k)
    j = int(np.argmax(smooth))
    return np.radians(j + 0.5), float(smooth[j])


def align_walls(normals: FloatArray, areas: FloatArray, heights: FloatArray, floor: float, ceiling: float, params: OrientParams) -> WallAlignment:
    """Cluster the wall normals of a levelled mesh and find the yaw onto the axes.

    Parameters
    ----------
    normals, areas, heights
        Face normals (levelled frame, +y up), areas and centroid heights.
    floor, ceiling
        Lowest floor and highest ceiling; faces outside are left out.
    """
    band = (heights >= floor) & (heights <= ceiling)
    if params.keep_horizontal:
        sel = band
    else:
        sel = band & (np.abs(normals[:, 1]) < np.cos(np.radians(params.wall_exclusion_deg)))
    n, w = normals[sel], areas[sel]
    if len(n) == 0:
        return WallAlignment(0.0, (), np.zeros((0, 3)), np.zeros(0), 0)
    vertical = np.abs(n[:, 1]) < np.sin(np.radians(ALIGN_VERTICAL_DEG))
    theta0 = _manhattan_angle(n[vertical], w[vertical]) if vertical.any() else 0.0
    angles = theta0 + np.arange(4) * np.pi / 2
    walls = np.c_[np.cos(angles), np.zeros(4), np.sin(angles)]
    if params.wall_clusters and params.wall_clusters != 4:
        k = params.wall_clusters
        angles = theta0 + np.arange(k) * 2 * np.pi / k
        walls = np.c_[np.cos(angles), np.zeros(k), np.sin(angles)]
    extra = np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]]) if params.keep_horizontal else np.zeros((0, 3))
    centers = np.r_[walls, extra]
    schedule = params.wall_trim_schedule_deg
    res = trimmed_spherical_kmeans(n, w, centers, schedule)
    if params.wall_clusters == 0:
        vertical_area = w[vertical].sum()
        far = np.cos(np.radians(NEW_DIRECTION_DEG))
        for _ in range(12):
            wall_centers = res.centers[: len(res.centers) - len(extra)]
            # wall normals far from every direction found so far
            left = vertical & (np.max(n @ wall_centers.T, axis=1) < far)
            if not left.any():
                break
            az, weight = _azimuth_peak(n[left], w[left])
            if weight < params.extra_direction_fraction * vertical_area:
                break
            cand = np.array([np.cos(az), 0.0, np.sin(az)])
            centers = np.r_[wall_centers, cand[None], res.centers[len(wall_centers):]]
            res = trimmed_spherical_kmeans(n, w, centers, schedule)
    n_walls = len(res.centers) - len(extra)
    wc, ww = res.centers[:n_walls], res.weights[:n_walls]
    horiz = unit(wc * np.array([1.0, 0.0, 1.0]))
    order = np.argsort(-ww, kind="stable")
    azimuths = _azimuth(horiz)
    # the lattice most of the wall area agrees with: each cluster's lattice, voted by area
    pair = (azimuths[None, :] - azimuths[:, None] + np.pi / 4) % (np.pi / 2) - np.pi / 4
    agree = (np.abs(pair) <= np.radians(LATTICE_DEG)) & (ww[None, :] > 0)
    votes = (agree * ww[None, :]).sum(axis=1)
    best = max(order, key=lambda i: (round(float(votes[i]), 9), float(ww[i])))  # ties: the larger cluster
    members = agree[best]
    largest = int(order[np.flatnonzero(members[order])[0]]) if members.any() else int(order[0])
    yaw = float(_azimuth(horiz[largest]))
    # refine with the clusters on the lattice
    off = (azimuths - yaw + np.pi / 4) % (np.pi / 2) - np.pi / 4
    lattice = (np.abs(off) <= np.radians(LATTICE_DEG)) & (ww > 0)
    if lattice.sum() >= 2:
        yaw = yaw + float(np.arctan2((ww[lattice] * np.sin(4 * off[lattice])).sum(), (ww[lattice] * np.cos(4 * off[lattice])).sum()) / 4)
    principal = lattice
    directions = tuple(
        WallDirection(horiz[i], float(ww[i]), bool(principal[i])) for i in order if ww[i] > 0
    )
    return WallAlignment(yaw, directions, res.centers, res.weights, int((res.labels >= 0).sum()))

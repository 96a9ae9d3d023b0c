"""Floor and ceiling heights from the area-weighted altitude histogram (paper, "Finding the height
of the floor" and "Dividing a mesh into separate levels").

The centroid heights of the near-horizontal faces are binned in 2-inch buckets, each face weighted
by its area. Adjacent bucket pairs are scored together so that a floor spread over two buckets is
not missed; local maxima of the pair scores are the *spikes*. A story is a floor spike and a
ceiling spike at least a room height apart; stories are chosen together (dynamic programming
over the spikes, maximizing the area of the floors and ceilings used) so that the gap between one
story's ceiling and the next story's floor (the slab) is respected. Spikes close to a story's main
floor (ceiling) are its sunken floors (raised ceilings): the highest floor and the lowest ceiling
are reported, as in the paper. Each height is refined to the weighted median of the face heights
around its spike, which is far finer than the bucket.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import numpy as np

from ..errors import GeometryError
from ..geometry import FloatArray
from .params import OrientParams


@dataclass(frozen=True)
class Spike:
    """A peak of the altitude histogram."""

    height: float  # refined height (weighted median of the faces around the peak)
    weight: float  # area (m2) of the bucket pair at the peak


@dataclass(frozen=True)
class StoryLevels:
    """Floor and ceiling of one story."""

    index: int
    floor: float
    ceiling: float
    ceiling_found: bool
    floors: tuple[float, ...]  # all floor spikes of the story (sunken floors)
    ceilings: tuple[float, ...]  # all ceiling spikes of the story (raised ceilings)


@dataclass(frozen=True)
class Levels:
    """Outcome of :func:`find_levels`: the histogram, its spikes and the stories."""

    edges: FloatArray
    weights: FloatArray
    spikes: tuple[Spike, ...]
    stories: tuple[StoryLevels, ...]
    warnings: tuple[str, ...]

    def shifted(self, dy: float) -> Levels:
        """The same levels with every height moved by ``dy``."""
        return Levels(
            edges=self.edges + dy,
            weights=self.weights,
            spikes=tuple(Spike(s.height + dy, s.weight) for s in self.spikes),
            stories=tuple(
                StoryLevels(
                    s.index,
                    s.floor + dy,
                    s.ceiling + dy,
                    s.ceiling_found,
                    tuple(f + dy for f in s.floors),
                    tuple(c + dy for c in s.ceilings),
                )
                for s in self.stories
            ),
            warnings=self.warnings,
        )


def altitude_histogram(heights: FloatArray, weights: FloatArray, bucket_m: float) -> tuple[FloatArray, FloatArray]:
    """Area-weighted histogram of heights with buckets of ``bucket_m``, aligned to a multiple
    of the bucket (so that shifting the input by whole buckets shifts the histogram)."""
    if not len(heights):
        return np.zeros(1), np.zeros(0)
    lo = np.floor(heights.min() / bucket_m) - 1
    hi = np.floor(heights.max() / bucket_m) + 2
    idx = (np.floor(heights / bucket_m) - lo).astype(np.int64)
    # with weights bincount returns float64 (the stubs say intp whatever the weights)
    hist = cast(FloatArray, np.bincount(idx, weights=weights, minlength=int(hi - lo)))
    edges = (lo + np.arange(len(hist) + 1)) * bucket_m
    return edges, hist


def _weighted_median(h: FloatArray, w: FloatArray, lo: float, resolution: float = 5e-4) -> float | None:
    """Weighted median of ``h`` (all >= ``lo``) to ``resolution``, by a fine histogram: no sort."""
    total = w.sum()
    if not len(h) or total <= 0:
        return None
    idx = ((h - lo) / resolution).astype(np.int64)
    cum = np.cumsum(np.bincount(idx, weights=w))
    k = int(np.searchsorted(cum, 0.5 * total))
    return float(lo + (k + 0.5) * resolution)


def find_spikes(heights: FloatArray, weights: FloatArray, bucket_m: float, fraction: float) -> list[Spike]:
    """Spikes of the paired-bucket histogram holding at least ``fraction`` of the largest."""
    edges, hist = altitude_histogram(heights, weights, bucket_m)
    if len(hist) < 2 or hist.sum() <= 0:
        return []
    pair = hist[:-1] + hist[1:]
    left = np.r_[-np.inf, pair[:-1]]
    right = np.r_[pair[1:], -np.inf]
    peaks = np.flatnonzero((pair >= left) & (pair > right) & (pair >= fraction * pair.max()) & (pair > 0))
    # one spike per 3 buckets: keep the larger of close maxima
    order = peaks[np.argsort(-pair[peaks], kind="stable")]
    chosen: list[int] = []
    for p in order:
        if all(abs(p - q) > 2 for q in chosen):
            chosen.append(int(p))
    spikes = []
    for p in chosen:
        centre = edges[p + 1]  # the boundary between the two buckets of the pair
        near = np.abs(heights - centre) < 2 * bucket_m
        h, w = heights[near], weights[near]
        for _ in range(3):  # re-centre the window on the weighted median
            inside = np.abs(h - centre) < bucket_m
            med = _weighted_median(h[inside], w[inside], centre - bucket_m)
            if med is None:
                break
            centre = med
        spikes.append(Spike(height=float(centre), weight=float(pair[p])))
    spikes.sort(key=lambda s: s.height)
    return spikes


def _choose_stories(spikes: list[Spike], lo: float, hi: float) -> list[tuple[int, int]]:
    """Disjoint (floor, ceiling) spike pairs, floor-to-ceiling in [lo, hi], in height order,
    maximizing the total weight of the spikes used."""
    m = len(spikes)
    h = np.array([s.height for s in spikes])
    w = np.array([s.weight for s in spikes])
    # best[j]: best total with every used spike at index < j; choice[j] remembers how
    best = np.zeros(m + 1)
    choice: list[tuple[int, int] | None] = [None] * (m + 1)
    for j in range(1, m + 1):
        best[j], choice[j] = best[j - 1], None
        c = j - 1  # spike c as the ceiling of the last story
        for f in range(c):
            gap = h[c] - h[f]
            if lo <= gap <= hi:
                total = best[f] + w[f] + w[c]
                if total > best[j] + 1e-12:
                    best[j], choice[j] = total, (f, c)
    pairs = []
    j = m
    while j > 0:
        step = choice[j]
        if step is None:
            j -= 1
        else:
            f, c = step
            pairs.append((f, c))
            j = f
    return pairs[::-1]


def find_levels(heights: FloatArray, normal_y: FloatArray, areas: FloatArray, params: OrientParams) -> Levels:
    """Floors, ceilings and stories of a levelled mesh.

    Parameters
    ----------
    heights
        ``(F,)`` centroid heights along up (metres).
    normal_y
        ``(F,)`` up component of the unit face normals (either sign).
    areas
        ``(F,)`` face areas.

    Raises
    ------
    GeometryError
        When the mesh has no horizontal surface to call a floor, or its story heights are
        implausible (wrong units).
    """
    horiz = np.abs(normal_y) >= np.cos(np.radians(params.horizontal_tolerance_deg))
    h, w = heights[horiz], areas[horiz]
    edges, hist = altitude_histogram(h, w, params.level_bucket_m)
    spikes = find_spikes(h, w, params.level_bucket_m, params.spike_fraction)
    if not spikes:
        raise GeometryError(
            "no floor found: the scan has no horizontal surface",
            "check that the scan includes the floor and that --up names the up axis",
        )
    pairs = _choose_stories(spikes, params.min_room_height_m, params.max_story_height_m)
    warnings: list[str] = []
    weights = np.array([s.weight for s in spikes])
    heights_s = np.array([s.height for s in spikes])
    if not pairs:
        top_gap = heights_s.max() - heights_s.min()
        if top_gap > params.max_story_height_m and len(spikes) >= 2:
            raise GeometryError(
                f"implausible story height: horizontal surfaces {top_gap:.1f} m apart with nothing in between",
                _units_hint(top_gap, params),
            )
        # no ceiling: the floor is the lowest spike holding at least half of the largest one
        f = int(np.flatnonzero(weights >= 0.5 * weights.max())[0])
        floor = spikes[f].height
        warnings.append(
            f"no ceiling found; assuming a ceiling {params.default_ceiling_height_m:.2f} m above the floor "
            f"(--default-ceiling-height)"
        )
        stories = [StoryLevels(0, floor, floor + params.default_ceiling_height_m, False, (floor,), ())]
        return Levels(edges, hist, tuple(spikes), tuple(stories), tuple(warnings))
    stories = []
    for i, (f, c) in enumerate(pairs):
        lower = stories[-1].ceiling if stories else -np.inf
        fl = [
            k
            for k in range(len(spikes))
            if abs(heights_s[k] - heights_s[f]) <= params.floor_group_m and weights[k] >= 0.5 * weights[f] and heights_s[k] > lower
        ]
        cl = [
            k
            for k in range(len(spikes))
            if abs(heights_s[k] - heights_s[c]) <= params.ceiling_group_m and weights[k] >= 0.5 * weights[c]
        ]
        floor = max(heights_s[k] for k in fl)
        ceiling = min(heights_s[k] for k in cl)
        if ceiling - floor < params.min_room_height_m:  # groups must not eat the room
            floor, ceiling = heights_s[f], heights_s[c]
        stories.append(
            StoryLevels(i, float(floor), float(ceiling), True, tuple(float(heights_s[k]) for k in fl), tuple(float(heights_s[k]) for k in cl))
        )
    # a large floor above the last ceiling without a ceiling of its own: an open top story
    last = stories[-1]
    above = [
        k
        for k in range(len(spikes))
        if heights_s[k] > last.ceiling + params.level_bucket_m and weights[k] >= 0.5 * weights.max()
    ]
    if above:
        floor = float(heights_s[above[0]])
        warnings.append(
            f"story {len(stories)} has no ceiling; assuming a ceiling {params.default_ceiling_height_m:.2f} m above its floor"
        )
        stories.append(StoryLevels(len(stories), floor, floor + params.default_ceiling_height_m, False, (floor,), ()))
    return Levels(edges, hist, tuple(spikes), tuple(stories), tuple(warnings))


def _units_hint(size_m: float, params: OrientParams) -> str:
    for unit, factor in (("mm", 0.001), ("cm", 0.01), ("in", 0.0254), ("ft", 0.3048)):
        if params.min_room_height_m <= size_m * factor <= params.max_story_height_m:
            return f"the scan seems to be in {unit}: pass --units {unit}"
    return "check the units of the scan (--units)"

"""Diagnostic figures of the orientation: the altitude histogram and the normals heat map."""

from __future__ import annotations

import numpy as np

from ..geometry import FloatArray
from ..orient import Orientation
from ..sphere import to_spherical
from .params import RenderParams

#: Room (inches) left of the histogram for the height axis, and right of the level labels.
_LEVELS_LEFT_IN = 0.75
_LEVELS_RIGHT_PAD_IN = 0.12
#: The peaks of the histogram, the candidate levels the floors and ceilings were chosen from.
PEAK_COLOR = "#d62728"


def levels_figure(orientation: Orientation, params: RenderParams):
    """The area-weighted histogram of near-horizontal face heights, with the floors and
    ceilings found (paper, Fig. "histogram-horizontal"): each floor and ceiling a dashed line
    labelled at the right of the plot (dotted where a ceiling was assumed), each peak of the
    histogram (a candidate level: :class:`meshplan.orient.levels.Spike`) a red marker at the tip
    of its bar, all in the legend. The plot is as wide as its labels leave room for."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.collections import PolyCollection
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    lv = orientation.levels
    unit, name = (0.3048, "ft") if params.imperial else (1.0, "m")
    fw, fh = 7.5, 4.5
    fig = Figure(figsize=(fw, fh), dpi=150)
    ax = fig.add_axes((_LEVELS_LEFT_IN / fw, 0.11, 0.8, 0.8))
    centres = 0.5 * (lv.edges[:-1] + lv.edges[1:])
    # the bars as one collection of rectangles: barh makes an artist of each (58 on the
    # benchmark apartment, 0.1 s of the figure's 0.2 s)
    y0, y1 = (centres - np.diff(lv.edges) / 2) / unit, (centres + np.diff(lv.edges) / 2) / unit
    w = np.asarray(lv.weights, dtype=np.float64)
    bars = np.stack([np.c_[np.zeros_like(w), y0], np.c_[w, y0], np.c_[w, y1], np.c_[np.zeros_like(w), y1]], axis=1)
    ax.add_collection(PolyCollection(list(bars), facecolors="#7f7f7f", linewidths=0))
    xmax = float(lv.weights.max()) if len(lv.weights) else 1.0
    labels = []
    to_right = ax.get_yaxis_transform()  # x in axes fractions, y in heights
    assumed = False
    for s in orientation.stories:
        ax.axhline(s.floor / unit, color="#2ca02c", lw=1.2, ls="--")
        floor = f"story {s.index} floor {s.floor / unit:.2f} {name}"
        labels.append(ax.text(1.01, s.floor / unit, floor, color="#2ca02c", fontsize=7, va="center", transform=to_right))
        style = "--" if s.ceiling_found else ":"
        assumed |= not s.ceiling_found
        ax.axhline(s.ceiling / unit, color="#1f77b4", lw=1.2, ls=style)
        label = f"story {s.index} ceiling {s.ceiling / unit:.2f} {name}" + ("" if s.ceiling_found else " (assumed)")
        labels.append(ax.text(1.01, s.ceiling / unit, label, color="#1f77b4", fontsize=7, va="center", transform=to_right))
    if len(lv.spikes) and len(lv.weights):
        # at the tip of the tallest bar within a bucket of the peak's (refined) height
        tips = []
        for sp in lv.spikes:
            near = np.abs(centres - sp.height) <= np.diff(lv.edges).max() * 1.01
            tips.append(float(lv.weights[near].max()) if near.any() else 0.0)
        ax.plot(tips, [sp.height / unit for sp in lv.spikes], linestyle="none", marker="<", color=PEAK_COLOR, ms=4, zorder=3)
    handles = [Line2D([], [], color="#2ca02c", lw=1.2, ls="--"), Line2D([], [], color="#1f77b4", lw=1.2, ls="--")]
    names = ["floor found", "ceiling found"]
    if assumed:
        handles.append(Line2D([], [], color="#1f77b4", lw=1.2, ls=":"))
        names.append("ceiling assumed (none found)")
    if len(lv.spikes):
        handles.append(Line2D([], [], color=PEAK_COLOR, marker="<", ms=4, ls="none"))
        names.append("histogram peak: a candidate level")
    # above the plot, right of the title: inside it would cover a level at the top
    ax.legend(handles, names, loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=2, fontsize=6, frameon=False, borderaxespad=0.2)
    ax.set_xlabel("area of near-horizontal faces per 2-inch bucket (m²)", fontsize=8)
    ax.set_ylabel(f"height ({name})", fontsize=8)
    ax.set_title("Altitude histogram: floors and ceilings", fontsize=9, loc="left")
    ax.tick_params(labelsize=7)
    ax.set_xlim(0, xmax * 1.05 if xmax > 0 else 1)
    # as wide as the labels at the right leave room for
    renderer = FigureCanvasAgg(fig).get_renderer()
    widest = max((t.get_window_extent(renderer).width for t in labels), default=0.0) / fig.dpi
    right = widest + 0.01 * 0.8 * fw + _LEVELS_RIGHT_PAD_IN
    ax.set_position((_LEVELS_LEFT_IN / fw, 0.11, 1.0 - (_LEVELS_LEFT_IN + right) / fw, 0.8))
    return fig


def normals_histogram(normals: FloatArray, areas: FloatArray) -> FloatArray:
    """``(180, 90)`` face area (m2) per 2-degree bucket of theta and phi
    (:func:`meshplan.sphere.to_spherical`): what :func:`normals_figure` draws. The run makes it
    and hands the drawing worker these 130 kB instead of every face's normal and area (96 MB
    at 3M faces)."""
    theta, phi = to_spherical(normals)
    # 2-degree buckets (bincount: histogram2d is several times slower)
    i = np.clip((theta / 2).astype(np.int64), 0, 179)
    j = np.clip((phi / 2).astype(np.int64), 0, 89)
    return np.asarray(np.bincount(i * 90 + j, weights=areas, minlength=180 * 90), dtype=np.float64).reshape(180, 90)


def normals_figure(normals: FloatArray, areas: FloatArray, orientation: Orientation):
    """Heat map of the face directions in spherical coordinates (theta around +y, phi from the
    south pole to the north pole) with the cluster centres, as the paper's Fig. "heatmap1"."""
    return normals_heat_map(normals_histogram(normals, areas), orientation)


def normals_heat_map(hist: FloatArray, orientation: Orientation):
    """:func:`normals_figure` of the histogram :func:`normals_histogram` made."""
    from matplotlib.colors import LogNorm
    from matplotlib.figure import Figure
    from matplotlib.ticker import FuncFormatter

    fig = Figure(figsize=(7.0, 3.8), dpi=150)
    ax = fig.add_axes((0.08, 0.13, 0.78, 0.77))
    positive = hist[hist > 0]
    norm = LogNorm(vmin=max(positive.min(), positive.max() * 1e-4), vmax=positive.max()) if len(positive) else None
    im = ax.imshow(hist.T, origin="lower", extent=(0, 360, 0, 180), aspect="auto", cmap="inferno", norm=norm, interpolation="nearest")
    cax = fig.add_axes((0.88, 0.13, 0.025, 0.77))
    cb = fig.colorbar(im, cax=cax)
    cb.set_label("face area per bucket (m²)", fontsize=7)
    cb.ax.tick_params(labelsize=6)
    cb.ax.minorticks_off()  # a log colour bar has dozens of minor ticks, slow to draw
    # plain numbers (0.01, 1e-05): the default labels (10 to a power) are set as math text, whose
    # parser a fresh drawing worker builds for them alone (0.07 s of the figure's 0.13 s)
    cb.ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    centres = [d.normal for d in orientation.alignment.directions] + [np.array([0.0, 1.0, 0.0]), np.array([0.0, -1.0, 0.0])]
    ct, cp = to_spherical(np.array(centres))
    ax.scatter(ct, cp, s=40, facecolors="none", edgecolors="#00e5ff", linewidths=1.3)
    box = dict(facecolor="black", alpha=0.6, pad=1, linewidth=0)
    ax.text(6, 174, "floors (+y)", color="#00e5ff", fontsize=7, va="top", bbox=box)
    ax.text(6, 6, "ceilings (-y)", color="#00e5ff", fontsize=7, va="bottom", bbox=box)
    ax.set_xlabel("theta: angle around the vertical axis from +x towards +z (degrees)", fontsize=7)
    ax.set_ylabel("phi: from -y to +y (degrees)", fontsize=7)
    ax.set_title(f"Face directions with the {len(orientation.alignment.directions)} wall directions found", fontsize=9)
    ax.tick_params(labelsize=6)
    ax.set_xticks(range(0, 361, 45))
    ax.set_yticks(range(0, 181, 30))
    return fig

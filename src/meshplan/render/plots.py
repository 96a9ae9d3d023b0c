"""Diagnostic figures of the orientation: the altitude histogram and the normals heat map."""

from __future__ import annotations

import numpy as np

from ..geometry import FloatArray
from ..orient import Orientation
from ..sphere import to_spherical
from .params import RenderParams


def levels_figure(orientation: Orientation, params: RenderParams):
    """The area-weighted histogram of near-horizontal face heights, with the floors and
    ceilings found (paper, Fig. "histogram-horizontal")."""
    from matplotlib.figure import Figure

    lv = orientation.levels
    unit, name = (0.3048, "ft") if params.imperial else (1.0, "m")
    fig = Figure(figsize=(7.5, 4.5), dpi=150)
    ax = fig.add_axes((0.1, 0.11, 0.58, 0.8))
    centres = 0.5 * (lv.edges[:-1] + lv.edges[1:])
    ax.barh(centres / unit, lv.weights, height=np.diff(lv.edges) / unit, color="#7f7f7f", linewidth=0)
    xmax = float(lv.weights.max()) if len(lv.weights) else 1.0
    for s in orientation.stories:
        ax.axhline(s.floor / unit, color="#2ca02c", lw=1.2, ls="--")
        ax.text(xmax * 1.02, s.floor / unit, f"story {s.index} floor {s.floor / unit:.2f} {name}", color="#2ca02c", fontsize=7, va="center")
        style = "--" if s.ceiling_found else ":"
        ax.axhline(s.ceiling / unit, color="#1f77b4", lw=1.2, ls=style)
        label = f"story {s.index} ceiling {s.ceiling / unit:.2f} {name}" + ("" if s.ceiling_found else " (assumed)")
        ax.text(xmax * 1.02, s.ceiling / unit, label, color="#1f77b4", fontsize=7, va="center")
    for sp in lv.spikes:
        ax.plot([sp.weight / 2], [sp.height / unit], marker="<", color="#d62728", ms=4)  # pair weight spans two buckets
    ax.set_xlabel("area of near-horizontal faces per 2-inch bucket (m²)", fontsize=8)
    ax.set_ylabel(f"height ({name})", fontsize=8)
    ax.set_title("Altitude histogram: floors and ceilings", fontsize=9)
    ax.tick_params(labelsize=7)
    ax.set_xlim(0, xmax * 1.05 if xmax > 0 else 1)
    return fig


def normals_figure(normals: FloatArray, areas: FloatArray, orientation: Orientation):
    """Heat map of the face directions in spherical coordinates (theta around +y, phi from the
    south pole to the north pole) with the cluster centres, as the paper's Fig. "heatmap1"."""
    from matplotlib.colors import LogNorm
    from matplotlib.figure import Figure

    theta, phi = to_spherical(normals)
    # 2-degree buckets (bincount: histogram2d is several times slower)
    i = np.clip((theta / 2).astype(np.int64), 0, 179)
    j = np.clip((phi / 2).astype(np.int64), 0, 89)
    hist = np.bincount(i * 90 + j, weights=areas, minlength=180 * 90).reshape(180, 90)
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

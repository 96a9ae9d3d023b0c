"""The plans' rasters: drawn without matplotlib's resampling (:mod:`meshplan.render.raster`)
yet byte for byte as matplotlib draws them, and counted per slice in one compiled pass
(:func:`meshplan.render.sheet.rasterize_segments`) as by sorting the (pixel, slice) pairs."""

from __future__ import annotations

import numpy as np
import pytest

from meshplan.render.sheet import Sheet, figure_bytes, place_raster, rasterize_segments


def _all_pairs(opaque: bool) -> np.ndarray:
    """Every (alpha, value) pair of bytes as pixels (all opaque when ``opaque``)."""
    a, v = np.meshgrid(np.arange(256), np.arange(256), indexing="ij")
    img = np.empty((256, 256, 4), dtype=np.uint8)
    img[..., 0], img[..., 1], img[..., 2] = v, 255 - v, (v * 7) % 256
    img[..., 3] = 255 if opaque else a
    return img


def _figure(rgba: np.ndarray, fast: bool, dpi: int = 150):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(4.0, 3.0), dpi=dpi)
    ax = fig.add_axes((0.1, 0.1, 0.8, 0.8))
    ax.set_zorder(2)
    ax.patch.set_alpha(0.0)
    ax.plot([0, 1], [0, 1], lw=0.5)
    if fast:
        place_raster(fig, ax, rgba)
    else:  # what place_raster did before: matplotlib's own figure image
        pos = ax.get_position()
        x0, y0 = pos.x0 * fig.get_figwidth() * dpi, pos.y0 * fig.get_figheight() * dpi
        h_px = pos.height * fig.get_figheight() * dpi
        fig.figimage(rgba, xo=int(round(x0)), yo=int(round(y0 + h_px - rgba.shape[0])), origin="upper", zorder=1)
    return fig


@pytest.mark.parametrize("opaque", [False, True])
@pytest.mark.parametrize("fmt", ["png", "svg", "pdf"])
def test_sheet_image_draws_the_same_bytes(opaque, fmt):
    rgba = _all_pairs(opaque)
    assert figure_bytes(_figure(rgba, True), fmt) == figure_bytes(_figure(rgba, False), fmt)


@pytest.mark.parametrize("fmt", ["png", "pdf"])
def test_sheet_image_falls_back_off_the_grid(fmt):
    """A raster that overhangs the page is clipped by matplotlib's own pipeline, unchanged."""
    rgba = np.tile(_all_pairs(False), (3, 3, 1))  # 768 px: more than the 3 in x 150 dpi page
    assert figure_bytes(_figure(rgba, True), fmt) == figure_bytes(_figure(rgba, False), fmt)


def test_pipeline_bytes_is_matplotlibs_arithmetic():
    from matplotlib.image import FigureImage

    from meshplan.render.raster import pipeline_bytes

    made = []
    original = FigureImage.make_image

    def spy(self, renderer, magnification=1.0, unsampled=False):
        out = original(self, renderer, magnification, unsampled)
        made.append(out[0])
        return out

    FigureImage.make_image = spy  # type: ignore[method-assign]
    try:
        for opaque in (False, True):
            rgba = _all_pairs(opaque)
            figure_bytes(_figure(rgba, False), "png")
            np.testing.assert_array_equal(made[-1], pipeline_bytes(rgba)[::-1])
    finally:
        FigureImage.make_image = original  # type: ignore[method-assign]


def _counts_by_sorting(segments, level, sheet: Sheet) -> np.ndarray:
    """The former implementation: distinct (pixel, slice) pairs by sorting their keys."""
    rows, cols = sheet.raster_shape
    p = sheet.pixel_m
    origin = np.array([sheet.xmin, sheet.zmin])
    a = (segments[:, 0] - origin) / p
    b = (segments[:, 1] - origin) / p
    n = np.ceil(np.hypot(*(b - a).T)).astype(np.int64) + 1
    seg = np.repeat(np.arange(len(a)), n)
    t = (np.arange(len(seg)) - np.repeat(np.cumsum(n) - n, n)) / np.repeat(np.maximum(n - 1, 1), n)
    pts = a[seg] + (b - a)[seg] * t[:, None]
    c, r = pts[:, 0].astype(np.int64), pts[:, 1].astype(np.int64)
    inside = (c >= 0) & (c < cols) & (r >= 0) & (r < rows)
    lv = np.asarray(level, dtype=np.int64)[seg[inside]]
    n_levels = int(lv.max()) + 1 if len(lv) else 1
    key = np.sort((r[inside] * cols + c[inside]) * n_levels + lv)
    first = np.r_[True, key[1:] != key[:-1]] if len(key) else np.zeros(0, bool)
    return np.bincount(key[first] // n_levels, minlength=rows * cols).reshape(rows, cols)


@pytest.mark.parametrize("n_levels", [1, 64, 65, 200])
def test_rasterize_segments_counts_each_slice_once(n_levels):
    rng = np.random.default_rng(n_levels)
    sheet = Sheet(-1.0, 6.0, -1.0, 5.0, 100, 60)
    a = rng.uniform(-1.5, 6.5, size=(3000, 2))
    segments = np.stack([a, a + rng.normal(scale=0.3, size=a.shape)], axis=1)
    level = rng.integers(0, n_levels, size=len(segments))
    got = rasterize_segments(segments, level, sheet)
    np.testing.assert_array_equal(got, _counts_by_sorting(segments, level, sheet))
    assert got.dtype == np.int32 and got.shape == sheet.raster_shape
    assert rasterize_segments(np.zeros((0, 2, 2)), np.zeros(0, int), sheet).shape == sheet.raster_shape


# --- the filters of the drawings (issue 15: the same pixels, faster) ---------------------------


@pytest.mark.parametrize("shape", [(1, 1), (1, 9), (9, 1), (40, 31), (40, 31, 4)])
@pytest.mark.parametrize("size", [2, 3])
def test_grow_max_is_scipys_maximum_filter(shape, size):
    from scipy.ndimage import maximum_filter

    from meshplan.render.sheet import grow_max

    rng = np.random.default_rng(len(shape) * 10 + size)
    image = ((rng.random(shape) < 0.1) * rng.integers(1, 256, size=shape)).astype(np.uint8)
    expected = maximum_filter(image, size=(size, size) + (1,) * (image.ndim - 2))
    np.testing.assert_array_equal(grow_max(image, size), expected)


def test_ink_rgba_looks_up_every_count():
    from meshplan.render.sheet import ink_rgba

    counts = np.arange(300, dtype=np.int32).reshape(15, 20)
    out = ink_rgba(counts, 0.5, width_px=1)
    assert out.shape == (15, 20, 4) and out.dtype == np.uint8
    k = np.minimum(counts, 255)
    np.testing.assert_array_equal(out[..., 3], np.round(255 * (1.0 - 0.5**k)).astype(np.uint8))
    np.testing.assert_array_equal(out[..., :3], np.broadcast_to(np.array([0x14, 0x21, 0x3D], np.uint8), (15, 20, 3)))


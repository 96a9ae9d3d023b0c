"""A raster placed on a figure pixel for pixel, drawn without matplotlib's resampling.

matplotlib draws every image through its general pipeline: the RGBA bytes are turned into
float32, premultiplied by their alpha, resampled onto the output grid, divided by the alpha
again and turned back into bytes, once per format a figure is saved in. For a plan's raster
(2-3 million pixels, placed at the sheet's own pixel size) the resampling maps each pixel onto
itself, and the rest is arithmetic on the byte values alone: the profile of the pen-and-ink
plan showed this at half of its saving time (0.28 s per format on the benchmark apartment).

:class:`SheetImage` gives the renderers exactly the bytes that pipeline would give, from a table
of what that pipeline makes of every (alpha, value) pair, and falls back to matplotlib's
own pipeline whenever the output grid is not the raster's own (a renderer whose resolution
differs from the sheet's).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from matplotlib.image import FigureImage

#: How far (in output pixels) the raster's corners may be from whole pixels of the output grid
#: and still count as placed on it: matplotlib's own transforms leave about 1e-13 of rounding,
#: and nearest-neighbour sampling then reads each pixel at its centre, half a pixel away.
_GRID_TOLERANCE_PX = 1e-6
#: Resolution of the figure the byte tables are measured on: any, the image is drawn at its
#: own size whatever the resolution.
_TABLE_DPI = 72


@lru_cache(maxsize=2)
def _byte_tables(premultiplied: bool) -> tuple[np.ndarray, np.ndarray]:
    """``(colour, alpha)`` tables of what matplotlib's image pipeline makes of an RGBA byte image
    drawn pixel for pixel: ``colour[a, v]`` is the output of colour value ``v`` at alpha ``a``,
    ``alpha[a]`` the output alpha.

    Measured, not re-derived: every (alpha, value) pair is drawn once through matplotlib's own
    pipeline (a 256 x 256 image, a few milliseconds a process), whose float32 arithmetic
    includes Agg's blending into the output buffer. Each output pixel depends on its own input
    pixel alone (nearest-neighbour sampling onto the same grid), and each channel on its value
    and the alpha alone. matplotlib premultiplies only when some pixel of the image is not
    opaque (``premultiplied``), so the opaque table comes from an opaque image.
    """
    from matplotlib.backends.backend_agg import RendererAgg
    from matplotlib.figure import Figure

    values = np.arange(256, dtype=np.uint8)
    pairs = np.empty((256, 256, 4), dtype=np.uint8)  # rows: alpha; columns: colour value
    pairs[..., :3] = values[None, :, None]
    pairs[..., 3] = values[:, None] if premultiplied else 255
    side = 256 / _TABLE_DPI
    fig = Figure(figsize=(side, side), dpi=_TABLE_DPI)
    image = FigureImage(fig, origin="lower")
    image.set_data(pairs)
    out = image.make_image(RendererAgg(256, 256, _TABLE_DPI))[0]
    if out is None or out.shape != pairs.shape:  # pragma: no cover - matplotlib changed
        raise RuntimeError("matplotlib does not draw a figure image pixel for pixel")
    return np.ascontiguousarray(out[..., 0]), np.ascontiguousarray(out[:, 0, 3])


def pipeline_bytes(rgba: np.ndarray) -> np.ndarray:
    """The bytes matplotlib's image pipeline makes of the ``(rows, cols, 4)`` uint8 image
    ``rgba`` drawn pixel for pixel, rows in the same order (no flip)."""
    alpha = rgba[..., 3]
    colour, alpha_table = _byte_tables(bool((alpha != 255).any()))
    flat = rgba.reshape(-1, 4)
    if colour[0].any() or alpha_table[0]:  # pragma: no cover - matplotlib keeps colour in transparent pixels
        shown = np.arange(len(flat))
    else:  # transparent pixels come out as zeros: only the inked ones (a fraction) are looked up
        shown = np.flatnonzero(alpha.reshape(-1))
    px = flat[shown]
    out = np.zeros_like(flat)
    out[shown, :3] = colour[px[:, 3, None], px[:, :3]]
    out[shown, 3] = alpha_table[px[:, 3]]
    return out.reshape(rgba.shape)


class SheetImage(FigureImage):
    """A figure image of uint8 RGBA, drawn pixel for pixel without resampling where the output
    grid is the raster's own; byte for byte what :class:`~matplotlib.image.FigureImage` draws."""

    _made: np.ndarray | None = None

    def make_image(self, renderer, magnification=1.0, unsampled=False):
        # docstring inherited
        a = self._A
        if unsampled or a is None or a.dtype != np.uint8 or a.ndim != 3 or a.shape[2] != 4 or self.get_alpha() is not None:
            return super().make_image(renderer, magnification, unsampled)
        from matplotlib.transforms import Affine2D, Bbox

        # the geometry of FigureImage.make_image and _ImageBase._make_image (no pixel rounding)
        fig = self.get_figure(root=True)
        fac = renderer.dpi / fig.dpi
        mag = magnification / fac
        rows, cols = a.shape[:2]
        bbox = Bbox([[self.ox / fac, self.oy / fac], [self.ox / fac + cols, self.oy / fac + rows]])
        width, height = fig.get_size_inches() * renderer.dpi
        clipped = Bbox.intersection(bbox, Bbox([[0, 0], [width, height]]))
        if clipped is None:
            return None, 0, 0, None
        out = Bbox.from_extents(clipped.extents * mag)
        shape = (int(out.height), int(out.width))
        t = Affine2D().translate(0, -rows).scale(1, -1) if self.origin == "upper" else Affine2D()
        t += Affine2D().scale(bbox.width / cols, bbox.height / rows).translate(bbox.x0, bbox.y0) + self.get_transform()
        t += Affine2D().scale(mag).translate(-out.x0, -out.y0)
        # drawn pixel for pixel: the raster's corners land on the output grid's corners
        flip = self.origin == "upper"
        corners = t.transform(np.array([[0.0, 0.0], [cols, rows]]))
        expected = np.array([[0.0, rows if flip else 0.0], [cols, 0.0 if flip else rows]])
        if shape != (rows, cols) or not t.is_affine or np.abs(corners - expected).max() > _GRID_TOLERANCE_PX:
            return super().make_image(renderer, magnification, unsampled)
        if self._made is None:
            made = pipeline_bytes(a)
            self._made = np.ascontiguousarray(made[::-1]) if flip else made
        return self._made, out.x0 / mag, out.y0 / mag, t

    def set_data(self, A):
        # docstring inherited
        super().set_data(A)
        self._made = None

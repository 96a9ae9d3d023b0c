"""A figure drawn once for all its files: the PNG from matplotlib's Agg renderer, the SVG and the
PDF written directly from what that one drawing pass drew.

matplotlib draws a figure anew for every format it is saved in: each save walks the whole
artist tree again (every text laid out, every tick, the legend packed, each arrow shrunk), and
that walk, not the writing of the file, was most of a plan's cost (about 0.1-0.2 s of the
0.15-0.22 s of each SVG and PDF of the 300k-face apartment's plans, profiled). Here the figure
is drawn once, on a :class:`PlanRenderer`: an Agg renderer (the PNG's pixels, as matplotlib
draws them) that also records each primitive it is handed (a path with its stroke, fill,
dashes, hatch and clip; a line of text at its baseline with its font; an image) in points of
paper. :func:`svg_bytes` and :func:`pdf_bytes` write those primitives out (a few milliseconds),
and :func:`png_bytes` encodes the pixels.

What the vector files hold is what matplotlib's own backends would write: texts as text (SVG:
``<text>`` in the figure's font family, anchored as matplotlib anchors them; PDF: the
DejaVu glyphs used, embedded as Type 3 fonts with their kerning, text extractable through a
ToUnicode map), paths unsimplified, images as PNG (SVG) or Flate streams with a soft mask (PDF).
The layout is the Agg drawing's (its text metrics, at the figure's resolution), so the three
files agree with each other to a fraction of a point. A primitive this module does not know (a
Gouraud-shaded or quad mesh: no plan draws one) makes :func:`figure_files` save that figure's
vector formats with matplotlib instead.

Why one long module: the recorder and the three writers share the recorded primitives (their
classes, the path and number formatting) and nothing else uses them.
"""

from __future__ import annotations

import base64
import math
import struct
import zlib
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any, cast

import numpy as np
from matplotlib.backend_bases import GraphicsContextBase, RendererBase
from matplotlib.backends.backend_agg import FigureCanvasAgg, RendererAgg
from matplotlib.path import Path

#: zlib level of the PNG files and of the images inside SVG and PDF: the fastest (1). Plans are
#: mostly blank paper, which every level packs well: level 6 made the 300k-face apartment's
#: drafting PNG a quarter smaller (192 KB instead of 255 KB) for 2.3 times the time (0.054 s
#: instead of 0.023 s per file).
ZLIB_LEVEL = 1
#: Decimals of a coordinate in points (1/72 inch) in the SVG and PDF: 0.001 pt is 0.35 micrometres.
COORD_DECIMALS = 3
#: Side of a hatch tile in points, as matplotlib's backends draw hatches (72: an inch).
HATCH_TILE_PT = 72.0
#: Streams of a PDF shorter than this (bytes: a glyph's outline) are written uncompressed, which
#: costs less than starting zlib for each.
_MIN_COMPRESSED = 2048
#: Glyphs per embedded Type 3 font: one byte per character code.
GLYPHS_PER_FONT = 256

_MOVETO, _LINETO, _CURVE3, _CURVE4, _CLOSEPOLY = Path.MOVETO, Path.LINETO, Path.CURVE3, Path.CURVE4, Path.CLOSEPOLY


class Unsupported(Exception):
    """A primitive the direct writers do not draw (the caller falls back to matplotlib)."""


# --- what was drawn ------------------------------------------------------------------------------


@dataclass(frozen=True)
class Style:
    """How a path is painted: colours as RGBA in 0-1, widths and dashes in points."""

    fill: tuple[float, ...] | None
    stroke: tuple[float, ...] | None
    linewidth: float
    dashes: tuple[float, tuple[float, ...]] | None
    join: str
    cap: str
    alpha: float | None  # forced alpha of the whole element (matplotlib's set_alpha), or None
    hatch: tuple | None  # (pattern, RGBA colour, linewidth) of a hatched fill


@dataclass(frozen=True)
class Clip:
    """A clip region in points: a rectangle ``(x0, y0, x1, y1)`` and/or a path."""

    rect: tuple[float, float, float, float] | None
    path: tuple[bytes, bytes] | None  # vertices and codes of the clip path, as bytes (hashable)

    def path_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        assert self.path is not None
        v = np.frombuffer(self.path[0], dtype=np.float64).reshape(-1, 2)
        return v, np.frombuffer(self.path[1], dtype=np.uint8)


@dataclass(frozen=True)
class PathOp:
    """A path as drawn: its vertices in points (y up) with matplotlib's path codes, painted
    with ``style`` inside ``clip``."""

    vertices: np.ndarray  # (N, 2) points, y up
    codes: np.ndarray  # (N,) matplotlib path codes (uint8)
    style: Style
    clip: Clip | None


@dataclass(frozen=True)
class TextOp:
    """A line of text as drawn: from its baseline's start (points, y up), turned by ``angle``,
    in the font of ``prop``; ``anchor`` is where matplotlib's SVG would anchor it."""

    x: float  # baseline start, points, y up
    y: float
    angle: float  # degrees counter-clockwise
    text: str
    prop: Any  # FontProperties
    color: tuple[float, ...]
    alpha: float | None
    anchor: tuple[float, float, str] | None  # (x, y, ha) where the SVG may anchor the text
    clip: Clip | None


@dataclass(frozen=True)
class ImageOp:
    """An image as drawn: its RGBA pixels placed on the rectangle of its lower left corner
    and size (points)."""

    x: float  # lower left, points
    y: float
    width: float
    height: float
    rgba: np.ndarray  # (rows, cols, 4) uint8, first row at the top
    alpha: float
    clip: Clip | None


def _rgba(c) -> tuple[float, ...]:
    t = tuple(float(v) for v in c)
    return t if len(t) == 4 else (*t, 1.0)


class PlanRenderer(RendererAgg):
    """An Agg renderer that also records, in points, every primitive it draws (``ops``).

    With ``raster=False`` nothing is painted (only recorded): for a figure saved as SVG or PDF
    alone. Text is laid out with Agg's metrics either way, so the files agree.
    """

    def __init__(self, width: float, height: float, dpi: float, raster: bool = True) -> None:
        self.raster = raster
        self.ops: list = []
        self._pt = 72.0 / dpi
        super().__init__(width, height, dpi)

    def _update_methods(self) -> None:
        super()._update_methods()
        agg = self._renderer

        def draw_markers(gc, marker_path, marker_trans, path, trans, rgbFace=None):
            RendererBase.draw_markers(self._recorder, gc, marker_path, marker_trans, path, trans, rgbFace)
            if self.raster:
                agg.draw_markers(gc, marker_path, marker_trans, path, trans, rgbFace)

        def draw_path_collection(gc, *args, **kwargs):
            RendererBase.draw_path_collection(self._recorder, gc, *args, **kwargs)
            if self.raster:
                agg.draw_path_collection(gc, *args, **kwargs)

        def draw_image(gc, x, y, im):
            self.record_image(gc, x, y, im)
            if self.raster:
                agg.draw_image(gc, x, y, im)

        def unsupported(*args, **kwargs):
            raise Unsupported("a mesh or shaded triangles")

        self.draw_markers = draw_markers  # type: ignore[method-assign]
        self.draw_path_collection = draw_path_collection  # type: ignore[method-assign]
        self.draw_image = draw_image  # type: ignore[method-assign, assignment]
        self.draw_quad_mesh = unsupported  # type: ignore[method-assign]
        self.draw_gouraud_triangles = unsupported  # type: ignore[method-assign]
        self._recorder = _Recorder(self)

    def begin(self, raster: bool) -> None:
        """Start a drawing: nothing recorded, a blank canvas (painted only when ``raster``)."""
        self.ops = []
        self.raster = raster
        if raster:
            self.clear()

    # --- drawing (and recording) ---------------------------------------------------------------

    def draw_path(self, gc, path, transform, rgbFace=None):
        # docstring inherited
        self.record_path(gc, path, transform, rgbFace)
        if self.raster:
            super().draw_path(gc, path, transform, rgbFace)

    def draw_text(self, gc, x, y, s, prop, angle, ismath=False, mtext=None):
        # docstring inherited
        if ismath:  # mathtext: recorded as outlines (plans draw none: their texts are plain)
            path, transform = self._get_text_path_transform(x, y, s, prop, angle, ismath)
            g = GraphicsContextBase()
            g.copy_properties(gc)
            g.set_linewidth(0.0)
            self.record_path(g, path, transform, gc.get_rgb())
        else:
            self.record_text(gc, x, y, s, prop, angle, mtext)
        if self.raster:
            super().draw_text(gc, x, y, s, prop, angle, ismath, mtext)

    # --- recording -----------------------------------------------------------------------------

    def _clip(self, gc) -> Clip | None:
        rect = gc.get_clip_rectangle()
        r = None
        if rect is not None:
            x0, y0, x1, y1 = (float(v) * self._pt for v in rect.extents)
            r = (x0, y0, x1, y1)
        tpath, affine = gc.get_clip_path()
        p = None
        if tpath is not None:
            cp = tpath.cleaned(transform=affine, remove_nans=True, curves=True)
            v, c = cp.vertices[:-1] * self._pt, cp.codes[:-1].astype(np.uint8)
            p = (np.ascontiguousarray(v, dtype=np.float64).tobytes(), c.tobytes())
        return None if r is None and p is None else Clip(r, p)

    def _style(self, gc, rgbFace) -> Style:
        forced = gc.get_forced_alpha()
        lw = float(gc.get_linewidth())
        rgb = _rgba(gc.get_rgb())
        stroke = rgb if lw > 0 else None
        fill = _rgba(rgbFace) if rgbFace is not None else None
        if forced and fill is not None:
            fill = (*fill[:3], 1.0)  # the element's alpha applies (as matplotlib's SVG writes)
        if forced and stroke is not None:
            stroke = (*stroke[:3], 1.0)
        offset, seq = gc.get_dashes()
        dashes = (float(offset or 0.0), tuple(float(v) for v in seq)) if seq is not None and len(seq) else None
        hatch = None
        if gc.get_hatch() is not None:
            hatch = (gc.get_hatch(), _rgba(gc.get_hatch_color()), float(gc.get_hatch_linewidth()))
        alpha = float(gc.get_alpha()) if forced and gc.get_alpha() != 1.0 else None
        return Style(fill, stroke, lw, dashes, gc.get_joinstyle(), gc.get_capstyle(), alpha, hatch)

    def record_path(self, gc, path, transform, rgbFace=None) -> None:
        p = path.cleaned(transform=transform, remove_nans=True, curves=True)
        if len(p.vertices) <= 1:
            return
        v = p.vertices[:-1] * self._pt  # the last vertex is the STOP code's
        self.ops.append(PathOp(v, p.codes[:-1].astype(np.uint8), self._style(gc, rgbFace), self._clip(gc)))

    def record_text(self, gc, x, y, s, prop, angle, mtext) -> None:
        if not s.strip():
            return
        forced = gc.get_forced_alpha()
        color = _rgba(gc.get_rgb())
        if self.flipy():  # Agg is handed texts from the top of the canvas; y up here
            y = self.height - y
        anchor = None
        if mtext is not None and (angle == 0 or mtext.get_rotation_mode() == "anchor"):
            # where matplotlib's SVG anchors a text (so that another font stays aligned): its
            # own position, moved along the text's vertical to the baseline drawn
            ax, ay = mtext.get_transform().transform(mtext.get_unitless_position())
            a = math.radians(angle)
            up = (-math.sin(a), math.cos(a))
            off = up[0] * (x - ax) + up[1] * (y - ay)
            anchor = ((ax + off * up[0]) * self._pt, (ay + off * up[1]) * self._pt, mtext.get_ha())
        self.ops.append(
            TextOp(x * self._pt, y * self._pt, float(angle), s, prop.copy(), color, float(gc.get_alpha()) if forced else None, anchor, self._clip(gc))
        )

    def record_image(self, gc, x, y, im) -> None:
        rows, cols = im.shape[:2]
        if not rows or not cols:
            return
        rgba = np.ascontiguousarray(np.asarray(im)[::-1])  # Agg's first row is the bottom one
        alpha = gc.get_alpha()
        self.ops.append(ImageOp(x * self._pt, y * self._pt, cols * self._pt, rows * self._pt, rgba, 1.0 if alpha is None else float(alpha), self._clip(gc)))


class _Recorder(RendererBase):
    """Splits markers and collections into paths (RendererBase's own loops) and records them,
    without painting: the Agg renderer paints them itself, in C."""

    def __init__(self, owner: PlanRenderer) -> None:
        super().__init__()
        self._owner = owner

    def draw_path(self, gc, path, transform, rgbFace=None):
        self._owner.record_path(gc, path, transform, rgbFace)

    def points_to_pixels(self, points):
        return self._owner.points_to_pixels(points)


# --- numbers and paths as text ---------------------------------------------------------------------


def _num(v: float) -> str:
    s = str(round(float(v), COORD_DECIMALS) + 0.0)  # + 0.0: no "-0.0"
    return s[:-2] if s.endswith(".0") else s


def _nums(a: np.ndarray) -> list[str]:
    """Each number of ``a`` (flattened) as short text (:func:`_num`; Python's float repr is
    three times faster than numpy's string formatting for these few thousand numbers)."""
    out = [str(v) for v in (np.round(np.asarray(a, dtype=np.float64).ravel(), COORD_DECIMALS) + 0.0).tolist()]
    return [s[:-2] if s.endswith(".0") else s for s in out]


def _cubic(vertices: np.ndarray, codes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The path with each quadratic curve (CURVE3: a control point and an end point) raised to
    a cubic one (CURVE4: two control points and the end point), the same curve."""
    n = len(codes)
    idx = np.arange(n)
    # the current point before each vertex: the previous vertex, or after a CLOSEPOLY the
    # start of its subpath
    starts = np.maximum.accumulate(np.where(codes == _MOVETO, idx, 0))
    here = np.where((codes == _CLOSEPOLY)[:, None], vertices[starts], vertices)
    is3 = codes == _CURVE3
    ctrl = is3 & (np.cumsum(is3) % 2 == 1)  # the first of each pair: the control point
    counts = np.where(ctrl, 2, 1)
    v = np.repeat(vertices, counts, axis=0)
    c = np.repeat(codes, counts)
    c[c == _CURVE3] = _CURVE4
    k = np.flatnonzero(ctrl)
    at = np.cumsum(counts) - counts  # where each input vertex starts in the output
    p0 = here[np.maximum(k - 1, 0)]
    q1, q2 = vertices[k], vertices[k + 1]
    v[at[k]] = p0 + 2.0 / 3.0 * (q1 - p0)
    v[at[k] + 1] = q2 + 2.0 / 3.0 * (q1 - q2)
    return v, c


def _path_text(vertices: np.ndarray, codes: np.ndarray, ops: dict[str, str], flip_h: float | None) -> str:
    """A path as text: SVG ``d`` (``flip_h``: the page height, y down) or PDF operators."""
    codes = np.asarray(codes)
    if len(codes) and codes.min() == 0:  # STOP codes: none after cleaning, but glyph paths
        keep = codes != 0
        vertices, codes = np.asarray(vertices)[keep], codes[keep]
    if not len(codes):
        return ""
    curves = bool(codes.max() >= _CURVE3) and bool(((codes == _CURVE3) | (codes == _CURVE4)).any())
    if curves and (codes == _CURVE3).any():
        vertices, codes = _cubic(vertices, codes)
    v = np.asarray(vertices, dtype=np.float64)
    if flip_h is not None:
        v = np.column_stack([v[:, 0], flip_h - v[:, 1]])
    nums = _nums(v)
    xy = [f"{x} {y}" for x, y in zip(nums[0::2], nums[1::2])]
    svg = flip_h is not None
    m, ln, z = ops["M"], ops["L"], ops["Z"]
    cl = codes.tolist()
    if not curves:
        if svg:
            return "".join(z if c == _CLOSEPOLY else (m if c == _MOVETO else ln) + p for c, p in zip(cl, xy))
        return " ".join(z if c == _CLOSEPOLY else p + (" m" if c == _MOVETO else " l") for c, p in zip(cl, xy))
    # the place of each cubic's vertex in its triple (0, 1, 2): runs of CURVE4 come in threes
    is4 = codes == _CURVE4
    idx = np.arange(len(codes))
    first = is4.copy()
    first[1:] &= ~is4[:-1]
    run = np.maximum.accumulate(np.where(first, idx, 0))
    third = np.where(is4, (idx - run) % 3, -1).tolist()
    out = []
    cop = ops["C"]
    for c, p, t in zip(cl, xy, third):
        if c == _CLOSEPOLY:
            out.append(z)
        elif c == _MOVETO:
            out.append(m + p if svg else p + " " + m)
        elif c == _LINETO:
            out.append(ln + p if svg else p + " " + ln)
        elif svg:
            out.append(cop + p if t == 0 else " " + p)
        else:
            out.append(p + " " + cop if t == 2 else p)
    return ("" if svg else " ").join(out)


_SVG_OPS = {"M": "M", "L": "L", "C": "C", "Z": "Z"}
_PDF_OPS = {"M": "m", "L": "l", "C": "c", "Z": "h"}


def _hex(c: tuple[float, ...]) -> str:
    return "#{:02x}{:02x}{:02x}".format(*(int(round(255 * min(max(v, 0.0), 1.0))) for v in c[:3]))


# --- PNG ---------------------------------------------------------------------------------------------


def png_bytes(rgba: np.ndarray, dpi: float | None = None, software: str = "meshplan", palette: np.ndarray | None = None) -> bytes:
    """An RGBA (or RGB) image, first row at the top, as PNG: every row filtered "Up", zlib at
    :data:`ZLIB_LEVEL`, a pHYs chunk for ``dpi`` and a ``Software`` text chunk (an opaque
    figure stays RGBA: dropping its alpha costs a strided copy, about what it saves zlib). With a
    ``palette`` (``(256, 4)`` RGBA) ``rgba`` is ``(rows, cols, 1)`` of indices into it.

    Pillow's encoder tries every PNG row filter on every row, which is most of its time; plans
    are mostly blank paper, whose rows repeat the row above: one filter for all rows packs them
    as well (the 300k-face apartment's drafting PNG: 0.022 s here, 255 KB; 0.074 s and 249 KB
    through Pillow at the same level; unfiltered 0.022 s, 274 KB)."""
    a = np.ascontiguousarray(rgba, dtype=np.uint8)
    rows, cols, channels = a.shape
    flat = a.reshape(rows, -1)
    raw = np.empty((rows, cols * channels + 1), dtype=np.uint8)
    raw[:, 0] = 2  # filter "Up": each row less the one above (modulo 256)
    raw[0, 1:] = flat[0]
    np.subtract(flat[1:], flat[:-1], out=raw[1:, 1:])

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    colour = {4: 6, 3: 2, 1: 0}[channels] if palette is None else 3
    out = [b"\x89PNG\r\n\x1a\n", chunk(b"IHDR", struct.pack(">IIBBBBB", cols, rows, 8, colour, 0, 0, 0))]
    if palette is not None:
        out.append(chunk(b"PLTE", np.ascontiguousarray(palette[:, :3], dtype=np.uint8).tobytes()))
        out.append(chunk(b"tRNS", np.ascontiguousarray(palette[:, 3], dtype=np.uint8).tobytes()))
    if dpi:
        ppm = int(round(dpi / 0.0254))
        out.append(chunk(b"pHYs", struct.pack(">IIB", ppm, ppm, 1)))
    if software:
        out.append(chunk(b"tEXt", b"Software\x00" + software.encode("latin-1")))
    out.append(chunk(b"IDAT", zlib.compress(raw.tobytes(), ZLIB_LEVEL)))
    out.append(chunk(b"IEND", b""))
    return b"".join(out)


def single_colour(rgba: np.ndarray) -> np.ndarray | None:
    """The one RGB colour of every pixel of ``rgba`` that is not fully transparent (a plan's ink
    raster: its pixels differ in opacity alone), or ``None`` when there are several."""
    flat = rgba.reshape(-1, 4)
    shown = np.flatnonzero(flat[:, 3])
    if not len(shown):
        return np.zeros(3, dtype=np.uint8)
    first = flat[shown[0], :3]
    return first.copy() if bool((flat[shown, :3] == first).all()) else None


def _image_png(rgba: np.ndarray) -> bytes:
    """An image for the SVG as PNG: of one colour (:func:`single_colour`), a palette of that
    colour at the 256 opacities indexed by the alpha channel (a quarter of the bytes to pack);
    else RGBA."""
    colour = single_colour(rgba)
    if colour is None:
        return png_bytes(rgba, software="")
    palette = np.empty((256, 4), dtype=np.uint8)
    palette[:, :3] = colour
    palette[:, 3] = np.arange(256)
    return png_bytes(rgba[..., 3:4], software="", palette=palette)


# --- SVG ---------------------------------------------------------------------------------------------


def _xml_text(s: str) -> str:
    s = "".join(ch for ch in s if ch in "\t\n\r" or ord(ch) >= 0x20)  # what XML 1.0 allows
    return s.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def _font_family(prop) -> str:
    """The CSS font family list matplotlib's SVG writes for ``prop``: each generic family
    preceded by the fonts configured for it."""
    from matplotlib import font_manager as fm
    from matplotlib import rcParams

    rc: Any = rcParams  # looked up by a computed name, which the typed keys do not list
    names: list[str] = []
    for entry in prop.get_family():
        fn = "sans-serif" if entry in ("sans", "sans serif") else entry
        if fn in fm.font_family_aliases:
            key = "sans-serif" if fn in ("sans", "sans serif", "sans-serif") else fn
            for name in rc.get(f"font.{key}", []):
                names.append("sans-serif" if name in ("sans", "sans serif") else name)
        names.append(fn)
    quoted = [n if n in fm.font_family_aliases else repr(n) for n in names]
    return ", ".join(dict.fromkeys(quoted))


def svg_bytes(ops: list, width_pt: float, height_pt: float, creator: str = "meshplan") -> bytes:
    """The recorded primitives as an SVG 1.1 document of ``width_pt`` x ``height_pt`` points."""
    from matplotlib import font_manager as fm

    h = height_pt
    defs: list[str] = []
    clip_ids: dict[Clip, str] = {}
    hatch_ids: dict[tuple, str] = {}
    families: dict[tuple, str] = {}

    def clip_attr(clip: Clip | None) -> str:
        if clip is None:
            return ""
        if clip not in clip_ids:
            cid = f"c{len(clip_ids) + 1}"
            clip_ids[clip] = cid
            if clip.path is not None:
                v, c = clip.path_arrays()
                shape = f'<path d="{_path_text(v, c, _SVG_OPS, h)}"/>'
            else:
                assert clip.rect is not None
                x0, y0, x1, y1 = clip.rect
                shape = f'<rect x="{_num(x0)}" y="{_num(h - y1)}" width="{_num(x1 - x0)}" height="{_num(y1 - y0)}"/>'
            defs.append(f' <clipPath id="{cid}">{shape}</clipPath>')
            if clip.path is not None and clip.rect is not None:  # both: the rectangle around the path's clip
                x0, y0, x1, y1 = clip.rect
                inner = cid
                cid = f"c{len(clip_ids) + 1}x"
                defs.append(
                    f' <clipPath id="{cid}" clip-path="url(#{inner})"><rect x="{_num(x0)}" y="{_num(h - y1)}" '
                    f'width="{_num(x1 - x0)}" height="{_num(y1 - y0)}"/></clipPath>'
                )
                clip_ids[clip] = cid
        return f' clip-path="url(#{clip_ids[clip]})"'

    def hatch_fill(style: Style) -> str:
        pattern, color, lw = style.hatch  # type: ignore[misc]
        key = (pattern, style.fill, color, lw)
        if key not in hatch_ids:
            hid = f"h{len(hatch_ids) + 1}"
            hatch_ids[key] = hid
            hp = Path.hatch(pattern, 6.0)
            hc = hp.cleaned(curves=True)
            v = hc.vertices[:-1] * HATCH_TILE_PT
            t = HATCH_TILE_PT
            back = f'<rect x="0" y="0" width="{_num(t + 1)}" height="{_num(t + 1)}" fill="{_hex(style.fill)}"/>' if style.fill else ""
            defs.append(
                f' <pattern id="{hid}" patternUnits="userSpaceOnUse" x="0" y="0" width="{_num(t)}" height="{_num(t)}">{back}'
                f'<path d="{_path_text(v, hc.codes[:-1], _SVG_OPS, t)}" style="fill: {_hex(color)}; stroke: {_hex(color)}; '
                f'stroke-width: {_num(lw)}; stroke-linecap: butt; stroke-linejoin: miter"/></pattern>'
            )
        return f"url(#{hatch_ids[key]})"

    body: list[str] = []
    for op in ops:
        if isinstance(op, PathOp):
            s = op.style
            css = []
            if s.hatch is not None:
                css.append(f"fill: {hatch_fill(s)}")
            elif s.fill is None:
                css.append("fill: none")
            else:
                css.append(f"fill: {_hex(s.fill)}")
                if s.fill[3] != 1.0:
                    css.append(f"fill-opacity: {_num(s.fill[3])}")
            if s.alpha is not None:
                css.append(f"opacity: {_num(s.alpha)}")
            if s.stroke is not None:
                if s.dashes is not None:
                    css.append(f"stroke-dasharray: {','.join(_num(d) for d in s.dashes[1])}")
                    css.append(f"stroke-dashoffset: {_num(s.dashes[0])}")
                css.append(f"stroke: {_hex(s.stroke)}")
                if s.stroke[3] != 1.0:
                    css.append(f"stroke-opacity: {_num(s.stroke[3])}")
                css.append(f"stroke-width: {_num(s.linewidth)}")
                if s.join != "round":
                    css.append(f"stroke-linejoin: {s.join}")
                if s.cap != "butt":
                    css.append(f"stroke-linecap: {'square' if s.cap == 'projecting' else s.cap}")
            body.append(f' <path d="{_path_text(op.vertices, op.codes, _SVG_OPS, h)}"{clip_attr(op.clip)} style="{"; ".join(css)}"/>')
        elif isinstance(op, TextOp):
            p = op.prop
            key = tuple(p.get_family())
            if key not in families:
                families[key] = _font_family(p)
            css = [f"font-size: {_num(p.get_size_in_points())}px", f"font-family: {families[key]}"]
            if p.get_style() != "normal":
                css.append(f"font-style: {p.get_style()}")
            weight = p.get_weight()
            weight = fm.weight_dict.get(weight, weight)
            if weight != 400:
                css.append(f"font-weight: {weight}")
            if _hex(op.color) != "#000000":
                css.append(f"fill: {_hex(op.color)}")
            a = op.alpha if op.alpha is not None else op.color[3]
            if a != 1.0:
                css.append(f"opacity: {_num(a)}")
            if op.anchor is not None:
                ax, ay, ha = op.anchor
                css.append(f"text-anchor: {dict(left='start', right='end', center='middle').get(ha, 'start')}")
                x, y = ax, h - ay
                rot = f' transform="rotate({_num(-op.angle)} {_num(x)} {_num(y)})"' if op.angle else ""
                place = f'x="{_num(x)}" y="{_num(y)}"{rot}'
            else:
                rot = f" rotate({_num(-op.angle)})" if op.angle else ""
                place = f'transform="translate({_num(op.x)} {_num(h - op.y)}){rot}"'
            text = f'<text {place} style="{"; ".join(css)}">{_xml_text(op.text)}</text>'
            clip = clip_attr(op.clip)
            body.append(f" <g{clip}>{text}</g>" if clip else f" {text}")
        elif isinstance(op, ImageOp):
            data = base64.b64encode(_image_png(op.rgba)).decode("ascii")
            opacity = f' opacity="{_num(op.alpha)}"' if op.alpha != 1.0 else ""
            image = (
                f'<image x="{_num(op.x)}" y="{_num(h - op.y - op.height)}" width="{_num(op.width)}" height="{_num(op.height)}"'
                f'{opacity} preserveAspectRatio="none" xlink:href="data:image/png;base64,{data}"/>'
            )
            clip = clip_attr(op.clip)
            body.append(f" <g{clip}>{image}</g>" if clip else f" {image}")
    head = (
        '<?xml version="1.0" encoding="utf-8" standalone="no"?>\n'
        '<!DOCTYPE svg PUBLIC "-//W3C//DTD SVG 1.1//EN"\n  "http://www.w3.org/Graphics/SVG/1.1/DTD/svg11.dtd">\n'
        f'<svg xmlns:xlink="http://www.w3.org/1999/xlink" width="{_num(width_pt)}pt" height="{_num(height_pt)}pt" '
        f'viewBox="0 0 {_num(width_pt)} {_num(height_pt)}" xmlns="http://www.w3.org/2000/svg" version="1.1">\n'
        " <metadata>\n"
        '  <rdf:RDF xmlns:dc="http://purl.org/dc/elements/1.1/" xmlns:cc="http://creativecommons.org/ns#" '
        'xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#">\n'
        '   <cc:Work><dc:type rdf:resource="http://purl.org/dc/dcmitype/StillImage"/><dc:format>image/svg+xml</dc:format>'
        f"<dc:creator><cc:Agent><dc:title>{_xml_text(creator)}</dc:title></cc:Agent></dc:creator></cc:Work>\n"
        "  </rdf:RDF>\n </metadata>\n"
        " <defs>\n  <style type=\"text/css\">*{stroke-linejoin: round; stroke-linecap: butt}</style>\n"
    )
    return (head + "\n".join(defs) + ("\n" if defs else "") + " </defs>\n" + "\n".join(body) + "\n</svg>\n").encode("utf-8")


# --- PDF ---------------------------------------------------------------------------------------------


class _Type3Fonts:
    """The glyphs a page shows, by font file, as Type 3 fonts of up to 256 glyphs each."""

    def __init__(self) -> None:
        self.codes: dict[tuple[str, int], tuple[str, int]] = {}  # (file, glyph) -> (font name, code)
        self.fonts: dict[str, tuple[str, list[tuple[int, str]]]] = {}  # name -> (file, [(glyph, char)])
        self._current: dict[str, str] = {}  # file -> name of its font being filled

    def code(self, fname: str, glyph: int, char: str) -> tuple[str, int]:
        key = (fname, glyph)
        if key not in self.codes:
            name = self._current.get(fname)
            if name is None or len(self.fonts[name][1]) >= GLYPHS_PER_FONT:
                name = f"F{len(self.fonts) + 1}"
                self.fonts[name] = (fname, [])
                self._current[fname] = name
            glyphs = self.fonts[name][1]
            self.codes[key] = (name, len(glyphs))
            glyphs.append((glyph, char))
        return self.codes[key]


class _Layouts:
    """Glyphs of texts as FreeType lays them out (unhinted, at 72 dpi: points), by font and
    text: tick labels and dimensions repeat."""

    def __init__(self) -> None:
        self._fonts: dict = {}
        self._done: dict = {}

    def get(self, prop, text: str) -> tuple[float, list[tuple[str, int, str, float, float, float]]]:
        """``(size, [(font file, glyph, character, x, y, kerning before it)])`` of ``text``."""
        from matplotlib import font_manager as fm

        size = float(prop.get_size_in_points())
        if prop not in self._fonts:
            self._fonts[prop] = fm.findfont(prop)
        key = (self._fonts[prop], size, text)
        if key not in self._done:
            font = fm.get_font(self._fonts[prop])
            font.clear()
            font.set_size(size, 72)
            self._done[key] = [
                (
                    item.ft_object.fname,
                    int(getattr(item, "glyph_index", getattr(item, "glyph_idx", 0))),
                    item.char,
                    float(item.x),
                    float(getattr(item, "y", 0.0)),
                    float(item.prev_kern),
                )
                for item in _glyph_items(font, text)
            ]
        return size, self._done[key]


def _glyph_items(font, text: str) -> list:
    """FreeType's layout of ``text`` (glyphs, positions, kerning), unhinted: ``FT2Font._layout``
    where matplotlib has it (3.11), which does not load each glyph as ``_text_helpers.layout``
    does on top of it; else the latter."""
    from matplotlib import ft2font

    if hasattr(font, "_layout"):
        return list(font._layout(text, ft2font.LoadFlags.NO_HINTING))
    from matplotlib import _text_helpers

    return list(_text_helpers.layout(text, font))


def _pdf_string(s: str) -> str:
    return "(" + s.replace("\\", "\\\\").replace("(", "\\(").replace(")", "\\)") + ")"


def _pdf_color(c: tuple[float, ...]) -> str:
    return " ".join(_num(v) for v in c[:3])


def pdf_bytes(ops: list, width_pt: float, height_pt: float, creator: str = "meshplan") -> bytes:
    """The recorded primitives as a one-page PDF 1.4 of ``width_pt`` x ``height_pt`` points."""
    fonts = _Type3Fonts()
    layouts = _Layouts()
    states: dict[tuple[float, float], str] = {}
    patterns: dict[tuple, str] = {}
    images: list[ImageOp] = []
    out: list[str] = []

    def gstate(stroke_a: float, fill_a: float) -> str:
        key = (round(stroke_a, 4), round(fill_a, 4))
        if key not in states:
            states[key] = f"A{len(states) + 1}"
        return f"/{states[key]} gs"

    def clip(c: Clip | None) -> None:
        if c is None:
            return
        if c.rect is not None:
            x0, y0, x1, y1 = c.rect
            out.append(f"{_num(x0)} {_num(y0)} {_num(x1 - x0)} {_num(y1 - y0)} re W n")
        if c.path is not None:
            v, cc = c.path_arrays()
            out.append(_path_text(v, cc, _PDF_OPS, None) + " W n")

    for op in ops:
        if isinstance(op, PathOp):
            s = op.style
            out.append("q")
            clip(op.clip)
            sa = (s.stroke[3] if s.stroke else 1.0) * (s.alpha if s.alpha is not None else 1.0)
            fa = (s.fill[3] if s.fill else 1.0) * (s.alpha if s.alpha is not None else 1.0)
            if sa != 1.0 or fa != 1.0:
                out.append(gstate(sa, fa))
            fill = s.fill is not None or s.hatch is not None
            if s.hatch is not None:
                key = (s.hatch, s.fill)
                if key not in patterns:
                    patterns[key] = f"H{len(patterns) + 1}"
                out.append(f"/Pattern cs /{patterns[key]} scn")
            elif s.fill is not None:
                out.append(f"{_pdf_color(s.fill)} rg")
            if s.stroke is not None:
                out.append(f"{_pdf_color(s.stroke)} RG {_num(s.linewidth)} w")
                out.append(f"{ {'miter': 0, 'round': 1, 'bevel': 2}.get(s.join, 1)} j { {'butt': 0, 'round': 1, 'projecting': 2}.get(s.cap, 0)} J")
                if s.dashes is not None:
                    out.append(f"[{' '.join(_num(d) for d in s.dashes[1])}] {_num(s.dashes[0])} d")
            paint = ("B" if fill else "S") if s.stroke is not None else ("f" if fill else "n")
            out.append(_path_text(op.vertices, op.codes, _PDF_OPS, None) + " " + paint)
            out.append("Q")
        elif isinstance(op, TextOp):
            size, items = layouts.get(op.prop, op.text)
            if not items:
                continue
            out.append("q")
            clip(op.clip)
            a = op.alpha if op.alpha is not None else op.color[3]
            if a != 1.0:
                out.append(gstate(a, a))
            r = math.radians(op.angle)
            cos, sin = math.cos(r), math.sin(r)
            out.append(f"{_pdf_color(op.color)} rg {_num(cos)} {_num(sin)} {_num(-sin)} {_num(cos)} {_num(op.x)} {_num(op.y)} cm BT")
            run: list[str] = []
            name = None
            start = 0.0
            for fname, glyph, char, x, y, kern in items:
                fid, code = fonts.code(fname, glyph, char)
                if fid != name or y:
                    if run:
                        out.append(f"[{' '.join(run)}] TJ")
                        run = []
                    out.append(f"/{fid} {_num(size)} Tf {_num(x - start)} {_num(y)} Td")
                    if y:
                        start, name = x, None
                        # a glyph raised or lowered: placed on its own, then the baseline back
                        out.append(f"<{code:02x}> Tj 0 {_num(-y)} Td")
                        continue
                    start, name = x, fid
                elif kern:
                    run.append(_num(-1000.0 * kern / size))
                run.append(f"<{code:02x}>")
            if run:
                out.append(f"[{' '.join(run)}] TJ")
            out.append("ET Q")
        elif isinstance(op, ImageOp):
            images.append(op)
            out.append("q")
            clip(op.clip)
            if op.alpha != 1.0:
                out.append(gstate(op.alpha, op.alpha))
            out.append(f"{_num(op.width)} 0 0 {_num(op.height)} {_num(op.x)} {_num(op.y)} cm /I{len(images)} Do Q")

    # objects: 1 catalog, 2 pages, 3 page, 4 contents, 5 info; then fonts, images, patterns
    objects: dict[int, bytes] = {}
    n = [5]

    def new(data: bytes | None = None) -> int:
        n[0] += 1
        if data is not None:
            objects[n[0]] = data
        return n[0]

    def stream(head: str, data: bytes) -> bytes:
        if len(data) > _MIN_COMPRESSED:
            data = zlib.compress(data, ZLIB_LEVEL)
            head += " /Filter /FlateDecode"
        return f"<< {head} /Length {len(data)} >>\nstream\n".encode("latin-1") + data + b"\nendstream"

    font_refs = {}
    for name, (fname, glyphs) in fonts.fonts.items():
        font_refs[name] = _type3_font(fname, glyphs, new, stream)
    image_refs = []
    for im in images:
        rows, cols = im.rgba.shape[:2]
        colour = single_colour(im.rgba)
        if colour is None:
            rgb, w, h = np.ascontiguousarray(im.rgba[..., :3]).tobytes(), cols, rows
        else:  # one colour (the ink raster): one pixel of it, under the full-size soft mask
            rgb, w, h = colour.tobytes(), 1, 1
        smask = ""
        if (im.rgba[..., 3] != 255).any():
            sm = new(stream(f"/Type /XObject /Subtype /Image /Width {cols} /Height {rows} /ColorSpace /DeviceGray /BitsPerComponent 8",
                            np.ascontiguousarray(im.rgba[..., 3]).tobytes()))
            smask = f" /SMask {sm} 0 R"
        image_refs.append(new(stream(f"/Type /XObject /Subtype /Image /Width {w} /Height {h} /ColorSpace /DeviceRGB /BitsPerComponent 8{smask}", rgb)))
    pattern_refs = {}
    for (hatch, face), name in patterns.items():
        pattern, color, lw = hatch
        t = HATCH_TILE_PT
        hp = Path.hatch(pattern, 6.0).cleaned(curves=True)
        body = "q "
        if face is not None:
            body += f"{_pdf_color(face)} rg 0 0 {_num(t)} {_num(t)} re f "
        body += f"{_pdf_color(color)} RG {_pdf_color(color)} rg {_num(lw)} w 0 J 0 j "
        body += _path_text(hp.vertices[:-1] * t, hp.codes[:-1], _PDF_OPS, None) + " S Q"
        pattern_refs[name] = new(stream(f"/PatternType 1 /PaintType 1 /TilingType 1 /BBox [0 0 {_num(t)} {_num(t)}] "
                                        f"/XStep {_num(t)} /YStep {_num(t)} /Resources << >>", body.encode("latin-1")))
    res = ["/ProcSet [/PDF /Text /ImageB /ImageC]"]
    if font_refs:
        res.append("/Font << " + " ".join(f"/{k} {v} 0 R" for k, v in font_refs.items()) + " >>")
    if image_refs:
        res.append("/XObject << " + " ".join(f"/I{i + 1} {r} 0 R" for i, r in enumerate(image_refs)) + " >>")
    if states:
        res.append("/ExtGState << " + " ".join(f"/{v} << /Type /ExtGState /CA {_num(k[0])} /ca {_num(k[1])} >>" for k, v in states.items()) + " >>")
    if pattern_refs:
        res.append("/Pattern << " + " ".join(f"/{k} {v} 0 R" for k, v in pattern_refs.items()) + " >>")
    objects[1] = b"<< /Type /Catalog /Pages 2 0 R >>"
    objects[2] = b"<< /Type /Pages /Kids [3 0 R] /Count 1 >>"
    objects[3] = (f"<< /Type /Page /Parent 2 0 R /MediaBox [0 0 {_num(width_pt)} {_num(height_pt)}] "
                  f"/Resources << {' '.join(res)} >> /Contents 4 0 R >>").encode("latin-1")
    objects[4] = stream("", "\n".join(out).encode("latin-1"))
    objects[5] = f"<< /Creator {_pdf_string(creator)} /Producer {_pdf_string(creator)} >>".encode("latin-1")
    chunks = [b"%PDF-1.4\n%\xac\xdc \xab\xba\n"]
    offsets = {}
    pos = len(chunks[0])
    for i in sorted(objects):
        data = f"{i} 0 obj\n".encode("latin-1") + objects[i] + b"\nendobj\n"
        offsets[i] = pos
        chunks.append(data)
        pos += len(data)
    count = max(objects) + 1
    xref = [f"xref\n0 {count}\n0000000000 65535 f \n"] + [f"{offsets[i]:010d} 00000 n \n" for i in range(1, count)]
    chunks.append("".join(xref).encode("latin-1"))
    chunks.append(f"trailer\n<< /Size {count} /Root 1 0 R /Info 5 0 R >>\nstartxref\n{pos}\n%%EOF\n".encode("latin-1"))
    return b"".join(chunks)


def _type3_font(fname: str, glyphs: list[tuple[int, str]], new, stream) -> int:
    """A Type 3 font of ``glyphs`` ``(glyph index, character)`` of the font file ``fname``, codes
    0, 1, ... in order, with a ToUnicode map; returns its object number."""
    from matplotlib import font_manager as fm
    from matplotlib import ft2font

    font = fm.get_font(fname)
    conv = 1000.0 / font.units_per_EM  # glyph space: thousandths of the em
    procs, widths, names = [], [], []
    lo = np.array([np.inf, np.inf])
    hi = -lo
    for k, (glyph, _) in enumerate(glyphs):
        g = font.load_glyph(cast(Any, glyph), ft2font.LoadFlags.NO_SCALE)
        bbox = [math.floor(g.bbox[0] * conv), math.floor(g.bbox[1] * conv), math.ceil(g.bbox[2] * conv), math.ceil(g.bbox[3] * conv)]
        advance = round(g.horiAdvance * conv)
        v, c = font.get_path()
        v = np.round(np.asarray(v, dtype=np.float64) * 64 * conv)
        drawing = _path_text(v, np.asarray(c, dtype=np.uint8), _PDF_OPS, None) if len(c) else ""
        proc = f"{advance} 0 {bbox[0]} {bbox[1]} {bbox[2]} {bbox[3]} d1\n{drawing} f".encode("latin-1")
        procs.append(new(stream("", proc)))
        widths.append(advance)
        names.append(f"g{k}")
        lo = np.minimum(lo, bbox[:2])
        hi = np.maximum(hi, bbox[2:])
    cmap = (
        "/CIDInit /ProcSet findresource begin\n12 dict begin\nbegincmap\n"
        "/CIDSystemInfo << /Registry (Adobe) /Ordering (UCS) /Supplement 0 >> def\n"
        "/CMapName /Adobe-Identity-UCS def\n/CMapType 2 def\n1 begincodespacerange\n<00> <ff>\nendcodespacerange\n"
        + "".join(
            f"{len(chunk)} beginbfchar\n" + "".join(f"<{i:02x}> <{''.join(f'{u:04x}' for u in _utf16(ch))}>\n" for i, ch in chunk) + "endbfchar\n"
            for chunk in _chunks([(i, ch) for i, (_, ch) in enumerate(glyphs)], 100)
        )
        + "endcmap\nCMapName currentdict /CMap defineresource pop\nend\nend"
    )
    to_unicode = new(stream("", cmap.encode("latin-1")))
    bbox_all = " ".join(str(int(v)) for v in (*lo, *hi)) if len(glyphs) else "0 0 0 0"
    procs_dict = " ".join(f"/{nm} {p} 0 R" for nm, p in zip(names, procs))
    return new(
        (
            f"<< /Type /Font /Subtype /Type3 /Name /{_ps_name(fname)} /FontBBox [{bbox_all}] /FontMatrix [0.001 0 0 0.001 0 0] "
            f"/CharProcs << {procs_dict} >> /Encoding << /Type /Encoding /Differences [0 {' '.join('/' + nm for nm in names)}] >> "
            f"/FirstChar 0 /LastChar {len(glyphs) - 1} /Widths [{' '.join(map(str, widths))}] /Resources << >> "
            f"/ToUnicode {to_unicode} 0 R >>"
        ).encode("latin-1")
    )


def _ps_name(fname: str) -> str:
    import os

    stem = os.path.splitext(os.path.basename(fname))[0]
    return "".join(ch for ch in stem if ch.isalnum() or ch in "-_") or "Font"


def _utf16(ch: str) -> list[int]:
    b = ch.encode("utf-16-be")
    return [int.from_bytes(b[i : i + 2], "big") for i in range(0, len(b), 2)]


def _chunks(items: list, size: int) -> Iterable[list]:
    for i in range(0, len(items), size):
        yield items[i : i + size]


# --- a figure's files ----------------------------------------------------------------------------------


class PlanCanvas(FigureCanvasAgg):
    """An Agg canvas whose renderer is a :class:`PlanRenderer`. The texts a plan measures while
    it is built (:class:`meshplan.render.placement.Placer`) and those it draws are then measured
    by one renderer, and matplotlib's text metrics, cached per renderer, are computed once."""

    def get_renderer(self):
        # docstring inherited
        w, h = self.get_width_height(physical=True)
        key = w, h, self.figure.dpi
        if self._lastKey != key or not isinstance(getattr(self, "renderer", None), PlanRenderer):
            self.renderer = PlanRenderer(w, h, self.figure.dpi)
            self._lastKey = key
        return self.renderer


def draw(fig, raster: bool = True) -> PlanRenderer:
    """Draw ``fig`` once on its canvas's :class:`PlanRenderer` (painting the pixels too when
    ``raster``) and return the renderer."""
    canvas = fig.canvas if isinstance(fig.canvas, PlanCanvas) else PlanCanvas(fig)
    renderer = canvas.get_renderer()
    renderer.begin(raster)
    fig.draw(renderer)
    return renderer


def figure_files(fig, fmts: Iterable[str], metadata_creator: str = "meshplan") -> dict[str, bytes]:
    """``format -> bytes`` of ``fig`` in each of ``fmts`` (png, svg, pdf), drawn once.

    The PNG holds the Agg drawing's pixels; the SVG and PDF its primitives
    (:func:`svg_bytes`, :func:`pdf_bytes`). A figure drawing what those do not write is
    saved in its vector formats by matplotlib instead (:class:`Unsupported`)."""
    import matplotlib

    from .sheet import _RC

    fmts = tuple(fmts)
    out: dict[str, bytes] = {}
    with matplotlib.rc_context(_RC):
        r: RendererAgg | None = None
        ops: list | None = None
        if not set(fmts) - {"png"}:  # pixels alone: nothing to record
            r = draw_raster_only(fig)
        else:
            try:
                drawn = draw(fig, raster="png" in fmts)
                r, ops = drawn, drawn.ops
            except Unsupported:
                if "png" in fmts:
                    r = draw_raster_only(fig)
        w_pt, h_pt = (float(v) * 72.0 for v in fig.get_size_inches())
        for fmt in fmts:
            if fmt == "png":
                assert r is not None
                out[fmt] = png_bytes(np.asarray(r.buffer_rgba()), fig.dpi, metadata_creator)
            elif ops is None:
                out[fmt] = _matplotlib_bytes(fig, fmt)
            elif fmt == "svg":
                out[fmt] = svg_bytes(ops, w_pt, h_pt, metadata_creator)
            elif fmt == "pdf":
                out[fmt] = pdf_bytes(ops, w_pt, h_pt, metadata_creator)
            else:
                raise ValueError(f"unknown format {fmt!r}")
    return out


def draw_raster_only(fig) -> RendererAgg:
    """The pixels alone of a figure (for its PNG alone, or one the recorder cannot follow): a
    plain Agg drawing, on the figure's own Agg renderer unless that is a recorder."""
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    if isinstance(canvas, PlanCanvas):
        w, h = canvas.get_width_height(physical=True)
        renderer = RendererAgg(w, h, fig.dpi)
        fig.draw(renderer)
        return renderer
    canvas.draw()
    return canvas.get_renderer()


def _matplotlib_bytes(fig, fmt: str) -> bytes:
    import io

    meta = {"svg": {"Date": None, "Creator": "meshplan"}, "pdf": {"CreationDate": None, "Creator": "meshplan", "Producer": "meshplan"}}[fmt]
    buf = io.BytesIO()
    fig.savefig(buf, format=fmt, metadata=meta)
    return buf.getvalue()

"""Drawing sheets: plans at a stated scale, seen from above (x to the right, z down the page).

Every plan of a story is drawn on the same :class:`Sheet`, so the pen-and-ink plan, the drafting
plan and the segment drawing line up when overlaid. Figures are made with matplotlib's object
API (no pyplot, no global state) and rendered to bytes; writing them is the export stage's job.

Why one long module: the sheet (page, scale, title block, north arrow, scale bar, legend,
annotations, the raster's placement) is shared by every drawing; its pieces are small and share
the page's geometry.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..geometry import ANNOTATION_PROBE_M
from ..units import FOOT_M, INCH_M
from ..validation import PLAIN_TEXT_KW, plain_text
from .params import AUTO_PAPER_IMPERIAL, AUTO_PAPER_METRIC, PAPER_SIZES_IN, STANDARD_SCALES, RenderParams

if TYPE_CHECKING:
    from matplotlib.typing import RcKeyType


#: Space around the drawing area, in inches: left, right, top, bottom (the bottom holds the
#: strip with the scale bar, north arrow, legend and title block).
_MARGINS_IN = (0.75, 0.35, 0.6, 1.75)
#: Height of that strip and narrowest page (inches): the title block and legend need room.
_STRIP_IN = 1.45
_MIN_PAGE_W_IN = 10.5
#: Paper kept around the building for the dimension chains (metres of paper on each side):
#: three chains at 8, 14 and 20 mm, their text and a little air.
DIMENSION_MARGIN_PAPER_M = 0.026
#: Largest drawing (model extent / scale) the automatic scale aims for, in metres of paper.
_MAX_PAPER_M = 0.30
#: Largest raster side in pixels; huge buildings get a coarser raster rather than run out of memory.
_MAX_PIXELS = 8000
#: Largest drawing a forced ``--scale`` may make, in metres of paper along its longer side: the
#: widest plotter rolls are about 1.5 m, so beyond 5 m the scale is a mistake (1:10 for a
#: 100 m building), and the vector files and figures would grow with the page.
MAX_PAGE_M = 5.0

#: Marker of each annotation kind (all drawn in red).
KIND_MARKERS = {"sensor": "o", "thermostat": "s", "door": "D", "window": "^", "other": "*"}
ANNOTATION_COLOR = "#d62728"


@dataclass(frozen=True)
class Sheet:
    """The model area drawn and the scale it is drawn at.

    Attributes
    ----------
    xmin, xmax, zmin, zmax
        Model extent shown (metres, plan frame).
    scale
        1:``scale``: one metre of model is ``1/scale`` metres of paper.
    dpi
        Raster resolution (pixels per inch of paper).
    paper, page_in
        The standard paper (``A3``, ``Letter`` ...) and its page (width, height in inches, in
        the orientation used); ``""`` and ``None`` for a page fitted around the drawing.
    """

    xmin: float
    xmax: float
    zmin: float
    zmax: float
    scale: int
    dpi: int
    paper: str = ""
    page_in: tuple[float, float] | None = None

    @property
    def drawing_in(self) -> tuple[float, float]:
        """Width and height of the drawing on paper (inches)."""
        return self.width_m / self.scale / INCH_M, self.depth_m / self.scale / INCH_M

    @property
    def width_m(self) -> float:
        return self.xmax - self.xmin

    @property
    def depth_m(self) -> float:
        return self.zmax - self.zmin

    @property
    def pixel_m(self) -> float:
        """Model size of one output pixel."""
        return self.scale * INCH_M / self.dpi

    @property
    def raster_shape(self) -> tuple[int, int]:
        """(rows along z, columns along x) of the ink raster."""
        p = self.pixel_m
        return max(1, int(np.ceil(self.depth_m / p))), max(1, int(np.ceil(self.width_m / p)))


def make_sheet(points_xz: np.ndarray, params: RenderParams, margin_m: float = 0.5) -> Sheet:
    """A sheet covering the points (robustly: 0.2 % outliers ignored) with a margin."""
    pts = np.asarray(points_xz, dtype=np.float64).reshape(-1, 2)
    if len(pts) == 0:
        lo, hi = np.zeros(2), np.ones(2)
    else:
        lo = np.quantile(pts, 0.001, axis=0)
        hi = np.quantile(pts, 0.999, axis=0)
    lo, hi = lo - margin_m, hi + margin_m
    longest = float(max(hi - lo))
    scale = params.scale
    if scale == 0:
        scale = next((s for s in STANDARD_SCALES if longest / s <= _MAX_PAPER_M), STANDARD_SCALES[-1])
    elif longest / scale > MAX_PAGE_M:
        from ..errors import ParameterError

        fits = next((s for s in STANDARD_SCALES if longest / s <= MAX_PAGE_M), STANDARD_SCALES[-1])
        raise ParameterError(
            f"scale 1:{scale} draws this {longest:.0f} m story on a {longest / scale:.1f} m page (at most {MAX_PAGE_M:g} m)",
            f"pass --scale {fits} or larger, or 0 for the automatic scale",
        )
    paper, page = "", None
    if params.sheet != "fit":
        scale, paper, page = _paper(lo, hi, scale, params)
    # room outside the building for the dimension chains, in paper millimetres at this scale
    lo, hi = lo - DIMENSION_MARGIN_PAPER_M * scale, hi + DIMENSION_MARGIN_PAPER_M * scale
    longest = float(max(hi - lo))
    # huge sheets (a forced small scale) get fewer dots per inch rather than exhaust memory
    dpi = min(params.dpi, max(30, int(_MAX_PIXELS * scale * INCH_M / longest)))
    return Sheet(float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1]), int(scale), dpi, paper, page)


def _fits(extent_m: np.ndarray, scale: int, page: tuple[float, float]) -> bool:
    """Whether a model extent (without the dimension margin) drawn at 1:``scale`` fits the page
    inside its margins and above its strip."""
    w, h = (extent_m + 2 * DIMENSION_MARGIN_PAPER_M * scale) / scale / INCH_M
    left, right, top, bottom = _MARGINS_IN
    return page[0] >= _MIN_PAGE_W_IN and w + left + right <= page[0] and h + top + bottom <= page[1]


def _orientations(name: str) -> list[tuple[float, float]]:
    """A paper's pages, landscape first."""
    a, b = sorted(PAPER_SIZES_IN[name])
    return [(b, a), (a, b)]


def _paper(lo: np.ndarray, hi: np.ndarray, scale: int, params: RenderParams) -> tuple[int, str, tuple[float, float]]:
    """The scale, paper and page of a standard sheet (``params.sheet``) for a model extent: for
    ``auto`` the smallest paper that holds the drawing at the scale; for a named paper with the
    automatic scale the automatic scale or the next smaller standard one that fits it.

    Raises
    ------
    ParameterError
        When a named paper cannot hold the drawing at the scale asked for (or at any standard
        scale), or no standard paper holds it for ``auto``.
    """
    from ..errors import ParameterError

    extent = np.asarray(hi - lo, dtype=np.float64)
    if params.sheet == "auto":
        names = AUTO_PAPER_IMPERIAL if params.imperial else AUTO_PAPER_METRIC
        for name in names:
            for page in _orientations(name):
                if _fits(extent, scale, page):
                    return scale, name, page
        raise ParameterError(
            f"the plan at 1:{scale} fits none of the papers {', '.join(names)}", "pass a smaller scale (a larger --scale N), or --sheet fit"
        )
    name = params.sheet
    scales = [scale] if params.scale else [s for s in STANDARD_SCALES if s >= scale]
    for s in scales:
        for page in _orientations(name):
            if _fits(extent, s, page):
                return s, name, page
    raise ParameterError(
        f"the plan does not fit on {name} at 1:{scales[0]}" + ("" if params.scale else " or any smaller standard scale"),
        "pass a larger paper, --sheet auto, or a larger --scale N",
    )


def new_figure(sheet: Sheet, title: str, params: RenderParams):
    """A figure whose axes show the sheet's model area at exactly its scale, z down the page."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import FuncFormatter

    w_in, h_in = sheet.drawing_in
    left, right, top, bottom = _MARGINS_IN
    if sheet.page_in is None:
        fw, fh = max(w_in + left + right, _MIN_PAGE_W_IN), h_in + top + bottom
        x0, y0 = left, bottom
    else:  # a standard paper: the drawing centred in the room above the strip
        fw, fh = sheet.page_in
        x0 = left + 0.5 * max(fw - left - right - w_in, 0.0)
        y0 = bottom + 0.5 * max(fh - top - bottom - h_in, 0.0)
    fig = Figure(figsize=(fw, fh), dpi=sheet.dpi)
    ax = fig.add_axes((x0 / fw, y0 / fh, w_in / fw, h_in / fh))
    ax.set_zorder(2)  # the plan's lines and texts above a raster placed on the figure
    ax.set_xlim(sheet.xmin, sheet.xmax)
    ax.set_ylim(sheet.zmax, sheet.zmin)  # z down the page
    ax.set_aspect("equal", adjustable="box")
    if params.imperial:
        from matplotlib.ticker import MultipleLocator

        step = FOOT_M * nice_length(max(sheet.width_m, sheet.depth_m) / FOOT_M / 6.0)
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_major_locator(MultipleLocator(step))
            axis.set_major_formatter(FuncFormatter(lambda v, _: format_feet_inches(v)))
    else:
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    for s in ax.spines.values():
        s.set_linewidth(0.4)
        s.set_color(_SPINE_COLOR)
    ax.set_xlabel(f"x ({'ft' if params.imperial else 'm'})", fontsize=_TICK_LABEL_PT, color=_TICK_COLOR, labelpad=_AXIS_LABEL_PAD_PT)
    ax.set_ylabel(f"z ({'ft' if params.imperial else 'm'})", fontsize=_TICK_LABEL_PT, color=_TICK_COLOR, labelpad=_AXIS_LABEL_PAD_PT)
    _static_ticks(ax)
    fig.text(left / fw, 1 - 0.18 / fh, title, fontsize=9, va="top", ha="left", weight="bold")
    fig.text(
        left / fw,
        1 - 0.36 / fh,
        f"Scale 1:{sheet.scale} on {_paper_name(sheet)}",
        fontsize=6,
        va="top",
        ha="left",
        color="#555555",
    )
    return fig, ax


#: The sheet's coordinate ticks: marks 2 points long and 0.4 wide outside the drawing, labels
#: of 6 points 3.5 points beyond them (matplotlib's default pad), the axis names 1 point
#: beyond the labels; grey, as the frame.
_TICK_LENGTH_PT = 2.0
_TICK_WIDTH_PT = 0.4
_TICK_PAD_PT = 3.5
_TICK_LABEL_PT = 6.0
_AXIS_LABEL_PAD_PT = 1.0
_TICK_COLOR = "#555555"
_SPINE_COLOR = "#999999"


def _static_ticks(ax) -> None:
    """The sheet's coordinate ticks drawn as one line of tick marks and a text per label, each
    axis's name placed beyond them, where matplotlib's own ticks were (the same marks, texts,
    transforms and distances; the PNG pixel for pixel).

    matplotlib's ticks are objects of two lines and two texts each, made anew at every drawing
    with their positions, and the axis names placed after measuring every label: about a sixth
    of a drafting plan's drawing time. The plan's limits are fixed once the figure is made, so
    the ticks are worked out once, here. The labels are tagged ``tick-label``.
    """
    from matplotlib.lines import Line2D
    from matplotlib.markers import MarkerStyle
    from matplotlib.ticker import NullLocator
    from matplotlib.transforms import Bbox, ScaledTranslation

    from .placement import renderer_of, tag

    fig = ax.figure
    renderer = renderer_of(fig)
    ax.apply_aspect()  # the frame where it is drawn (the ticks' number follows its length)
    pad = (_TICK_PAD_PT + _TICK_LENGTH_PT) / 72.0  # from the frame to the labels (inches)
    # the marks as matplotlib's ticks out of the frame: TICKDOWN (3) below, TICKLEFT (0) left
    specs = (
        (ax.xaxis, ax.get_xaxis_transform(), MarkerStyle(3), ScaledTranslation(0.0, -pad, fig.dpi_scale_trans), dict(ha="center", va="top")),
        (ax.yaxis, ax.get_yaxis_transform(), MarkerStyle(0), ScaledTranslation(-pad, 0.0, fig.dpi_scale_trans), dict(ha="right", va="center_baseline")),
    )
    for axis, along, marker, shift, align in specs:
        locs = np.asarray(axis.get_majorticklocs(), dtype=np.float64)
        labels = axis.major.formatter.format_ticks(locs)
        lo, hi = sorted(axis.get_view_interval())
        tol = 1e-10 * (hi - lo)  # matplotlib's: ticks at the limits up to rounding are drawn
        shown = [(v, t) for v, t in zip(locs.tolist(), labels) if lo - tol <= v <= hi + tol]
        axis.set_major_locator(NullLocator())
        xy = ([v for v, _ in shown], [0.0] * len(shown))
        line = Line2D(*(xy if axis is ax.xaxis else xy[::-1]), transform=along, marker=marker, markersize=_TICK_LENGTH_PT,
                      markeredgewidth=_TICK_WIDTH_PT, color=_TICK_COLOR, markeredgecolor=_TICK_COLOR, linestyle="none", zorder=1.5, clip_on=False)  # fmt: skip
        ax.add_line(line)
        texts = []
        for v, t in shown:
            x, y = (v, 0.0) if axis is ax.xaxis else (0.0, v)
            texts.append(tag(ax.text(x, y, t, transform=along + shift, fontsize=_TICK_LABEL_PT, color=_TICK_COLOR, zorder=1.5, **align), "tick-label"))
        # the axis name beyond the labels and the frame, as matplotlib places it
        spine = ax.spines["bottom" if axis is ax.xaxis else "left"].get_window_extent(renderer)
        box = Bbox.union([*(t.get_window_extent(renderer) for t in texts), spine])
        frame = ax.transAxes.transform([(0.0, 0.0)])[0]
        if axis is ax.xaxis:
            beyond = (frame[1] - box.y0) / fig.dpi + _AXIS_LABEL_PAD_PT / 72.0
            axis.set_label_coords(0.5, 0.0, transform=ax.transAxes + ScaledTranslation(0.0, -beyond, fig.dpi_scale_trans))
        else:
            beyond = (frame[0] - box.x0) / fig.dpi + _AXIS_LABEL_PAD_PT / 72.0
            axis.set_label_coords(0.0, 0.5, transform=ax.transAxes + ScaledTranslation(-beyond, 0.0, fig.dpi_scale_trans))


def _paper_name(sheet: Sheet) -> str:
    """``A3 landscape (420 x 297 mm)``, ``Letter portrait (8.5 x 11 in)``, or the fitted page."""
    if sheet.page_in is None:
        w, h = sheet.drawing_in
        left, right, top, bottom = _MARGINS_IN
        return f"a {max(w + left + right, _MIN_PAGE_W_IN):.1f} x {h + top + bottom:.1f} in page"
    w, h = sheet.page_in
    way = "landscape" if w > h else "portrait"
    if sheet.paper.startswith("A"):
        return f"{sheet.paper} {way} ({w * 25.4:.0f} x {h * 25.4:.0f} mm)"
    return f"{sheet.paper} {way} ({w:g} x {h:g} in)"


def place_raster(fig, ax, rgba: np.ndarray) -> None:
    """Put a raster made at the sheet's pixel size over the axes, pixel for pixel (no
    resampling: the raster is exactly what the PNG shows)."""
    from .raster import SheetImage

    dpi = fig.dpi
    pos = ax.get_position()
    h_px = pos.height * fig.get_figheight() * dpi
    x0, y0 = pos.x0 * fig.get_figwidth() * dpi, pos.y0 * fig.get_figheight() * dpi
    # what Figure.figimage does, with an image that skips the resampling (see .raster)
    im = SheetImage(fig, offsetx=int(round(x0)), offsety=int(round(y0 + h_px - rgba.shape[0])), origin="upper", zorder=1)
    im.set_array(rgba)
    im.set_alpha(None)
    im.set_clim(None, None)
    fig.images.append(im)
    im._remove_method = fig.images.remove  # type: ignore[attr-defined]  # an Artist attribute the stubs omit
    fig.stale = True


def nice_length(target: float) -> float:
    """The 1-2-5 number closest below ``target``."""
    if target <= 0:
        return 1.0
    exp = np.floor(np.log10(target))
    for m in (5, 2, 1):
        if m * 10**exp <= target:
            return float(m * 10**exp)
    return float(10**exp)


def format_feet_inches(m: float) -> str:
    """A length in feet and inches, as architects write it: ``12'-6"`` (to the nearest inch)."""
    inches = int(round(abs(m) / INCH_M))
    sign = "-" if m < 0 and inches else ""
    return f"{sign}{inches // 12}'-{inches % 12}\""


def draw_scale_bar(fig, sheet: Sheet, params: RenderParams) -> None:
    """A scale bar in metres (or feet) in the strip below the drawing, four alternating blocks."""
    from matplotlib.patches import Rectangle

    unit, name = (FOOT_M, "ft") if params.imperial else (1.0, "m")
    # at most 2.8 in of paper: the strip holds the north arrow and the legend beside it
    total = nice_length(min(sheet.width_m / 3.0, 2.8 * INCH_M * sheet.scale) / unit)
    left = _MARGINS_IN[0]
    fw = fig.get_figwidth()
    fh = fig.get_figheight()
    w_in = total * unit / sheet.scale / INCH_M
    ax = fig.add_axes((left / fw, 0.55 / fh, w_in / fw, 0.07 / fh))
    ax.set_xlim(0, total)
    ax.set_ylim(0, 1)
    ax.axis("off")
    for i in range(4):
        ax.add_patch(
            Rectangle((i * total / 4, 0), total / 4, 1, facecolor="black" if i % 2 == 0 else "white", edgecolor="black", linewidth=0.5)
        )
    for v in (0, total / 2, total):
        ax.text(v, 1.6, f"{v:g}", ha="center", va="bottom", fontsize=6)
    ax.text(total * 1.04, 0.5, name, ha="left", va="center", fontsize=6)
    ax.text(0, -1.2, f"SCALE 1:{sheet.scale}", ha="left", va="top", fontsize=6.5, weight="bold")


def draw_north_arrow(fig, north_deg: float = 0.0) -> None:
    """A north arrow in the strip below the drawing. ``north_deg`` is the compass bearing of
    up the page (plan -z): north is that many degrees counter-clockwise from up."""
    from matplotlib.patches import Circle, Polygon

    fw, fh = fig.get_figwidth(), fig.get_figheight()
    size = 0.62  # inches
    x0 = _MARGINS_IN[0] + 3.05
    ax = fig.add_axes((x0 / fw, 0.32 / fh, size / fw, size / fh))
    ax.set_xlim(-1, 1)
    ax.set_ylim(-1, 1)
    ax.set_aspect("equal")
    ax.axis("off")
    t = np.radians(north_deg)
    rot = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])  # counter-clockwise on the page
    ax.add_patch(Circle((0, 0), 0.62, fill=False, lw=0.6, color="black"))
    tip, left, right, tail = (rot @ np.array(v) for v in ((0, 0.78), (-0.25, -0.45), (0.25, -0.45), (0, -0.2)))
    ax.add_patch(Polygon([tip, left, tail], closed=True, facecolor="black", edgecolor="black", lw=0.5))
    ax.add_patch(Polygon([tip, right, tail], closed=True, facecolor="white", edgecolor="black", lw=0.5))
    n = rot @ np.array([0, 0.98])
    ax.text(n[0], n[1], "N", ha="center", va="center", fontsize=7.5, weight="bold")


def sheet_date() -> str:
    """The date written in title blocks: ``SOURCE_DATE_EPOCH`` (the reproducible-builds
    convention) when set, else today."""
    import datetime
    import os

    epoch = os.environ.get("SOURCE_DATE_EPOCH", "")
    if epoch.strip().isdigit():
        return datetime.datetime.fromtimestamp(int(epoch), tz=datetime.UTC).date().isoformat()
    return datetime.date.today().isoformat()


def draw_title_block(fig, sheet: Sheet, params: RenderParams, drawing: str, story: str, scan: str = "") -> None:
    """The title block at the bottom right: scan, drawing, story, scale, units, date and the
    meshplan version, as rows of a ruled box."""
    from matplotlib.patches import Rectangle

    from .._version import __version__

    fw, fh = fig.get_figwidth(), fig.get_figheight()
    w, h = 3.1, 1.2
    x0 = fw - _MARGINS_IN[1] - w
    ax = fig.add_axes((x0 / fw, 0.18 / fh, w / fw, h / fh))
    ax.set_xlim(0, w)
    ax.set_ylim(0, h)
    ax.axis("off")
    ax.add_patch(Rectangle((0, 0), w, h, fill=False, lw=1.0, color="black"))
    units = "feet and inches, ft²" if params.imperial else "metres, m²"
    rows = [
        ("SCAN", plain_text(scan) or "-"),
        ("DRAWING", drawing),
        ("STORY", story),
        ("SCALE", f"1:{sheet.scale}"),
        ("UNITS", units),
        ("DATE", sheet_date()),
        ("BY", f"meshplan {__version__}"),
    ]
    step = h / len(rows)
    for k, (key, value) in enumerate(rows):
        y = h - (k + 0.5) * step
        if k:
            ax.plot([0, w], [h - k * step] * 2, lw=0.3, color="#777777")
        ax.text(0.06, y, key, fontsize=5, color="#555555", va="center", ha="left")
        ax.text(0.72, y, value[:60], fontsize=6.3 if k else 6.8, va="center", ha="left", weight="bold" if k < 2 else "normal", **PLAIN_TEXT_KW)
    ax.plot([0.66, 0.66], [0, h], lw=0.3, color="#777777")


def draw_legend(fig, handles: list, labels: list[str]) -> None:
    """The legend in the strip, between the north arrow and the title block."""
    if not handles:
        return
    fw, fh = fig.get_figwidth(), fig.get_figheight()
    x0 = _MARGINS_IN[0] + 3.8
    x1 = fw - _MARGINS_IN[1] - 3.25
    ncol = max(1, min(3, int((x1 - x0) / 1.05), (len(handles) + 4) // 5))
    fig.legend(
        handles,
        labels,
        loc="lower left",
        bbox_to_anchor=(x0 / fw, 0.16 / fh),
        fontsize=5.5,
        ncol=ncol,
        frameon=False,
        handlelength=2.2,
        handleheight=1.1,
        borderaxespad=0.0,
        columnspacing=1.0,
        title="LEGEND",
        title_fontsize=6,
        alignment="left",
    )


#: Where an annotation's label goes around its marker (offset in points, alignment), in order.
_LABEL_SPOTS = (
    ((3, 3), "left", "bottom"),
    ((3, -3), "left", "top"),
    ((-3, 3), "right", "bottom"),
    ((-3, -3), "right", "top"),
    ((5, 0), "left", "center"),
    ((-5, 0), "right", "center"),
    ((0, 5), "center", "bottom"),
    ((0, -5), "center", "top"),
    ((9, 9), "left", "bottom"),
    ((-9, -9), "right", "top"),
)
#: Annotations are drawn above everything in the plan.
ANNOTATION_ZORDER = 20


def annotation_obstacles(positions, directions, probe_m: float = ANNOTATION_PROBE_M, marker_m: float = 0.06) -> list:
    """The annotation markers (a small box each) and probe arrows, as shapely geometries in
    the plan, for texts to keep clear of."""
    import shapely

    out = []
    pos = np.asarray(positions).reshape(-1, 3)
    dirs = np.asarray(directions).reshape(-1, 3)
    for i in range(len(pos)):
        x, z = pos[i, 0], pos[i, 2]
        out.append(shapely.box(x - marker_m, z - marker_m, x + marker_m, z + marker_m))
        d = dirs[i]
        if np.all(np.isfinite(d)) and np.hypot(d[0], d[2]) > 1e-6:
            n = np.hypot(d[0], d[2])
            out.append(shapely.LineString([(x, z), (x + probe_m * d[0] / n, z + probe_m * d[2] / n)]))
    return out


def draw_annotations(ax, labels, kinds, positions, directions, probe_m: float = ANNOTATION_PROBE_M, placer=None, legend: bool = True) -> list:
    """Annotated objects as red markers with their labels (on a white halo) and probe
    directions, above everything; with a :class:`meshplan.render.placement.Placer` each label
    goes where it covers no other text or line. Returns the legend handles (one per kind)."""
    from matplotlib.transforms import ScaledTranslation

    from .placement import tag, with_halo

    if not len(labels):
        return []
    pos = np.asarray(positions)
    dirs = np.asarray(directions)
    seen = set()
    for i, (label, kind) in enumerate(zip(labels, kinds)):
        x, z = pos[i, 0], pos[i, 2]
        ax.plot(
            [x],
            [z],
            marker=KIND_MARKERS.get(kind, "*"),
            color=ANNOTATION_COLOR,
            markersize=4.5,
            markeredgewidth=0.4,
            markeredgecolor="white",
            linestyle="none",
            label=kind if kind not in seen else None,
            zorder=ANNOTATION_ZORDER,
        )
        seen.add(kind)
        d = dirs[i]
        if np.all(np.isfinite(d)) and np.hypot(d[0], d[2]) > 1e-6:
            dx, dz = d[0], d[2]
            n = np.hypot(dx, dz)
            ax.annotate(
                "",
                xy=(x + probe_m * dx / n, z + probe_m * dz / n),
                xytext=(x, z),
                arrowprops=dict(arrowstyle="-|>", color=ANNOTATION_COLOR, lw=0.8, mutation_scale=5),
                zorder=ANNOTATION_ZORDER,
            )
        # the user's text, drawn as it is: no mathtext ("$x^2$"), no control characters
        text = plain_text(label)

        def make(spot, text=text, x=x, z=z):
            (dx, dz), ha, va = spot
            # a text shifted by points of paper (cheaper to measure than an annotation)
            at = ax.transData + ScaledTranslation(dx / 72.0, dz / 72.0, ax.figure.dpi_scale_trans)
            t = ax.text(
                x, z, text, transform=at, ha=ha, va=va, fontsize=5.5, color=ANNOTATION_COLOR,
                zorder=ANNOTATION_ZORDER + 1, **PLAIN_TEXT_KW,
            )
            return tag(with_halo(t, 1.8), "annotation-label")

        def spec(spot, text=text, x=x, z=z):
            from .placement import Spot

            (dx, dz), ha, va = spot
            return Spot(x, z, text, 5.5, ha, va, 0.0, dx, dz)

        if placer is None or placer.place(make, _LABEL_SPOTS, spec=spec) is None:
            t = make(_LABEL_SPOTS[0])
            if placer is not None:
                placer.keep(placer.box(t))
    handles, names = ax.get_legend_handles_labels()
    if legend:
        ax.legend(loc="lower right", fontsize=5, frameon=True, framealpha=0.8, markerscale=0.8, borderpad=0.3, handletextpad=0.3)
    return list(zip(handles, names))


def rasterize_segments(segments: np.ndarray, level: np.ndarray, sheet: Sheet) -> np.ndarray:
    """``(rows, cols)`` number of distinct slices whose segments cross each pixel.

    Segments are sampled at one-pixel steps (the ink is dilated afterwards, so no gap shows);
    a pixel counts each slice once, so a slice's chain of segments does not darken itself where
    its segments meet. The samples are walked slice by slice in one compiled pass
    (:func:`meshplan._kernels.count_levels`), a pixel counting a slice when first met at it:
    the numpy version made the 1.6 million samples of the benchmark apartment as eight arrays
    of 13 MB and set a bit per slice in a 25 MB word array for each 64 slices: 0.09-0.17 s of
    the pen-and-ink plan's 0.35-0.45 s, against 0.04 s; the same counts.
    """
    from .._kernels import count_levels

    rows, cols = sheet.raster_shape
    if not len(segments):
        return np.zeros((rows, cols), dtype=np.int32)
    p = sheet.pixel_m
    origin = np.array([sheet.xmin, sheet.zmin])
    a = (segments[:, 0] - origin) / p
    d = (segments[:, 1] - origin) / p - a
    n = np.ceil(np.hypot(d[:, 0], d[:, 1])).astype(np.int64) + 1
    level = np.asarray(level, dtype=np.int64)
    order = np.argsort(level, kind="stable")
    return count_levels(np.ascontiguousarray(a), np.ascontiguousarray(d), n, level, order, rows, cols).reshape(rows, cols)


def grow_max(image: np.ndarray, size: int = 2) -> np.ndarray:
    """``image`` with each pixel the largest value of the ``size`` x ``size`` block ending at it
    (over its first two axes; further axes, such as colour channels, each on their own): what
    ``scipy.ndimage.maximum_filter`` gives, edges repeated, value for value.

    A block of 2, the width of the plans' lines and dots, is two shifted maxima: a twentieth
    of the filter's time on an RGBA sheet (0.004 s instead of 0.08 s); other sizes are left to
    the filter.
    """
    if size != 2:
        from scipy.ndimage import maximum_filter

        return maximum_filter(image, size=(size, size) + (1,) * (image.ndim - 2))
    rows = image.copy()
    np.maximum(image[1:], image[:-1], out=rows[1:])
    out = rows.copy()
    np.maximum(rows[:, 1:], rows[:, :-1], out=out[:, 1:])
    return out


def ink_rgba(counts: np.ndarray, opacity: float, color: str = "#14213d", width_px: int = 2) -> np.ndarray:
    """Translucent ink: a pixel crossed by ``k`` slices has opacity ``1 - (1 - opacity)^k``."""
    from matplotlib.colors import to_rgb

    c = np.minimum(counts, 255).astype(np.uint8)
    if width_px > 1:
        c = grow_max(c, width_px)
    lut = np.empty((256, 4), dtype=np.uint8)
    lut[:, :3] = np.round(np.array(to_rgb(color)) * 255)
    lut[:, 3] = np.round(255 * (1.0 - (1.0 - opacity) ** np.arange(256)))
    # each pixel's four bytes looked up as one 32-bit word: a single gather instead of four
    return lut.view(np.uint32)[c].view(np.uint8).reshape(*c.shape, 4)


_RC: dict[RcKeyType, Any] = {"path.simplify": True}


def figure_files(fig, fmts) -> dict[str, bytes]:
    """``format -> bytes`` of a figure in each of ``fmts`` (PNG, SVG, PDF), drawn once for all
    of them (:mod:`.vector`), without timestamps (byte-reproducible)."""
    from .vector import figure_files as files

    return files(fig, fmts)


def figure_bytes(fig, fmt: str) -> bytes:
    """Render a figure to PNG, SVG or PDF bytes, without timestamps (byte-reproducible)."""
    return figure_files(fig, (fmt,))[fmt]

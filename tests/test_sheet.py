"""The drafting plan as an architectural sheet (issue 12): walls as solids with openings cut
through them, rooms labelled and tinted, dimensions outside the building, no text over another
text or a wall, a title block, north arrow and scale bar, imperial units throughout."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import shapely

from conftest import real_scan, real_scan_names
from meshplan.plan.symbols import plan_symbols
from meshplan.render import drafting_figure, make_sheet
from meshplan.render.sheet import format_feet_inches

PRESETS = ("room", "apartment", "office", "multistory")
#: Every real scan (18 of them; a placeholder that skips when ../shared is absent).
REAL = real_scan_names() or ["(no real scans)"]
LABELS = ("room-label", "dimension", "annotation-label", "stair-label")


def _figures(result, **kw):
    """(symbols, figure) of each story's drafting plan, made as the export makes them."""
    o, params = result.orientation, result.options.render
    if kw:
        from dataclasses import replace

        params = replace(params, **kw)
    for sp in result.stories:
        i = sp.story.index
        sheet = make_sheet(result.mesh.face_centroids[o.face_story == i][:, [0, 2]], params)
        symbols = plan_symbols(i, result.walls, result.openings, result.rooms, result.physical_walls, params.imperial, stairs=result.stairs)
        yield symbols, drafting_figure(sp.drafting, sp.annotations, sheet, params, len(result.stories), symbols, scan="scan.ply")


def _texts(fig):
    """(gid, text, display box) of the labels of the plan."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    renderer = FigureCanvasAgg(fig).get_renderer()
    out = []
    for t in fig.axes[0].texts:
        if getattr(t, "meshplan_role", None) in LABELS and t.get_visible() and t.get_text():
            bb = t.get_window_extent(renderer)
            out.append((getattr(t, "meshplan_role", None), t.get_text(), shapely.box(bb.x0, bb.y0, bb.x1, bb.y1)))
    return out


def _wall_lines(fig, symbols):
    """The outlines of the cut walls in display coordinates."""
    to_px = fig.axes[0].transData.transform
    lines = []
    for w in symbols.wall_solids:
        for ring in shapely.get_rings(shapely.get_parts(w.polygon)):
            lines.append(shapely.LineString(to_px(np.asarray(ring.coords))))
    return shapely.MultiLineString(lines) if lines else None


def _check_clear(result) -> int:
    """No two labels overlap; no room label or dimension crosses a wall line. Returns the
    number of labels checked."""
    n = 0
    for symbols, fig in _figures(result):
        texts = _texts(fig)
        n += len(texts)
        for (g1, t1, b1), (g2, t2, b2) in itertools.combinations(texts, 2):
            # boxes that only touch are fine: 0.5 pixel
            assert b1.intersection(b2).area <= 0.5 * max(b1.length, b2.length) * 0.5, f"{g1} {t1!r} overlaps {g2} {t2!r}"
        walls = _wall_lines(fig, symbols)
        for gid, text, box in texts:
            if gid != "annotation-label" and walls is not None:
                assert not box.buffer(-0.5).intersects(walls), f"{gid} {text!r} crosses a wall"
    return n


@pytest.mark.slow
@pytest.mark.parametrize("preset", PRESETS)
def test_labels_clear_of_each_other_and_of_walls_on_presets(computed, preset):
    _, result = computed(preset, 1)
    assert _check_clear(result) > 0


@pytest.fixture(scope="module")
def real_results():
    import meshplan

    cache = {}

    def get(name):
        if name not in cache:
            cache[name] = meshplan.run(real_scan(name), output=None)
        return cache[name]

    return get


@pytest.mark.slow
@pytest.mark.realscan
@pytest.mark.parametrize("name", REAL)
def test_labels_clear_of_each_other_and_of_walls_on_real_scans(real_results, name):
    _check_clear(real_results(name))


@pytest.mark.slow
def test_walls_are_solids_with_openings_cut_through(computed):
    from matplotlib.patches import PathPatch

    _, result = computed("apartment", 1)
    (symbols, fig), *_ = _figures(result)
    mine = [w for w in result.physical_walls if w.story == 0]
    assert len(symbols.wall_solids) == len(mine)
    solid = shapely.union_all([w.polygon for w in symbols.wall_solids])
    # every wall's centre line lies in the poche, but where its doors and windows are
    for w in mine:
        line = shapely.LineString([w.start, w.end])
        assert line.difference(solid.buffer(1e-6)).length < 0.5 * w.length
    centres = result.openings.center(result.walls)
    for i in np.flatnonzero(result.openings.story == 0):
        f = int(result.openings.wall[i])
        carrier = next(w for w in mine if f in w.faces)
        # the middle of the wall at the opening's centre is a gap in the poche
        mid = centres[i] - result.walls.normal[f] * 0.5 * carrier.thickness
        assert not solid.contains(shapely.Point(mid)), result.openings.kind[i]
    assert sum(isinstance(p, PathPatch) for p in fig.axes[0].patches) >= 2  # exterior and interior
    exterior = [w for w in symbols.wall_solids if w.exterior]
    assert exterior and len(exterior) < len(symbols.wall_solids)


@pytest.mark.slow
def test_dimension_chains_lie_outside_the_building(computed):
    _, result = computed("apartment", 1)
    (symbols, fig), *_ = _figures(result)
    building = shapely.union_all([w.polygon for w in symbols.wall_solids] + [shapely.Polygon(r) for r in symbols.room_outlines])
    x0, z0, x1, z1 = building.bounds
    assert {(c.axis, c.outward) for c in symbols.chains} == {(0, -1), (0, 1), (1, -1), (1, 1)}
    tiers = {c.tier for c in symbols.chains}
    assert 2 in tiers and 0 in tiers  # overall and openings
    overall = [c for c in symbols.chains if c.tier == 2]
    for c in overall:
        assert c.ticks[-1] - c.ticks[0] == pytest.approx((x1 - x0) if c.axis == 0 else (z1 - z0), abs=0.01)
    # the chain texts sit outside the building's box
    ax = fig.axes[0]
    to_data = ax.transData.inverted()
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    renderer = FigureCanvasAgg(fig).get_renderer()
    dims = [t for t in ax.texts if getattr(t, "meshplan_role", None) == "dimension"]
    outside = 0
    for t in dims:
        bb = t.get_window_extent(renderer)
        (a, b), (c, d) = to_data.transform([(bb.x0, bb.y0), (bb.x1, bb.y1)])
        box = shapely.box(min(a, c), min(b, d), max(a, c), max(b, d))
        outside += not box.intersects(shapely.box(x0, z0, x1, z1))
    assert outside >= 8
    # one text size for every dimension, in points of paper whatever the scale
    assert len({t.get_fontsize() for t in dims}) == 1


@pytest.mark.slow
def test_room_labels_name_number_area_and_tints(computed):
    _, result = computed("apartment", 1)
    (symbols, fig), *_ = _figures(result)
    texts = [t.get_text() for t in fig.axes[0].texts if getattr(t, "meshplan_role", None) == "room-label"]
    rooms = [r for r in result.rooms if r.story == 0]
    assert len(texts) == len(rooms)
    for r in rooms:
        assert any(r.name in t and r.number in t and "m²" in t for t in texts), (r.name, texts)
    # corridors are tinted apart from rooms
    assert "corridor" in symbols.room_types
    colors = {tuple(np.round(c, 3)) for c in fig.axes[0].collections[0].get_facecolor()}
    assert len(colors) >= 2


@pytest.mark.slow
def test_title_block_north_arrow_and_scale(computed, monkeypatch):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1767225600")  # 2026-01-01
    _, result = computed("room", 1)
    (_, fig), *_ = _figures(result)
    texts = [t.get_text() for ax in fig.axes for t in ax.texts]
    from meshplan import __version__

    assert "scan.ply" in texts and "2026-01-01" in texts and f"meshplan {__version__}" in texts
    assert "N" in texts and any(t.startswith("SCALE 1:") for t in texts)
    assert "metres, m²" in texts
    assert fig.legends  # the legend in the strip


def test_feet_and_inches():
    assert format_feet_inches(3.81) == "12'-6\""
    assert format_feet_inches(0.3048) == "1'-0\""
    assert format_feet_inches(0.0) == "0'-0\""


@pytest.mark.slow
def test_imperial_sheet_is_all_feet_and_inches(computed):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    _, result = computed("apartment", 1)
    (_, fig), *_ = _figures(result, imperial=True)
    FigureCanvasAgg(fig).draw()
    ax = fig.axes[0]
    # the coordinate ticks' labels (drawn as texts of their own: render.sheet._static_ticks)
    ticks = [t.get_text() for t in ax.texts if getattr(t, "meshplan_role", None) == "tick-label" and t.get_text()]
    assert ticks and all("'-" in t and '"' in t for t in ticks), ticks
    labels = [t.get_text() for t in ax.texts if getattr(t, "meshplan_role", None) in ("room-label", "dimension")]
    assert labels and not any("m²" in t for t in labels)
    assert all("'-" in t for t in labels if not any(c.isalpha() for c in t.replace("ft²", "")))
    assert any("ft²" in t for t in labels)


@pytest.mark.slow
def test_dxf_walls_are_hatched(computed):
    import io

    import ezdxf

    from meshplan.export import _jobs

    _, result = computed("apartment", 1)
    _, dxf = _jobs(result)
    job = dxf[0]
    data = job[0](*job[1:])["drafting-0.dxf"]
    doc = ezdxf.read(io.StringIO(data.decode()))
    hatches = [e for e in doc.modelspace() if e.dxftype() == "HATCH" and e.dxf.layer == "WALLS"]
    assert len(hatches) >= len([w for w in result.physical_walls if w.story == 0])


# --- standard sheet sizes (--sheet) ------------------------------------------------------------


def _square(side_m: float) -> np.ndarray:
    g = np.linspace(0.0, side_m, 40)
    return np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)


def test_fit_is_the_default_and_unchanged():
    from meshplan.render.params import RenderParams
    from meshplan.render.sheet import new_figure

    params = RenderParams()
    assert params.sheet == "fit"
    sheet = make_sheet(_square(10.0), params)
    assert sheet.page_in is None and sheet.paper == ""
    fig, _ = new_figure(sheet, "t", params)
    w, h = sheet.drawing_in
    assert tuple(fig.get_size_inches()) == pytest.approx((max(w + 1.1, 10.5), h + 2.35))


@pytest.mark.parametrize(("side", "scale", "imperial"), [(10.0, 100, False), (10.0, 50, False), (30.0, 100, False), (10.0, 50, True), (4.0, 50, True)])
def test_auto_sheet_is_the_smallest_that_holds_the_plan(side, scale, imperial):
    from meshplan.render.params import AUTO_PAPER_IMPERIAL, AUTO_PAPER_METRIC, PAPER_SIZES_IN, RenderParams
    from meshplan.render.sheet import _fits, _orientations, new_figure

    params = RenderParams(sheet="auto", scale=scale, imperial=imperial)
    sheet = make_sheet(_square(side), params)
    names = AUTO_PAPER_IMPERIAL if imperial else AUTO_PAPER_METRIC
    assert sheet.paper in names and sheet.scale == scale
    assert sorted(sheet.page_in) == pytest.approx(sorted(PAPER_SIZES_IN[sheet.paper]))
    extent = np.array([sheet.width_m, sheet.depth_m]) - 2 * 0.026 * scale
    for smaller in names[: names.index(sheet.paper)]:
        assert not any(_fits(extent, scale, page) for page in _orientations(smaller))
    fig, ax = new_figure(sheet, "t", params)
    assert tuple(fig.get_size_inches()) == pytest.approx(sheet.page_in)
    x0, y0, x1, y1 = ax.get_position().extents
    assert 0 < x0 < x1 < 1 and 0 < y0 < y1 < 1  # the drawing on the paper
    # exactly at the scale: the axes are the drawing's size on paper
    assert (x1 - x0) * sheet.page_in[0] == pytest.approx(sheet.drawing_in[0])


def test_named_sheet_picks_a_scale_that_fits_or_refuses():
    from meshplan.errors import ParameterError
    from meshplan.render.params import RenderParams

    auto = make_sheet(_square(10.0), RenderParams())
    a4 = make_sheet(_square(10.0), RenderParams(sheet="A4"))
    a0 = make_sheet(_square(10.0), RenderParams(sheet="A0"))
    assert a4.paper == "A4" and a4.scale > auto.scale  # a smaller standard scale to fit A4
    assert a0.scale == auto.scale and a0.page_in == pytest.approx((1189 / 25.4, 841 / 25.4))  # landscape
    with pytest.raises(ParameterError, match="does not fit on A4 at 1:20"):
        make_sheet(_square(10.0), RenderParams(sheet="A4", scale=20))
    with pytest.raises(ParameterError, match="one of fit, auto, A4"):
        RenderParams(sheet="A5")


# --- short dimension pieces and bare numbers (hl2_su_apartment_two_story story 0) ---------------


def test_ticks_closer_than_the_paper_gap_merge():
    from meshplan.render.plans import merge_ticks

    t = [1.626, 1.793, 3.53, 3.605, 3.68, 12.424, 12.511]
    assert merge_ticks(t, 0.1).tolist() == [1.626, 1.793, 3.605, 12.511]  # the ends stay
    assert merge_ticks(t, 0.1, prefer=[3.68]).tolist() == [1.626, 1.793, 3.68, 12.511]  # the coarser chain's
    assert merge_ticks(t, 0.01).tolist() == t


@pytest.mark.slow
def test_real_apartment_has_no_short_dimension_pieces_nor_bare_numbers(real_results):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from meshplan.render.plans import DIM_TICK_MERGE_MM

    result = real_results("hl2_su_apartment_two_story.ply")
    for _symbols, fig in _figures(result):
        FigureCanvasAgg(fig).draw()
        ax = fig.axes[0]
        scale = int(next(t.get_text() for a in fig.axes for t in a.texts if t.get_text().startswith("SCALE 1:"))[8:])
        dims = [float(t.get_text()) for t in ax.texts if getattr(t, "meshplan_role", None) == "dimension"]
        assert dims and min(dims) >= DIM_TICK_MERGE_MM * scale / 1000 - 0.005, sorted(dims)[:5]
        rooms = [t.get_text() for t in ax.texts if getattr(t, "meshplan_role", None) == "room-label"]
        assert not any(t.replace(".", "").isdigit() for t in rooms), rooms  # "0.02" reads as a length

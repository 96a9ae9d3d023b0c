"""Reference-PNG regression tests (issue 12 item 7): the drafting plans of a few small, fixed
synthetic scans, rendered at a low resolution, against reference PNGs in ``tests/data/``.

The images are compared after a small blur (a Gaussian of :data:`BLUR_PX` pixels: antialiasing
does not count) by the share of the drawing's ink (pixels darker than :data:`INK` in either
image) whose grey value differs by more than :data:`PIXEL_TOLERANCE`; at most :data:`MAX_CHANGED`
of it may (one door fewer changes about 1 % of the ink, a stair fewer 8 %; see
:func:`test_the_metric_sees_a_change`). Blank paper does not dilute a change.

To regenerate the references after an intended change of the drawings (look at them first)::

    MESHPLAN_UPDATE_REFERENCES=1 .venv/bin/python -m pytest tests/test_reference_png.py

which writes ``tests/data/reference-*.png`` instead of comparing (the tests then skip), and keep
the new files with the change that made them.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.slow  # whole computations of synthetic scans

DATA = Path(__file__).parent / "data"
#: (preset, seed, story) of each reference: a room, and both stories of the multistory preset
#: (a stair starting on one, arriving on the other).
CASES = (("room", 1, 0), ("multistory", 1, 0), ("multistory", 1, 1))
#: Low resolution keeps the references a few tens of KB and the comparison about geometry.
DPI = 50
BLUR_PX = 1.0
INK = 0.9  # grey (0 black, 1 white) below which a blurred pixel is ink
PIXEL_TOLERANCE = 0.05  # of the grey range
MAX_CHANGED = 0.005  # of the ink
UPDATE = os.environ.get("MESHPLAN_UPDATE_REFERENCES", "") not in ("", "0")


def _render(result, story: int, drop_stairs: bool = False, drop_door: bool = False) -> bytes:
    from dataclasses import replace

    from meshplan.plan.symbols import plan_symbols
    from meshplan.render import drafting_figure, figure_bytes, make_sheet

    params = replace(result.options.render, dpi=DPI)
    sp = result.stories[story]
    sheet = make_sheet(result.mesh.face_centroids[result.orientation.face_story == story][:, [0, 2]], params)
    symbols = plan_symbols(story, result.walls, result.openings, result.rooms, result.physical_walls, stairs=() if drop_stairs else result.stairs)
    if drop_door:
        symbols = replace(symbols, door_leaves=symbols.door_leaves[1:], door_arcs=symbols.door_arcs[1:])
    fig = drafting_figure(sp.drafting, sp.annotations, sheet, params, len(result.stories), symbols, scan="reference")
    return figure_bytes(fig, "png")


def _grey(png: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("L"), dtype=np.float64) / 255.0


def changed_share(a: bytes, b: bytes) -> float:
    """The share of the ink of two images whose blurred grey values differ by more than the
    tolerance (1.0 when the images differ in size)."""
    from scipy.ndimage import gaussian_filter

    x, y = _grey(a), _grey(b)
    if x.shape != y.shape:
        return 1.0
    x, y = gaussian_filter(x, BLUR_PX), gaussian_filter(y, BLUR_PX)
    ink = (x < INK) | (y < INK)
    changed = np.abs(x - y) > PIXEL_TOLERANCE
    return float(changed.sum() / max(ink.sum(), 1))


@pytest.fixture(autouse=True)
def _fixed_date(monkeypatch):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1767225600")  # the title block's date: 2026-01-01


@pytest.mark.parametrize(("preset", "seed", "story"), CASES, ids=[f"{p}-{s}-{k}" for p, s, k in CASES])
def test_drafting_plan_matches_its_reference(computed, preset, seed, story):
    _, result = computed(preset, seed)
    png = _render(result, story)
    path = DATA / f"reference-{preset}-{seed}-{story}.png"
    if UPDATE:
        DATA.mkdir(exist_ok=True)
        path.write_bytes(png)
        pytest.skip(f"wrote {path.name}")
    assert path.is_file(), f"no reference {path.name}: MESHPLAN_UPDATE_REFERENCES=1 makes it"
    share = changed_share(png, path.read_bytes())
    assert share <= MAX_CHANGED, f"{share:.2%} of the pixels changed (at most {MAX_CHANGED:.2%}); look at the drawing, then regenerate"


def test_the_metric_sees_a_change(computed):
    """The comparison can fail: the same plan without its stair, or without one door, differs."""
    _, result = computed("multistory", 1)
    png = _render(result, 0)
    assert changed_share(png, png) == 0.0
    assert changed_share(png, _render(result, 0, drop_stairs=True)) > 10 * MAX_CHANGED
    assert changed_share(png, _render(result, 0, drop_door=True)) > 1.5 * MAX_CHANGED

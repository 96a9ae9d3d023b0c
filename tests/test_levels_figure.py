"""levels.png (issue 12): every mark explained in a legend (the red markers are the histogram's
peaks, the candidate levels), and no wide empty margin right of the level labels."""

from __future__ import annotations

import pytest

pytestmark = pytest.mark.slow  # a whole computation of a synthetic scan


@pytest.mark.parametrize(("preset", "seed"), [("multistory", 1), ("room", 1)])
def test_levels_legend_and_margin(computed, preset, seed):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from meshplan.render import levels_figure
    from meshplan.render.plots import PEAK_COLOR

    _, result = computed(preset, seed)
    fig = levels_figure(result.orientation, result.options.render)
    ax = fig.axes[0]
    (legend,) = [ax.get_legend()]
    names = [t.get_text() for t in legend.get_texts()]
    assert "histogram peak: a candidate level" in names and "floor found" in names
    peaks = [line for line in ax.lines if line.get_color() == PEAK_COLOR]
    assert len(peaks) == 1 and len(peaks[0].get_xdata()) == len(result.orientation.levels.spikes) > 0
    # each marker at the tip of a bar: within the plot, not in the middle of nowhere
    assert max(peaks[0].get_xdata()) <= ax.get_xlim()[1]
    renderer = FigureCanvasAgg(fig).get_renderer()
    right = max(t.get_window_extent(renderer).x1 for t in ax.texts)
    width = fig.get_figwidth() * fig.dpi
    assert width - 0.3 * fig.dpi <= right <= width  # the labels end near the edge, inside it



_NO_MATH = """
import pathlib, tempfile
from matplotlib.mathtext import MathTextParser
import meshplan
from meshplan.export import _levels_files, _normals_files
from meshplan.export.synth import write_synthetic
from meshplan.synthetic import SynthParams, generate
d = pathlib.Path(tempfile.mkdtemp())
write_synthetic(generate(SynthParams(preset="room", seed=1)), d, "ply", force=True)
r = meshplan.run(d / "scan.ply")
from meshplan.render.plots import normals_histogram
files = {**_normals_files(normals_histogram(r.mesh.face_normals, r.mesh.face_areas), r.orientation), **_levels_files(r.orientation, r.options.render)}
assert sorted(files) == ["levels.png", "normals.png"] and all(v.startswith(bytes([137]) + b"PNG") for v in files.values())
print(getattr(MathTextParser, "_parser", None) is None)
"""


def test_the_orientation_figures_are_cheap_to_draw(computed):
    """normals.png and levels.png in plain text and few artists: math text (the log colour
    bar's default 10-to-a-power labels) made a fresh drawing worker build its parser for them
    alone (0.07 s), and barh made an artist of each of the histogram's bars (0.1 s)."""
    import subprocess
    import sys

    from matplotlib.collections import PolyCollection

    from meshplan.render import levels_figure

    out = subprocess.run([sys.executable, "-c", _NO_MATH], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "True"
    _, result = computed("room", 1)
    ax = levels_figure(result.orientation, result.options.render).axes[0]
    assert not ax.patches
    (bars,) = [c for c in ax.collections if isinstance(c, PolyCollection)]
    assert len(bars.get_paths()) == len(result.orientation.levels.weights)

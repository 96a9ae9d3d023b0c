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

"""Parameters of the drawings."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import ClassVar

from ..validation import AnyOf, Boolean, Constraint, Integer, Real, validated

#: Drawing scales meshplan chooses from (1:n), so that a plan prints between about 12 and 40 cm.
STANDARD_SCALES = (20, 50, 100, 200, 500, 1000, 2000)

#: Largest drawing scale (smallest n of 1:n) that can be asked for. The page grows as 1/n: at
#: 1:1 a 20 m story is a 20 m page, whose raster at the lowest resolution (30 dpi) would hold
#: 24,000 x 24,000 pixels; 1:10 is the largest scale architects draw plans at (details are 1:5 and
#: below), and keeps a 50 m story on a 5 m page (6000 pixels at 30 dpi).
MIN_SCALE = 10

#: Smallest drawing scale (largest n): at 1:100,000 a 100 m building is 1 mm on the page.
MAX_SCALE = 100_000

#: Resolution bounds in dots per inch: below 30 text is unreadable; above 1200 (a photo printer's
#: resolution) the raster grows as the square of the dpi without anything more to see.
MIN_DPI, MAX_DPI = 30, 1200

#: Most drawing processes: each is a forked copy of the run (with the scan in memory); more than
#: the cores only wait, and 64 is more cores than meshplan's machines have.
MAX_PROCESSES = 64


@validated
@dataclass(frozen=True)
class RenderParams:
    """How plans and figures are drawn.

    Attributes
    ----------
    opacity
        Opacity of each slice of the pen-and-ink plan, so that what stands at many heights is
        dark (paper: 0.5).
    imperial
        Scale bars and areas in feet and square feet (metres remain the model's unit).
    scale
        Drawing scale 1:``scale`` of the printed plans (PDF/SVG page size); 0 picks the
        largest standard scale (1:20 ... 1:2000) at which the story fits on about 30 cm; else
        from :data:`MIN_SCALE` to :data:`MAX_SCALE`.
    dpi
        Resolution of the PNG drawings and of the ink raster inside SVG and PDF.
    processes
        Worker processes that draw the plans and build the models in parallel (Linux, forked);
        0 is one per core, at most 4; 1 draws everything in the main process.
    """

    _parameter_constraints: ClassVar[dict[str, Constraint]] = {
        "opacity": Real(0.0, 1.0, closed="right"),
        "imperial": Boolean(),
        "scale": AnyOf(
            Integer(0, 0),
            Integer(MIN_SCALE, MAX_SCALE),
            what=f"0 (automatic) or an integer n from {MIN_SCALE} to {MAX_SCALE:,} for 1:n",
            why="a larger scale draws a page the size of the building",
        ),
        "dpi": Integer(MIN_DPI, MAX_DPI, why="below 30 dpi text is unreadable; above 1200 the raster only grows"),
        "processes": Integer(0, MAX_PROCESSES, why="each process is a copy of the run; more than the cores only wait"),
    }

    opacity: float = 0.5
    imperial: bool = False
    scale: int = 0
    dpi: int = 150
    processes: int = 0

    def to_dict(self) -> dict:
        return asdict(self)

"""Parameters of the drawings."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import ClassVar

from ..validation import AnyOf, Boolean, Constraint, Integer, Options, Real, validated

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

#: Standard paper sizes (portrait width x height, inches): ISO 216 A4-A0 (210 x 297 mm ...
#: 841 x 1189 mm), ANSI A (Letter) and B (Tabloid), ARCH D. Each is used in landscape or portrait,
#: whichever holds the plan (landscape first).
PAPER_SIZES_IN: dict[str, tuple[float, float]] = {
    "A4": (210 / 25.4, 297 / 25.4),
    "A3": (297 / 25.4, 420 / 25.4),
    "A2": (420 / 25.4, 594 / 25.4),
    "A1": (594 / 25.4, 841 / 25.4),
    "A0": (841 / 25.4, 1189 / 25.4),
    "Letter": (8.5, 11.0),
    "Tabloid": (11.0, 17.0),
    "ANSI-B": (11.0, 17.0),
    "Arch-D": (24.0, 36.0),
}
#: The sizes ``--sheet auto`` picks from, smallest first: ISO for metric sheets, US sizes for
#: imperial ones (the paper a reader of that unit system has).
AUTO_PAPER_METRIC = ("A4", "A3", "A2", "A1", "A0")
AUTO_PAPER_IMPERIAL = ("Letter", "Tabloid", "Arch-D")
#: ``sheet`` values besides the paper names: ``fit`` a page fitted around the drawing (its
#: margins and the strip below it; the behaviour before standard sizes), ``auto`` the smallest
#: standard size that holds it.
SHEET_CHOICES = ("fit", "auto", *PAPER_SIZES_IN)

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
        Processes that draw the plans and build the models in parallel (Linux, forked): the
        run itself and ``processes - 1`` workers; 0 is one per core, at most 4 (on 2 cores, the
        run and one worker); 1 draws everything in the main process.
    sheet
        Paper of the drawings: ``fit`` (a page fitted around the plan), ``auto`` (the smallest
        of :data:`AUTO_PAPER_METRIC` or, imperial, :data:`AUTO_PAPER_IMPERIAL` that holds the plan at its
        scale) or a size of :data:`PAPER_SIZES_IN` (A4 ... A0, Letter, Tabloid, ANSI-B, Arch-D).
        With a named size and the automatic scale the scale is the automatic one, or the next
        smaller standard scale that fits the paper.
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
        "sheet": Options(SHEET_CHOICES),
    }

    opacity: float = 0.5
    imperial: bool = False
    scale: int = 0
    dpi: int = 150
    processes: int = 0
    sheet: str = "fit"

    def to_dict(self) -> dict:
        return asdict(self)

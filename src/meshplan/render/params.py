"""Parameters of the drawings."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from ..errors import ParameterError

#: Drawing scales meshplan chooses from (1:n), so that a plan prints between about 12 and 40 cm.
STANDARD_SCALES = (20, 50, 100, 200, 500, 1000, 2000)


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
        largest standard scale (1:20 ... 1:2000) at which the story fits on about 30 cm.
    dpi
        Resolution of the PNG drawings and of the ink raster inside SVG and PDF.
    processes
        Worker processes that draw the plans and build the models in parallel (Linux, forked);
        0 is one per core, at most 4; 1 draws everything in the main process.
    """

    opacity: float = 0.5
    imperial: bool = False
    scale: int = 0
    dpi: int = 150
    processes: int = 0

    def __post_init__(self) -> None:
        if not (0.0 < self.opacity <= 1.0):
            raise ParameterError(f"opacity must be in (0, 1], got {self.opacity!r}", "pass --opacity between 0 and 1, e.g. 0.5")
        if not isinstance(self.scale, int) or self.scale < 0:
            raise ParameterError(f"scale must be a non-negative integer, got {self.scale!r}", "pass --scale 100 for 1:100, or 0 for automatic")
        if not isinstance(self.processes, int) or self.processes < 0:
            raise ParameterError(f"processes must be a non-negative integer, got {self.processes!r}", "pass 0 for automatic, or 1 to draw in the main process")
        if not isinstance(self.dpi, int) or not 30 <= self.dpi <= 1200:
            raise ParameterError(f"dpi must be an integer from 30 to 1200, got {self.dpi!r}", "pass --dpi 200")

    def to_dict(self) -> dict:
        return asdict(self)

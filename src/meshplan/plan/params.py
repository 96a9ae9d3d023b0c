"""Parameters of the floor plans (paper, "Floor plan computation"), with the paper's values."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from ..errors import ParameterError
from ..geometry import check_positive


@dataclass(frozen=True)
class PlanParams:
    """What the plans are made of.

    Attributes
    ----------
    slices
        Number ``n`` of slicing intervals of the pen-and-ink plan: the story is cut at the
        ``n + 1`` heights ``floor + (ceiling - floor) * i / n`` (paper: 100 balances detail and
        clutter).
    drafting_height_m
        Height above the floor at which the flat-wall model is cut for the drafting plan (the
        paper's "single intermediate altitude"; 1.2 m is the usual architectural cut plane,
        through windows and doors).
    """

    slices: int = 100
    drafting_height_m: float = 1.2

    def __post_init__(self) -> None:
        if not isinstance(self.slices, int) or isinstance(self.slices, bool) or not 1 <= self.slices <= 10000:
            raise ParameterError(f"slices must be an integer from 1 to 10000, got {self.slices!r}", "pass --slices N")
        check_positive("drafting_height_m", self.drafting_height_m)

    def to_dict(self) -> dict:
        return asdict(self)

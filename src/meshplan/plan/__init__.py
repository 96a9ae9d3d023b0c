"""Floor plans of each story: pen-and-ink (many slices of the mesh) and drafting (one slice of
the flat-wall model)."""

from .drafting import DraftingPlan, drafting
from .params import PlanParams
from .peninink import PenAndInkPlan, pen_and_ink

__all__ = ["DraftingPlan", "PenAndInkPlan", "PlanParams", "drafting", "pen_and_ink"]

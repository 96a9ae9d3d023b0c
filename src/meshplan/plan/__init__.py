"""Floor plans of each story: pen-and-ink (many slices of the mesh), drafting (one slice of the
flat-wall model), rooms, doors and windows."""

from .drafting import DraftingPlan, drafting
from .openings import Openings, find_openings
from .params import PlanParams
from .peninink import PenAndInkPlan, pen_and_ink
from .rooms import Room, find_rooms
from .stairs import StairElement, find_stairs

__all__ = [
    "DraftingPlan",
    "Openings",
    "PenAndInkPlan",
    "PlanParams",
    "Room",
    "StairElement",
    "drafting",
    "find_openings",
    "find_rooms",
    "find_stairs",
    "pen_and_ink",
]

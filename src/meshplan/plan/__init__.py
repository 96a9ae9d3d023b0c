"""Floor plans of each story: pen-and-ink (many slices of the mesh), drafting (one slice of the
flat-wall model), rooms, doors and windows."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:  # pragma: no cover
    from .draft import DraftingPlan, drafting
    from .openings import Openings, find_openings
    from .params import PlanParams
    from .peninink import PenAndInkPlan, pen_and_ink
    from .rooms import Room, find_rooms
    from .stairs import StairElement, find_stairs
    from .voids import Void, double_height_voids

#: Where each public name lives (loaded when first used, :mod:`meshplan._lazy`).
_EXPORTS = {
    "DraftingPlan": "draft",
    "Openings": "openings",
    "PenAndInkPlan": "peninink",
    "PlanParams": "params",
    "Room": "rooms",
    "StairElement": "stairs",
    "Void": "voids",
    "drafting": "draft",
    "find_openings": "openings",
    "find_rooms": "rooms",
    "find_stairs": "stairs",
    "double_height_voids": "voids",
    "pen_and_ink": "peninink",
}

__all__ = [
    "DraftingPlan",
    "Openings",
    "PenAndInkPlan",
    "PlanParams",
    "Room",
    "StairElement",
    "Void",
    "double_height_voids",
    "drafting",
    "find_openings",
    "find_rooms",
    "find_stairs",
    "pen_and_ink",
]
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())

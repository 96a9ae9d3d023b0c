"""Lengths meshplan knows by name: the foot and the inch, and the units a scan may be in.

One place for them (the paper states its sizes in feet and inches: the DBSCAN box of 1.5 ft by
4 in, 2-inch histogram buckets), so that every module converts the same way.
"""

from __future__ import annotations

__all__ = ["FOOT_M", "INCH_M", "UNITS_M", "UNIT_NAMES"]

#: One international foot and one inch, in metres (exact by definition).
FOOT_M = 0.3048
INCH_M = 0.0254

#: Metres per unit of a scan's coordinates, for each unit ``--units`` accepts.
UNITS_M = {"m": 1.0, "cm": 0.01, "mm": 0.001, "ft": FOOT_M, "in": INCH_M}

#: Each unit's name in messages.
UNIT_NAMES = {"m": "metres", "cm": "centimetres", "mm": "millimetres", "ft": "feet", "in": "inches"}

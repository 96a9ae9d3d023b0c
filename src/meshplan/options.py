"""All options of a run, grouped by the stage that owns them.

Each stage defines its own frozen parameter dataclass with the paper's defaults (see
:class:`meshplan.orient.OrientParams`, ...). :class:`RunOptions` holds one of each plus the input
and output options, and :meth:`RunOptions.from_kwargs` routes flat keyword options (as the CLI and
:func:`meshplan.run` take them) to the stage that owns each name, so every default lives in exactly
one place.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, ClassVar

from .errors import ParameterError
from .io.mesh import UNITS_M
from .orient.params import OrientParams
from .plan.params import PlanParams
from .render.params import RenderParams
from .validation import (
    Boolean,
    Constraint,
    Integer,
    Optional,
    Options,
    describe,
    unknown_name,
    validated,
)
from .walls.params import WallParams


@validated
@dataclass(frozen=True)
class InputParams:
    """How the input is read.

    Attributes
    ----------
    units
        Unit of the scan's coordinates (m, cm, mm, ft, in).
    max_faces
        Refuse scans with more faces than this; ``None`` refuses only scans that cannot fit in
        the available memory.
    """

    _parameter_constraints: ClassVar[dict[str, Constraint]] = {
        "units": Options(tuple(UNITS_M)),
        # no upper bound: max_faces is how a user overrides the memory estimate on purpose
        "max_faces": Optional(Integer(1, None)),
    }

    units: str = "m"
    max_faces: int | None = None


@validated
@dataclass(frozen=True)
class ExportParams:
    """Optional outputs.

    Attributes
    ----------
    ifc
        Also write ``model.ifc`` (IFC4; needs the ``ifc`` extra, ifcopenshell).
    """

    _parameter_constraints: ClassVar[dict[str, Constraint]] = {"ifc": Boolean()}

    ifc: bool = False


_GROUPS = {
    "input": InputParams,
    "orient": OrientParams,
    "walls": WallParams,
    "plan": PlanParams,
    "render": RenderParams,
    "export": ExportParams,
}


@dataclass(frozen=True)
class RunOptions:
    """Every parameter of a run, one frozen dataclass per stage."""

    input: InputParams = field(default_factory=InputParams)
    orient: OrientParams = field(default_factory=OrientParams)
    walls: WallParams = field(default_factory=WallParams)
    plan: PlanParams = field(default_factory=PlanParams)
    render: RenderParams = field(default_factory=RenderParams)
    export: ExportParams = field(default_factory=ExportParams)

    def __post_init__(self) -> None:
        # RunOptions(orient={...}) would otherwise fail deep inside a stage
        for group, klass in _GROUPS.items():
            value = getattr(self, group)
            if not isinstance(value, klass):
                raise ParameterError(f"{group} must be a {klass.__name__}, got {describe(value)}", f"pass {group}={klass.__name__}(...)")

    @classmethod
    def names(cls) -> dict[str, str]:
        """Every flat option name and the group that owns it."""
        out: dict[str, str] = {}
        for group, klass in _GROUPS.items():
            for f in dataclasses.fields(klass):
                if f.name in out:  # pragma: no cover - guarded by a test
                    raise RuntimeError(f"option {f.name} defined twice")
                out[f.name] = group
        return out

    @classmethod
    def from_kwargs(cls, **options: Any) -> RunOptions:
        """Build the options from flat keywords (``up="+z", slices=50, ...``).

        Raises
        ------
        ParameterError
            For an unknown option name or an invalid value.
        """
        names = cls.names()
        grouped: dict[str, dict[str, Any]] = {g: {} for g in _GROUPS}
        for key, value in options.items():
            if key not in names:
                raise unknown_name(key, list(names), "option", "see meshplan run --help")
            # None means "not given" (the CLI passes every option), except for max_faces, whose
            # None is a value of its own (no limit)
            if value is not None or key == "max_faces":
                grouped[names[key]][key] = value
        # every value is checked by the constraints of the stage that owns it (meshplan.validation)
        return cls(**{g: _GROUPS[g](**kw) for g, kw in grouped.items()})

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """All parameters, grouped by stage (JSON-ready)."""
        return {g: dataclasses.asdict(getattr(self, g)) for g in _GROUPS}

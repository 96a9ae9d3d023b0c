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

from .errors import MeshplanError, ParameterError
from .io.params import VOXEL_M
from .orient.params import OrientParams
from .plan.params import PlanParams
from .render.params import RenderParams
from .units import UNITS_M
from .validation import (
    Boolean,
    Constraint,
    Integer,
    Optional,
    Options,
    Real,
    describe,
    unknown_name,
    validated,
)
from .walls.params import WallParams

#: Bounds of ``point_voxel_m``, metres: a finer grid keeps laser noise and millions of points; a
#: coarser one merges the two faces of a partition and blurs door jambs.
MIN_VOXEL_M, MAX_VOXEL_M = 0.005, 0.2


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
    point_voxel_m
        Voxel size of the grid a point cloud is subsampled on before it is turned into splats
        (:data:`meshplan.io.params.VOXEL_M`, 3 cm: coarser than laser spacing, finer than phone
        spacing and than anything the stages look at).
    """

    _parameter_constraints: ClassVar[dict[str, Constraint]] = {
        "units": Options(tuple(UNITS_M)),
        # no upper bound: max_faces is how a user overrides the memory estimate on purpose
        "max_faces": Optional(Integer(1, None)),
        "point_voxel_m": Real(
            MIN_VOXEL_M, MAX_VOXEL_M, why="below 5 mm the grid keeps laser noise and millions of points; above 20 cm it merges the two faces of a wall"
        ),
    }

    units: str = "m"
    max_faces: int | None = None
    point_voxel_m: float = VOXEL_M


#: Default site of the energy model: Chicago O'Hare airport (41.98 N, 87.92 W), the site of
#: EnergyPlus's example files and weather data; set --site-lat/--site-lon for the real one.
DEFAULT_SITE_LAT_DEG = 41.98
DEFAULT_SITE_LON_DEG = -87.92

#: Optional outputs -> (the module they need, the extra that installs it, the option to leave out).
_EXTRAS = {
    "ifc": ("ifcopenshell", "ifc", "--ifc"),
    "idf": ("openstudio", "energy", "--idf"),
    "osm": ("openstudio", "energy", "--osm"),
}


@validated
@dataclass(frozen=True)
class ExportParams:
    """Optional outputs.

    Attributes
    ----------
    ifc
        Also write ``model.ifc`` (IFC4; needs the ``ifc`` extra, ifcopenshell).
    gbxml
        Also write ``model.gbxml`` (gbXML 7.03 energy model; no extra needed).
    idf, osm
        Also write ``model.idf`` (EnergyPlus) and ``model.osm`` (OpenStudio), translated from the
        gbXML by OpenStudio (the ``energy`` extra).
    site_lat_deg, site_lon_deg
        Site of the energy model (degrees north and east; default Chicago O'Hare, the site of
        EnergyPlus's example files).
    north_deg
        Compass bearing of plan -z, up the page (degrees clockwise from true north): 0 makes plan
        -z north and +z south. Sets the facade orientations of the envelope summary.
    window_type
        gbXML type of the windows found (a scan cannot tell): operable or fixed.
    """

    _parameter_constraints: ClassVar[dict[str, Constraint]] = {
        "ifc": Boolean(),
        "gbxml": Boolean(),
        "idf": Boolean(),
        "osm": Boolean(),
        "site_lat_deg": Real(-90.0, 90.0, why="a latitude"),
        "site_lon_deg": Real(-180.0, 180.0, why="a longitude"),
        "north_deg": Real(-360.0, 360.0, why="a compass bearing"),
        "window_type": Options(("operable", "fixed")),
    }

    ifc: bool = False
    gbxml: bool = False
    idf: bool = False
    osm: bool = False
    site_lat_deg: float = DEFAULT_SITE_LAT_DEG
    site_lon_deg: float = DEFAULT_SITE_LON_DEG
    north_deg: float = 0.0
    window_type: str = "operable"

    def _check_together(self) -> None:
        """An output whose optional dependency is missing is refused here, when the options are
        made: before any scan is read (run, batch and the Python API alike)."""
        from importlib.util import find_spec

        for name, (module, extra, flag) in _EXTRAS.items():
            if getattr(self, name) and find_spec(module) is None:
                what = {"ifc": "IFC export", "idf": "EnergyPlus export", "osm": "OpenStudio export"}[name]
                raise MeshplanError(f"{what} needs {module}, which is not installed", f"pip install 'meshplan[{extra}]', or leave out {flag}")


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

"""The OpenStudio model and the EnergyPlus input file of a result (``--osm``, ``--idf``).

OpenStudio's Python bindings (an optional extra: ``pip install 'meshplan[energy]'``) are the
consumer of meshplan's gbXML (:mod:`meshplan.export.gbxml`): the document is checked against the
gbXML 7.03 schema (``openstudio.XMLValidator.gbxmlValidator``), read into a model
(``openstudio.gbxml.GbXMLReverseTranslator``), completed with what gbXML does not carry to
OpenStudio, and translated to EnergyPlus (``openstudio.energyplus.ForwardTranslator``). A
failure at any step is a bug in meshplan (the gbXML is its own), reported as such.

What is added to the model read from the gbXML (every default named in the files, as object
names and comments, and listed in the IDF's header):

* names: the spaces, zones and surfaces get the gbXML ``Name`` (their room's label) instead of
  the gbXML id;
* each space's volume and ceiling height from its story (area times floor-to-ceiling height);
* the second copy of each shared surface (OpenStudio makes it in the second space by reversing
  the first) is moved onto that space's own boundary: across the wall's thickness for a wall, up
  through the slab for a floor, so that every space is closed on its own;
* the site (``site_lat_deg``, ``site_lon_deg``, a time zone from the longitude) and the
  building's north axis (``north_deg``: the bearing of the model's +y, plan -z);
* a thermostat in every zone with constant schedules at :data:`~meshplan.export.gbxml.HEATING_SETPOINT_C`
  and :data:`~meshplan.export.gbxml.COOLING_SETPOINT_C`, and ideal loads for HVAC (the scan says
  nothing of the building's systems); the annotated thermostat's label and position as the
  zone's additional properties (``meshplan_thermostat``), each sensor's as its space's
  (``meshplan_sensor <label>``), and both in the IDF's header (EnergyPlus has no object for them).

Constructions come from the gbXML (its stated defaults). No internal loads, infiltration or
weather file are set: attach a weather file for the site before simulating.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import MeshplanError
from .gbxml import CONSTRUCTIONS, COOLING_SETPOINT_C, HEATING_SETPOINT_C, MATERIALS, WINDOW, EnergyModel, _annotations, energy_model, gbxml_bytes

if TYPE_CHECKING:  # pragma: no cover
    from ..result import Result

__all__ = ["energy_files", "openstudio_model", "translate_idf"]

#: Degrees of longitude per hour of standard time: the time zone assumed from the site.
DEG_PER_HOUR = 15.0


def require_openstudio() -> Any:
    """The ``openstudio`` module, or a :class:`MeshplanError` saying how to install it."""
    try:
        import openstudio
    except ImportError:
        raise MeshplanError(
            "EnergyPlus and OpenStudio export need openstudio, which is not installed", "pip install 'meshplan[energy]', or leave out --idf and --osm"
        ) from None
    # OpenStudio logs every message to standard output: meshplan reports what matters itself
    logger = openstudio.Logger.instance().standardOutLogger()
    logger.setLogLevel(openstudio.Fatal)
    logger.disable()
    return openstudio


def _messages(items: Any) -> list[str]:
    return [" ".join(str(m.logMessage()).split()) for m in items]


def _read_gbxml(os_: Any, data: bytes) -> Any:
    """Validate the gbXML against its schema and read it into an OpenStudio model."""
    with tempfile.TemporaryDirectory(prefix="meshplan-gbxml-") as tmp:
        path = Path(tmp) / "model.xml"  # the validator wants the .xml extension
        path.write_bytes(data)
        validator = os_.XMLValidator.gbxmlValidator()
        if not validator.validate(os_.path(str(path))):
            raise RuntimeError(f"the gbXML meshplan wrote does not validate against the gbXML schema: {'; '.join(_messages(validator.errors())[:3])}")
        rt = os_.gbxml.GbXMLReverseTranslator()
        loaded = rt.loadModel(os_.path(str(path)))
        errors = _messages(rt.errors())
        if not loaded.is_initialized() or errors:
            raise RuntimeError(f"OpenStudio could not read the gbXML meshplan wrote: {'; '.join(errors[:3]) or 'no model'}")
    return loaded.get()


def _feature(obj: Any, name: str) -> str | None:
    value = obj.additionalProperties().getFeatureAsString(name)
    return value.get() if value.is_initialized() else None


def _reversed(obj: Any) -> bool:
    """Whether OpenStudio made this surface as the reversed copy of a shared gbXML surface."""
    value = obj.additionalProperties().getFeatureAsBoolean("gbXMLReversed")
    return bool(value.get()) if value.is_initialized() else False


def _translate(os_: Any, surface: Any, offset: np.ndarray) -> None:
    """Move a surface (and its subsurfaces) by ``offset`` (m)."""
    if not np.any(offset):
        return
    t = os_.Vector3d(float(offset[0]), float(offset[1]), float(offset[2]))
    for s in (surface, *surface.subSurfaces()):
        s.setVertices([p + t for p in s.vertices()])


def _constant_schedule(os_: Any, model: Any, name: str, value: float, limits: Any) -> Any:
    schedule = os_.model.ScheduleRuleset(model, value)
    schedule.setName(name)
    schedule.setScheduleTypeLimits(limits)
    schedule.setComment(f"meshplan default: {value:g} C all year")
    return schedule


def openstudio_model(result: Result, model: EnergyModel | None = None, data: bytes | None = None) -> Any:
    """The OpenStudio model of a result, read from its gbXML and completed (module docstring).

    Parameters
    ----------
    result
        What :func:`meshplan.run` found.
    model
        Its energy model (:func:`~meshplan.export.gbxml.energy_model`), when already made.
    data
        Its gbXML (:func:`~meshplan.export.gbxml.gbxml_bytes`), when already made.

    Returns
    -------
    openstudio.model.Model
    """
    os_ = require_openstudio()
    if model is None:
        model = energy_model(result)
    if data is None:
        data = gbxml_bytes(result, model)
    m = _read_gbxml(os_, data)
    spaces = {sp.id: sp for sp in model.spaces}
    surfaces = {s.id: s for s in model.surfaces}
    export = result.options.export

    for obj in [*m.getSpaces(), *m.getThermalZones(), *m.getSurfaces(), *m.getSubSurfaces()]:
        name = _feature(obj, "displayName")
        if name:
            obj.setName(name)
    for space in m.getSpaces():
        sp = spaces.get(_feature(space, "gbXMLId") or "")
        if sp is None:  # pragma: no cover - every space comes from the gbXML
            continue
        space.setVolume(sp.volume)
        space.setCeilingHeight(sp.ceiling - sp.floor)
    for surface in m.getSurfaces():
        s = surfaces.get(_feature(surface, "gbXMLId") or "")
        if s is not None and _reversed(surface):
            _translate(os_, surface, s.offset)

    site = m.getSite()
    site.setName("meshplan site (--site-lat/--site-lon)")
    site.setLatitude(export.site_lat_deg)
    site.setLongitude(export.site_lon_deg)
    site.setTimeZone(float(max(-12, min(14, round(export.site_lon_deg / DEG_PER_HOUR)))))
    m.getBuilding().setNorthAxis(float(export.north_deg % 360.0))

    limits = os_.model.ScheduleTypeLimits(m)
    limits.setName("meshplan temperature")
    limits.setUnitType("Temperature")
    heating = _constant_schedule(os_, m, f"meshplan default heating setpoint {HEATING_SETPOINT_C:g} C", HEATING_SETPOINT_C, limits)
    cooling = _constant_schedule(os_, m, f"meshplan default cooling setpoint {COOLING_SETPOINT_C:g} C", COOLING_SETPOINT_C, limits)
    notes = _annotations(result, model)
    index = {sp.id: k for k, sp in enumerate(model.spaces)}
    for zone in m.getThermalZones():
        thermostat = os_.model.ThermostatSetpointDualSetpoint(m)
        thermostat.setName(f"{zone.nameString()} thermostat")
        thermostat.setHeatingSetpointTemperatureSchedule(heating)
        thermostat.setCoolingSetpointTemperatureSchedule(cooling)
        zone.setThermostatSetpointDualSetpoint(thermostat)
        zone.setUseIdealAirLoads(True)
        for space in zone.spaces():
            k = index.get(_feature(space, "gbXMLId") or "")
            for kind, label, point, _ in notes.get(k, []) if k is not None else []:
                where = " ".join(f"{v:.4f}" for v in point)
                if kind == "thermostat":
                    zone.additionalProperties().setFeature("meshplan_thermostat", f"{label} at {where} m")
                    thermostat.setComment(f"meshplan: thermostat {label} at {where} m")
                else:
                    space.additionalProperties().setFeature(f"meshplan_{kind} {label}", f"{where} m")
    for construction in m.getConstructions():
        construction.setComment("meshplan default construction (layers from the outside in)")
    return m


def _header(result: Result, model: EnergyModel) -> str:
    """The IDF's header: what meshplan assumed, and where the annotations are."""
    export = result.options.export
    lines = [
        "meshplan energy model: one zone per room, translated from meshplan's gbXML by OpenStudio",
        f"scan: {result.input.path}",
        f"site: latitude {export.site_lat_deg:.4f}, longitude {export.site_lon_deg:.4f} (--site-lat/--site-lon); "
        f"north axis {export.north_deg % 360.0:g} deg (bearing of +y, plan -z)",
        f"default schedules: heating setpoint {HEATING_SETPOINT_C:g} C and cooling setpoint {COOLING_SETPOINT_C:g} C all year; "
        "HVAC: ideal loads; no internal loads, infiltration or weather file",
        "default constructions (outside to inside):",
    ]
    for name, layers in CONSTRUCTIONS.values():
        lines.append(f"  {name}: " + ", ".join(MATERIALS[m][0].removeprefix("meshplan default: ") for m in layers))
    lines.append(f"  {WINDOW[1]}: U {WINDOW[2]:g} W/m2-K, SHGC {WINDOW[3]:g}, visible transmittance {WINDOW[4]:g}")
    labels = {k: sp.label for k, sp in enumerate(model.spaces)}
    for k, items in sorted(_annotations(result, model).items(), key=lambda kv: -1 if kv[0] is None else kv[0]):
        for kind, label, point, _ in items:
            where = " ".join(f"{v:.4f}" for v in point)
            lines.append(f"{kind} {label} at {where} m (model coordinates) in {labels[k] if k is not None else 'no room'}")
    return "\n".join("! " + " ".join(line.split("\n")) for line in lines)


def translate_idf(result: Result, osm: Any, model: EnergyModel | None = None) -> str:
    """The EnergyPlus input file of an OpenStudio model (:func:`openstudio_model`).

    Raises
    ------
    RuntimeError
        When OpenStudio's forward translator reports an error (a bug in meshplan).
    """
    os_ = require_openstudio()
    if model is None:
        model = energy_model(result)
    ft = os_.energyplus.ForwardTranslator()
    workspace = ft.translateModel(osm)
    errors = _messages(ft.errors())
    if errors:
        raise RuntimeError(f"OpenStudio could not translate meshplan's model to EnergyPlus: {'; '.join(errors[:3])}")
    idf = workspace.toIdfFile()
    idf.setHeader(_header(result, model))
    return str(idf)


def energy_files(result: Result, idf: bool, osm: bool, model: EnergyModel | None = None, data: bytes | None = None) -> dict[str, bytes]:
    """``model.idf`` and/or ``model.osm`` of a result, as ``name -> bytes``."""
    if not (idf or osm):
        return {}
    if model is None:
        model = energy_model(result)
    m = openstudio_model(result, model, data)
    files: dict[str, bytes] = {}
    if osm:
        files["model.osm"] = str(m).encode("utf-8")
    if idf:
        files["model.idf"] = translate_idf(result, m, model).encode("utf-8")
    return files


"""Export a scenario as an SSP 1.0 archive that third-party co-simulation masters can run.

The archive holds ``SystemStructure.ssd`` and the scene's FMUs under ``resources/``. The SSD
declares the components, their connections, each component's parameter values as an inline
``ssd:ParameterBinding`` (one ``ssv:ParameterSet`` named after the scenario, so that a master
that applies parameter sets by name, such as Ecos, gets all of them with one name) and a
``ssd:DefaultExperiment`` with the scenario's stop time.

Wiring (SSP connections cannot subtract, so BlockSpring forms ``dv = V - v`` itself)::

    Drive.V -> BlockSpring.V,  BlockSpring.dv -> Friction.dv,  Friction.F -> BlockSpring.F

The constant conditions ``n`` and ``T`` are inputs of Friction; they are bound like parameters
(SSP allows parameter values on inputs) and deliberately *not* declared as connectors: fmpy's
SSP master writes every declared input connector before each step, from its connection or 0.0
when unconnected, which would overwrite the bound value. For the same reason an input is only
declared as a connector when something is connected to it.

Only the standard ``ssd:``, ``ssc:`` and ``ssv:`` prefixes are used: libcosim and Ecos look the
elements up by their prefixed names.
"""
from __future__ import annotations

import os
import uuid
import zipfile
from dataclasses import fields
from pathlib import Path
from typing import Any
from xml.etree import ElementTree as ET

from ..physics.friction import REGIMES, LubricantConstants
from .scenario import Scenario

SSD = "http://ssp-standard.org/SSP1/SystemStructureDescription"
SSC = "http://ssp-standard.org/SSP1/SystemStructureCommon"
SSV = "http://ssp-standard.org/SSP1/SystemStructureParameterValues"
FMU_MIME = "application/x-fmu-sharedlibrary"

# Friction FMU parameter name <- scenario.friction.effects field.
EFFECT_PARAMETERS = {"melting": "melting", "pressure_term": "pressure",
                     "temperature_term": "temperature", "viscous_term": "viscous",
                     "elastic_term": "elastic"}

# Every connection the scene can have: (start FMU, output) -> (end FMU, input).
CONNECTIONS = (
    ("Drive", "V", "BlockSpring", "V"),
    ("BlockSpring", "dv", "Friction", "dv"),
    ("Friction", "F", "BlockSpring", "F"),
)
# Outputs declared as connectors so that masters that only record connectors (fmpy) show them.
OUTPUTS = {"Drive": ("X", "V", "a"), "BlockSpring": ("x", "v", "a", "dv"), "Friction": ("F", "f")}
COMPONENT_ORDER = ("Drive", "BlockSpring", "Friction")


def parameter_values(scenario: Scenario) -> dict[str, dict[str, float | int | bool]]:
    """The value of every FMU parameter (and constant input) the scene sets, per component.

    Python types carry the FMI types: float -> Real, int -> Integer, bool -> Boolean.
    """
    values: dict[str, dict[str, float | int | bool]] = {}
    for name in _components(scenario):
        if name == "Drive":
            values[name] = {"A": float(scenario.drive.A), "omega": float(scenario.drive.omega)}
        elif name == "BlockSpring":
            b = scenario.block
            values[name] = {"M": float(b.M), "K": float(b.K), "x0": float(b.x0), "v0": float(b.v0)}
        elif name == "Friction":
            fr = scenario.friction
            p: dict[str, float | int | bool] = {"regime": int(REGIMES[fr.regime])}
            for key in ("mu_friction", "S", "m", "gamma", "f0"):
                p[key] = float(getattr(fr, key))
            for f in fields(LubricantConstants):
                p[f.name] = float(getattr(fr.lubricant, f.name))
            for fmu_name, effect in EFFECT_PARAMETERS.items():
                p[fmu_name] = bool(getattr(fr.effects, effect))
            p["n"] = float(scenario.conditions.n)  # constant inputs
            p["T"] = float(scenario.conditions.T)
            values[name] = p
    return values


def export_ssp(scenario: Scenario, out: Path, fmu_dir: Path = Path("build")) -> Path:
    """Write ``out`` as an SSP 1.0 archive of the scenario; returns ``out``.

    ``fmu_dir`` holds the built FMUs (``<Name>.fmu``). A missing FMU raises
    :class:`FileNotFoundError` naming the file, before anything is written. The archive is
    written aside and renamed into place, so ``out`` appears whole or not at all.
    """
    out, fmu_dir = Path(out), Path(fmu_dir)
    components = _components(scenario)
    sources = {}
    for name in components:
        path = fmu_dir / f"{name}.fmu"
        if not path.is_file():
            error = FileNotFoundError(f"FMU {path} not found (build it with tribofmu.build.build_fmus)")
            error.filename = str(path)
            raise error
        sources[name] = path
    ssd = system_structure(scenario)
    out.parent.mkdir(parents=True, exist_ok=True)
    # Beside the target (same file system, so the rename is atomic); opened with "x" rather
    # than mkstemp so that the archive gets the usual umask-based permissions, not 0600.
    tmp = out.with_name(f".{out.name}.{os.getpid()}.{uuid.uuid4().hex}.tmp")
    try:
        with open(tmp, "xb") as handle, zipfile.ZipFile(handle, "w", zipfile.ZIP_DEFLATED) as zf:
            zf.writestr("SystemStructure.ssd", ssd)
            for name, path in sources.items():
                zf.write(path, f"resources/{name}.fmu")
        os.replace(tmp, out)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return out


def system_structure(scenario: Scenario) -> bytes:
    """The ``SystemStructure.ssd`` document of the scenario (UTF-8 XML)."""
    for prefix, uri in (("ssd", SSD), ("ssc", SSC), ("ssv", SSV)):
        ET.register_namespace(prefix, uri)
    components = _components(scenario)
    connections = [c for c in CONNECTIONS if c[0] in components and c[2] in components]
    connected_inputs = {(c[2], c[3]) for c in connections}
    values = parameter_values(scenario)
    set_name = scenario.name

    root = ET.Element(f"{{{SSD}}}SystemStructureDescription", {"name": scenario.name, "version": "1.0"})
    system_attrs = {"name": scenario.name}
    if scenario.title:
        system_attrs["description"] = scenario.title
    system = ET.SubElement(root, f"{{{SSD}}}System", system_attrs)
    elements = ET.SubElement(system, f"{{{SSD}}}Elements")
    for name in components:
        comp = ET.SubElement(elements, f"{{{SSD}}}Component",
                             {"name": name, "type": FMU_MIME, "source": f"resources/{name}.fmu"})
        connectors = ET.SubElement(comp, f"{{{SSD}}}Connectors")
        for comp_name, var in sorted(connected_inputs):
            if comp_name == name:
                _connector(connectors, var, "input")
        for var in OUTPUTS[name]:
            _connector(connectors, var, "output")
        if values.get(name):
            bindings = ET.SubElement(comp, f"{{{SSD}}}ParameterBindings")
            binding = ET.SubElement(bindings, f"{{{SSD}}}ParameterBinding")
            holder = ET.SubElement(binding, f"{{{SSD}}}ParameterValues")
            pset = ET.SubElement(holder, f"{{{SSV}}}ParameterSet", {"version": "1.0", "name": set_name})
            params = ET.SubElement(pset, f"{{{SSV}}}Parameters")
            for var, value in values[name].items():
                param = ET.SubElement(params, f"{{{SSV}}}Parameter", {"name": var})
                kind, text = _typed(value)
                ET.SubElement(param, f"{{{SSV}}}{kind}", {"value": text})
    if connections:
        conns = ET.SubElement(system, f"{{{SSD}}}Connections")
        for start, out_var, end, in_var in connections:
            ET.SubElement(conns, f"{{{SSD}}}Connection", {
                "startElement": start, "startConnector": out_var,
                "endElement": end, "endConnector": in_var})
    ET.SubElement(root, f"{{{SSD}}}DefaultExperiment",
                  {"startTime": "0.0", "stopTime": repr(float(scenario.stop_time))})
    ET.indent(root)
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True)


def _components(scenario: Scenario) -> list[str]:
    return [name for name in COMPONENT_ORDER if name in scenario.fmus]


def _connector(parent: ET.Element, name: str, kind: str) -> None:
    connector = ET.SubElement(parent, f"{{{SSD}}}Connector", {"name": name, "kind": kind})
    ET.SubElement(connector, f"{{{SSC}}}Real")


def _typed(value: Any) -> tuple[str, str]:
    if isinstance(value, bool):
        return "Boolean", "true" if value else "false"
    if isinstance(value, int):
        return "Integer", str(value)
    return "Real", repr(float(value))

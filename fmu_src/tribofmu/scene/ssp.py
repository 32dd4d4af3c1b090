"""Export a scenario as an SSP 1.0 archive that third-party co-simulation masters can run.

The archive holds ``SystemStructure.ssd`` and the scene's FMUs under ``resources/``. The SSD
declares the components, their connections, each component's parameter values as an inline
``ssd:ParameterBinding`` (one ``ssv:ParameterSet`` named after the scenario, so that a master
that applies parameter sets by name, such as Ecos, gets all of them with one name) and a
``ssd:DefaultExperiment`` with the scenario's span and, as libcosim's
``com.opensimulationplatform`` annotation, the archive's communication step
(:func:`archive_step`).

The archive carries its scene even for masters that ignore parameter bindings (fmpy's
``simulate_ssp``, Ecos without a parameter-set name): each FMU copy in the archive has the
scene's values as the start values of its ``modelDescription.xml`` (the FMUs take their start
values from there) and the archive's span and step as its own ``DefaultExperiment``.

The components, connections, parameters and constant inputs are the scene's wiring
(:mod:`tribofmu.scene.wiring`); components are named after their FMUs (``BlockSpring.v``).

Constant inputs (Friction's conditions ``n`` and ``T`` today) are bound like parameters
(SSP allows parameter values on inputs) and deliberately *not* declared as connectors: fmpy's
SSP master writes every declared input connector before each step, from its connection or 0.0
when unconnected, which would overwrite the bound value. For the same reason an input is only
declared as a connector when something is connected to it.

Only the standard ``ssd:``, ``ssc:`` and ``ssv:`` prefixes are used for the standard's elements:
libcosim and Ecos look the elements up by their prefixed names. Tool-specific information is in
SSP vendor annotations, which other tools ignore: libcosim's step (``osp:``, on the
``DefaultExperiment``) and OMSimulator's fixed-step master with that step (``oms:``, the last
child of the root system; without it OMSimulator's command line aborts on import).
"""
from __future__ import annotations

import io
import math
import os
import uuid
import zipfile
from pathlib import Path
from typing import Any
from xml.etree import ElementTree as ET

from .. import __version__
from ..errors import FMUFileError  # a FileNotFoundError, and a TriboFMUError
from ..fmu_cache import find_fmus
from .scenario import Scenario
from .wiring import connections, instances

SSD = "http://ssp-standard.org/SSP1/SystemStructureDescription"
SSC = "http://ssp-standard.org/SSP1/SystemStructureCommon"
SSV = "http://ssp-standard.org/SSP1/SystemStructureParameterValues"
OSP = "http://opensimulationplatform.com/SSP/OSPAnnotations"  # libcosim's DefaultExperiment step
# OMSimulator's vendor annotation (its schema's namespace): the root system's master and step
OMS = "https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd"
FMU_MIME = "application/x-fmu-sharedlibrary"
GENERATION_TOOL = "tribofmu"  # the SSD's generationTool starts with it: an archive we wrote
# Communication steps per period of the fastest motion the host's steps must resolve. The pair
# resolves the block and its friction inside its doStep and follows the drive linearly within
# a host step: the host step need only resolve the drive (Fig. 2 at T/2000 = 1e-4 s: nRMS(v)
# below 1e-3, tests/external). Three FMUs exchange the friction force once per step, explicitly:
# the step must also resolve the block's own oscillation, sqrt(2K/M), and more finely (their
# error is first order in h: Fig. 5 Newtonian 0.88 % at 1e-4 s).
STEPS_PER_PERIOD = {True: 2000, False: 5000}


def archive_step(scenario: Scenario, pair: bool = False) -> float:
    """The fixed communication step [s] an archive proposes (its DefaultExperiment): the
    period of the fastest motion the host must resolve over :data:`STEPS_PER_PERIOD`, rounded
    down to 1, 2 or 5 times a power of ten. Three FMUs at dry stick chatter at any step: only
    the pair archive holds stick exactly."""
    rates = [scenario.drive.omega] if "Drive" in scenario.fmus else []
    if not pair:
        rates.append(math.sqrt(2.0 * scenario.block.K / scenario.block.M))
    step = 2.0 * math.pi / max(rates) / STEPS_PER_PERIOD[pair]
    decade = 10.0 ** math.floor(math.log10(step))
    mantissa = max(m for m in (1.0, 2.0, 5.0, 10.0) if m * decade <= step * (1 + 1e-12))
    return float(f"{mantissa * decade:.1g}")


def parameter_values(scenario: Scenario, pair: bool = False) -> dict[str, dict[str, float | int | bool]]:
    """The value of every FMU parameter (and constant input) the scene sets, per component.

    Python types carry the FMI types: float -> Real, int -> Integer, bool -> Boolean.
    pair: BlockSpring and Friction replaced by TriboPair (see :func:`export_ssp`).
    """
    return {inst.fmu.name: {**inst.start_values, **inst.constant_inputs}
            for inst in instances(scenario, pair)}


def export_ssp(scenario: Scenario, out: Path, fmu_dir: Path | None = None, pair: bool = False) -> Path:
    """Write ``out`` as an SSP 1.0 archive of the scenario; returns ``out``.

    pair: BlockSpring and Friction are replaced by the TriboPair FMU, which couples them
    implicitly inside itself (for masters that exchange values once per step); a scene
    without both raises :class:`~tribofmu.errors.ScenarioError`.

    ``fmu_dir`` holds the built FMUs (``<Name>.fmu``; default: the per-user cache of FMUs
    built from this source, see :func:`tribofmu.build.default_fmu_dir`). A missing FMU raises
    :class:`FileNotFoundError` naming the file, before anything is written. The archive is
    written aside and renamed into place, so ``out`` appears whole or not at all. An existing
    ``out`` is replaced only when it is an archive this function wrote; anything else raises
    :class:`FileExistsError` before anything is built or written (:func:`check_replaceable_archive`).
    """
    check_replaceable_archive(Path(out))
    # the cache's FMUs, checked (or built); a given folder's, required
    fmu_dir = find_fmus([inst.fmu.name for inst in instances(scenario, pair)], fmu_dir,
                        build=None if fmu_dir is None else False)
    out, fmu_dir = Path(out), Path(fmu_dir)
    sources = {}  # archive member -> built FMU
    for inst in instances(scenario, pair):
        path = fmu_dir / inst.fmu.file
        if not path.is_file():
            error = FMUFileError(f"FMU {path} not found (build it with tribofmu.build.build_fmus)")
            error.filename = str(path)
            raise error
        sources[f"resources/{inst.fmu.file}"] = path
    ssd = system_structure(scenario, pair)
    values = parameter_values(scenario, pair)
    experiment = (0.0, float(scenario.stop_time), archive_step(scenario, pair))
    out.parent.mkdir(parents=True, exist_ok=True)
    # Beside the target (same file system, so the rename is atomic); opened with "x" rather
    # than mkstemp so that the archive gets the usual umask-based permissions, not 0600.
    tmp = out.with_name(f".{out.name}.{os.getpid()}.{uuid.uuid4().hex}.tmp")
    try:
        with open(tmp, "xb") as handle, zipfile.ZipFile(handle, "w", zipfile.ZIP_DEFLATED) as zf:
            zf.writestr("SystemStructure.ssd", ssd)
            for member, path in sources.items():
                name = Path(member).stem
                zf.writestr(member, fmu_with_start_values(path, values.get(name, {}), experiment))
        os.replace(tmp, out)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return out


SSD_BYTES = 1_000_000  # an SSD tribofmu writes is a few kB


def check_replaceable_archive(out: Path) -> None:
    """Raise :class:`FileExistsError` unless ``out`` is missing or a regular file that is an
    SSP archive tribofmu wrote (a zip whose ``SystemStructure.ssd`` names tribofmu as its
    ``generationTool``): an export never replaces a user's file, a link or a folder."""
    out = Path(out)
    if not out.exists() and not out.is_symlink():
        return
    if out.is_symlink() or not out.is_file():
        kind = "a symbolic link" if out.is_symlink() else "a folder" if out.is_dir() else "not a regular file"
        raise FileExistsError(f"{out} is {kind}; give a new file or an archive written by tribofmu export-ssp")
    try:
        with zipfile.ZipFile(out) as archive, archive.open("SystemStructure.ssd") as ssd:
            text = ssd.read(SSD_BYTES + 1)  # bounded: an SSD that inflates to 6 GB is not ours
        if len(text) > SSD_BYTES:
            raise ValueError("not an SSD of ours: too large")
        root = ET.fromstring(text)
        ours = (root.tag == f"{{{SSD}}}SystemStructureDescription"
                and root.get("generationTool", "").split(" ")[0] == GENERATION_TOOL)
    except Exception:  # a damaged or hostile archive fails in many ways (zlib, EOF, encryption): none is ours
        ours = False
    if not ours:
        raise FileExistsError(f"{out} exists and is not an archive written by tribofmu export-ssp; "
                              "it is not replaced (remove it or give another file)")


def fmu_with_start_values(path: Path, values: dict[str, Any],
                          experiment: tuple[float, float, float] | None = None) -> bytes:
    """The FMU file at ``path`` with ``values`` (variable name -> value) as the start values
    of its ``modelDescription.xml`` and, if given, ``experiment`` (start, stop, step [s]) as
    its ``DefaultExperiment``; every other member is copied unchanged. FMI 2.0 and 3.0."""
    with zipfile.ZipFile(path) as source:
        root = ET.fromstring(source.read("modelDescription.xml"))
        fmi3 = root.get("fmiVersion", "").startswith("3")
        nodes = {node.get("name"): node for node in root.find("ModelVariables")}
        for name, value in values.items():
            node = nodes.get(name)
            typed = node if fmi3 or node is None else next(iter(node), None)
            if typed is None or typed.get("start") is None:
                raise ValueError(f"{path.name}: no variable {name!r} with a start value to set")
            typed.set("start", _typed(value)[1])
        if experiment is not None:
            default = root.find("DefaultExperiment")
            if default is None:  # schema order: after LogCategories, before ModelVariables
                default = ET.Element("DefaultExperiment")
                root.insert(list(root).index(root.find("ModelVariables")), default)
            for key, number in zip(("startTime", "stopTime", "stepSize"), experiment):
                default.set(key, repr(float(number)))
        description = ET.tostring(root, encoding="UTF-8", xml_declaration=True)
        buffer = io.BytesIO()
        with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as copy:
            for info in source.infolist():
                data = description if info.filename == "modelDescription.xml" else source.read(info)
                copy.writestr(info, data, compress_type=zipfile.ZIP_DEFLATED)
    return buffer.getvalue()


def system_structure(scenario: Scenario, pair: bool = False) -> bytes:
    """The ``SystemStructure.ssd`` document of the scenario (UTF-8 XML); pair: as
    :func:`export_ssp`."""
    for prefix, uri in (("ssd", SSD), ("ssc", SSC), ("ssv", SSV), ("osp", OSP), ("oms", OMS)):
        ET.register_namespace(prefix, uri)
    links = connections(scenario, pair)
    connected_inputs = {(c.end, c.input) for c in links}
    values = parameter_values(scenario, pair)
    set_name = scenario.name

    root = ET.Element(f"{{{SSD}}}SystemStructureDescription", {
        "name": scenario.name, "version": "1.0", "generationTool": f"{GENERATION_TOOL} {__version__}"})
    system_attrs = {"name": scenario.name}
    if scenario.title:
        system_attrs["description"] = scenario.title
    system = ET.SubElement(root, f"{{{SSD}}}System", system_attrs)
    elements = ET.SubElement(system, f"{{{SSD}}}Elements")
    for inst in instances(scenario, pair):
        name = inst.fmu.name
        comp = ET.SubElement(elements, f"{{{SSD}}}Component",
                             {"name": name, "type": FMU_MIME, "source": f"resources/{inst.fmu.file}"})
        connectors = ET.SubElement(comp, f"{{{SSD}}}Connectors")
        for comp_name, var in sorted(connected_inputs):
            if comp_name == name:
                _connector(connectors, var, "input")
        for var in inst.fmu.outputs:
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
    if links:
        conns = ET.SubElement(system, f"{{{SSD}}}Connections")
        for c in links:
            ET.SubElement(conns, f"{{{SSD}}}Connection", {
                "startElement": c.start, "startConnector": c.output,
                "endElement": c.end, "endConnector": c.input})
    _openmodelica_annotation(system, archive_step(scenario, pair))
    default = ET.SubElement(root, f"{{{SSD}}}DefaultExperiment",
                            {"startTime": "0.0", "stopTime": repr(float(scenario.stop_time))})
    # SSP 1.0 has no step size: libcosim reads it from its own annotation
    annotation = ET.SubElement(ET.SubElement(default, f"{{{SSD}}}Annotations"), f"{{{SSC}}}Annotation",
                               {"type": "com.opensimulationplatform"})
    ET.SubElement(ET.SubElement(annotation, f"{{{OSP}}}Algorithm"), f"{{{OSP}}}FixedStepAlgorithm",
                  {"baseStepSize": repr(archive_step(scenario, pair))})
    ET.indent(root)
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True)


def _openmodelica_annotation(system: ET.Element, step: float) -> None:
    """OMSimulator's annotation of the root system, as its own SSP export writes it: a
    fixed-step master (``oms-ma``) at the archive's step. OMSimulator's importer
    (``oms_importFile``, its command line) takes the root system's type from this annotation
    and aborts without it; it must be the system's last child (after ``ssd:Connections``) and
    its ``description`` must not be empty. Other tools ignore annotations of a type they do
    not know, as SSP provides. The stop time is the ``DefaultExperiment``'s (OMSimulator's
    command line takes it from ``--stopTime``, see docs/hosts.md)."""
    annotation = ET.SubElement(ET.SubElement(system, f"{{{SSD}}}Annotations"), f"{{{SSC}}}Annotation",
                               {"type": "org.openmodelica"})
    info = ET.SubElement(ET.SubElement(annotation, f"{{{OMS}}}Annotations"), f"{{{OMS}}}SimulationInformation")
    ET.SubElement(info, f"{{{OMS}}}FixedStepMaster",
                  {"description": "oms-ma", "stepSize": repr(float(step)), "relativeTolerance": "0.0001"})


def _connector(parent: ET.Element, name: str, kind: str) -> None:
    connector = ET.SubElement(parent, f"{{{SSD}}}Connector", {"name": name, "kind": kind})
    ET.SubElement(connector, f"{{{SSC}}}Real")


def _typed(value: Any) -> tuple[str, str]:
    if isinstance(value, bool):
        return "Boolean", "true" if value else "false"
    if isinstance(value, int):
        return "Integer", str(value)
    return "Real", repr(float(value))

"""What pythonfmu 0.7 leaves out of ``modelDescription.xml`` (units, ``initial`` attributes,
``InitialUnknowns``, the outputs' dependencies in ``ModelStructure``), and the start values read
back from an FMU's own description (FMI: the start value is the value at instantiation, so a
copy whose description was rewritten by ``tribofmu export-ssp`` starts from the rewritten
values)."""
from __future__ import annotations

import os
from typing import Any
from xml.etree.ElementTree import Element, SubElement, parse

from .fmi import FMI_VERSION, Causality


def _start_values(resources: str | None) -> dict[str, str]:
    """name -> start text of every variable with a start value in the modelDescription.xml
    beside ``resources`` (empty when there is none, e.g. while pythonfmu builds the FMU)."""
    if not resources or os.path.basename(os.path.normpath(resources)) != "resources":
        return {}
    path = os.path.join(os.path.dirname(os.path.normpath(resources)), "modelDescription.xml")
    try:
        root = parse(path).getroot()
    except (OSError, SyntaxError):
        return {}
    starts = {}
    for node in root.iterfind("ModelVariables/*"):
        typed = node if FMI_VERSION == 3 else next(iter(node), None)  # FMI 2: <Real start=.../>
        if typed is not None and typed.get("start") is not None:
            starts[node.get("name")] = typed.get("start")
    return starts


def _parse_start(kind: type, text: str) -> Any:
    if kind is bool:
        if text not in ("true", "false", "1", "0"):
            raise ValueError(f"not a Boolean: {text!r}")
        return text in ("true", "1")
    return kind(text)


class ModelDescriptionMixin:
    """``to_xml`` for :class:`.base.TriboModel`: pythonfmu's description plus units and the
    model structure declared with ``declare``."""

    def to_xml(self, model_options: dict[str, str] = dict()) -> Element:
        self._describing = True  # pythonfmu reads each start value through the getters
        try:
            root = super().to_xml(model_options)
        finally:
            self._describing = False
        units = sorted(set(self._units.values()))
        unit_defs = Element("UnitDefinitions")
        for unit in units:
            SubElement(unit_defs, "Unit", name=unit)
        # UnitDefinitions precede LogCategories in the FMI 2.0 and 3.0 schema order.
        position = list(root).index(root.find("CoSimulation")) + 1
        root.insert(position, unit_defs)
        if FMI_VERSION == 3:
            self._fmi3_variables_and_structure(root)
        else:
            self._fmi2_variables_and_structure(root)
        return root

    def _fmi2_variables_and_structure(self, root: Element) -> None:
        index = {v.name: i + 1 for i, v in enumerate(self.vars.values())}
        for node in root.find("ModelVariables"):
            name = node.get("name")
            real = node.find("Real")
            if real is not None and name in self._units:
                real.set("unit", self._units[name])
            var = next(v for v in self.vars.values() if v.name == name)
            if var.causality == Causality.output:
                for child in node:
                    child.attrib.pop("start", None)  # initial="calculated" forbids a start
        structure = root.find("ModelStructure")
        for child in list(structure):
            structure.remove(child)
        outputs = [v for v in self.vars.values() if v.causality == Causality.output]
        if outputs:
            out_node = SubElement(structure, "Outputs")
            init_node = SubElement(structure, "InitialUnknowns")
            for v in outputs:
                deps = " ".join(str(index[d]) for d in self._depends_on[v.name])
                SubElement(out_node, "Unknown", index=str(index[v.name]), dependencies=deps)
                # No dependencies attribute: initially an output may depend on anything.
                SubElement(init_node, "Unknown", index=str(index[v.name]))

    def _fmi3_variables_and_structure(self, root: Element) -> None:
        # FMI 3.0 names variables by valueReference (no indices), types are elements of their own.
        reference = {v.name: v.value_reference for v in self.vars.values()}
        for node in root.find("ModelVariables"):
            name = node.get("name")
            if node.tag == "Float64" and name in self._units:
                node.set("unit", self._units[name])
            if name in reference and self.vars[reference[name]].causality == Causality.output:
                node.attrib.pop("start", None)  # initial="calculated" forbids a start
        structure = root.find("ModelStructure")
        for child in list(structure):
            structure.remove(child)
        outputs = [v for v in self.vars.values() if v.causality == Causality.output]
        for v in outputs:
            deps = " ".join(str(reference[d]) for d in self._depends_on[v.name])
            SubElement(structure, "Output", valueReference=str(v.value_reference), dependencies=deps)
        for v in outputs:
            # No dependencies attribute: initially an output may depend on anything.
            SubElement(structure, "InitialUnknown", valueReference=str(v.value_reference))

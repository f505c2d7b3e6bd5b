"""Model descriptions of the native (C) FMUs, FMI 2.0 and FMI 3.0, from the interface tables.

The native FMUs expose exactly the variables of the pythonfmu ones: the same names, value
references (the position in the unit's table, inputs then outputs then parameters, as pythonfmu
registers them), causalities, variabilities, types and start values, the same units, default
experiment and model structure.  So the FMI 2.0 description is written in the shape pythonfmu
writes and then completed by the same :func:`orchestration.packaging.fmu_model_description.complete`; the
FMI 3.0 description is a translation of it:

* ``<Float64>``, ``<Int32>``, ``<Boolean>``, ``<String><Start value=.../></String>`` elements with
  the ScalarVariable's attributes; ``instantiationToken`` for ``guid``;
* ``<ModelStructure>``: ``<Output>`` and ``<InitialUnknown>`` by value reference (FMI 3.0 refers
  to variables by value reference, FMI 2.0 by index), the same (empty) dependencies;
* the independent variable ``time`` [s] FMI 3.0 requires, with the first value reference after
  the table's (the others keep theirs);
* ``<CoSimulation>``: ``canGetAndSetFMUState`` (capital S in 3.0), ``needsExecutionTool="false"``,
  no intermediate update, no event mode; the controller's sample period ``Ts`` (its start value) as
  ``fixedInternalStepSize``.

Both say ``needsExecutionTool="false"``: the binaries need nothing but the C library.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import satmotor.interface as itf
from orchestration.packaging.fmu_model_description import complete, variables

GENERATION_TOOL = "satmotor native C glue"
DATE = "2026-01-01T00:00:00Z"  # fixed: reproducible builds
_FMI3_TYPE = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "String": "String"}
UNIT_DESCRIPTION = _UNIT = {"SaturatedInductionMotor": itf.PLANT_DESCRIPTION,
         "BacksteppingController": itf.CONTROLLER_DESCRIPTION}
LOG_CATEGORIES = (("logStatusWarning", "fmi2Warning"), ("logStatusDiscard", "fmi2Discard"),
                  ("logStatusError", "fmi2Error"), ("logStatusFatal", "fmi2Fatal"))


def _start(var):
    if var.type == "Boolean":
        return "true" if var.start else "false"
    if var.type == "Real":  # shortest round-trip repr, without a trailing ".0" (as pythonfmu writes them)
        text = repr(float(var.start))
        return text[:-2] if text.endswith(".0") else text
    return str(var.start)


def _xml(root):
    ET.indent(root, space="\t")
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True).replace(
        b"<?xml version='1.0' encoding='UTF-8'?>", b'<?xml version="1.0" encoding="UTF-8"?>', 1) + b"\n"


def fmi2(name, guid="{GUID}"):
    """FMI 2.0 modelDescription.xml (bytes) of the native FMU ``name``."""
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "2.0", "modelName": name, "guid": guid, "generationTool": GENERATION_TOOL,
        "generationDateAndTime": DATE, "variableNamingConvention": "structured",
        "description": _UNIT[name], "author": itf.AUTHOR})
    ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": name, "needsExecutionTool": "false",
        "canHandleVariableCommunicationStepSize": "true" if name == "SaturatedInductionMotor" else "false",
        "canInterpolateInputs": "false", "canBeInstantiatedOnlyOncePerProcess": "false",
        "canNotUseMemoryManagementFunctions": "true", "canGetAndSetFMUstate": "true",
        "canSerializeFMUstate": "true"})
    cats = ET.SubElement(root, "LogCategories")
    for cat, status in LOG_CATEGORIES:
        ET.SubElement(cats, "Category", {"name": cat, "description": f"Log messages with {status} status."})
    ET.SubElement(cats, "Category", {"name": "logAll", "description": "Log all messages."})
    mv = ET.SubElement(root, "ModelVariables")
    for vr, var in enumerate(variables(name)):
        attrs = {"name": var.name, "valueReference": str(vr),
                 "description": f"{var.description} [{var.unit}]" if var.unit else var.description,
                 "causality": var.causality}
        if var.causality == "parameter":
            attrs["variability"] = "fixed"
        else:
            attrs["variability"] = "continuous" if var.type == "Real" else "discrete"
        if var.causality == "output":
            attrs["initial"] = "exact"
        sv = ET.SubElement(mv, "ScalarVariable", attrs)
        ET.SubElement(sv, var.type, {"start": _start(var)})
    ET.SubElement(root, "ModelStructure")
    return complete(name, _xml(root))


def sample_period_start():
    """The start value of the controller's sample period ``Ts`` [s]."""
    return next(v.start for v in itf.CONTROLLER_PARAMETERS if v.name == "Ts")


def fmi3(name, token="{GUID}"):
    """FMI 3.0 modelDescription.xml (bytes) of the native FMU ``name``: the FMI 2.0 one translated."""
    src = ET.fromstring(fmi2(name))
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "3.0", "modelName": name, "instantiationToken": token,
        "description": src.get("description"), "author": src.get("author"), "version": src.get("version"),
        "copyright": src.get("copyright"), "license": src.get("license"), "generationTool": GENERATION_TOOL,
        "generationDateAndTime": DATE, "variableNamingConvention": "structured"})
    cs = src.find("CoSimulation")
    ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": name, "needsExecutionTool": "false",
        "canBeInstantiatedOnlyOncePerProcess": "false", "canGetAndSetFMUState": "true",
        "canSerializeFMUState": "true",
        "canHandleVariableCommunicationStepSize": cs.get("canHandleVariableCommunicationStepSize"),
        "providesIntermediateUpdate": "false", "canReturnEarlyAfterIntermediateUpdate": "false",
        "hasEventMode": "false"})
    if name == "BacksteppingController":  # the sample period as FMI 3.0 lets a tool read it (docs/fmus.md)
        root.find("CoSimulation").set("fixedInternalStepSize", repr(float(sample_period_start())))
    root.append(src.find("UnitDefinitions"))
    cats = ET.SubElement(root, "LogCategories")
    for cat in src.find("LogCategories"):
        ET.SubElement(cats, "Category", {"name": cat.get("name"),
                                         "description": cat.get("description").replace("fmi2", "fmi3")})
    root.append(src.find("DefaultExperiment"))
    mv = ET.SubElement(root, "ModelVariables")
    svs = list(src.find("ModelVariables"))
    vr_of_index = {}
    for i, sv in enumerate(svs, start=1):
        typed = sv[0]
        vr_of_index[str(i)] = sv.get("valueReference")
        attrs = {k: sv.get(k) for k in ("name", "valueReference", "description", "causality", "variability",
                                         "initial") if sv.get(k) is not None}
        if typed.get("unit"):
            attrs["unit"] = typed.get("unit")
        el = ET.SubElement(mv, _FMI3_TYPE[typed.tag], attrs)
        if typed.get("start") is not None:
            if typed.tag == "String":
                ET.SubElement(el, "Start", {"value": typed.get("start")})
            else:
                el.set("start", typed.get("start"))
    # FMI 3.0 requires the independent variable; it takes the first value reference after the table's
    ET.SubElement(mv, "Float64", {"name": "time", "valueReference": str(len(svs)), "causality": "independent",
                                  "variability": "continuous", "description": "simulation time [s]",
                                  "unit": "s"})
    ms = ET.SubElement(root, "ModelStructure")
    for section, tag in (("Outputs", "Output"), ("InitialUnknowns", "InitialUnknown")):
        block = src.find(f"ModelStructure/{section}")
        for u in (block if block is not None else ()):
            deps = " ".join(vr_of_index[d] for d in (u.get("dependencies") or "").split())
            ET.SubElement(ms, tag, {"valueReference": vr_of_index[u.get("index")], "dependencies": deps})
    return _xml(root)


TERMINALS = {"SaturatedInductionMotor": itf.PLANT_TERMINALS,
             "BacksteppingController": itf.CONTROLLER_TERMINALS}
TERMINALS_FILE = "terminalsAndIcons/terminalsAndIcons.xml"


def terminals_and_icons(name):
    """FMI 3.0 ``terminalsAndIcons/terminalsAndIcons.xml`` (bytes) of the native FMU ``name``, from the
    terminal tables of :mod:`satmotor.interface`; every member a ``signal``."""
    root = ET.Element("fmiTerminalsAndIcons", {"fmiVersion": "3.0"})
    terminals = ET.SubElement(root, "Terminals")
    for t in TERMINALS[name]:
        el = ET.SubElement(terminals, "Terminal", {"name": t.name, "matchingRule": t.rule,
                                                   "terminalKind": t.kind, "description": t.description})
        for member, variable in t.members:
            ET.SubElement(el, "TerminalMemberVariable", {"variableName": variable, "memberName": member,
                                                         "variableKind": "signal"})
    return _xml(root)

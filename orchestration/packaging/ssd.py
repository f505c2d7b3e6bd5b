"""``SystemStructure.ssd``, the SSP 1.0 description of a scenario's system, generated from the
scenario and the FMUs' model descriptions (:func:`ssd_xml`): what ``export-ssp`` packs
(:mod:`orchestration.tools.ssp`) and what the libcosim engine loads
(:mod:`orchestration.run.libcosim_engine`).

One ``System`` with three ``Component`` elements named as the master's units, ``plant``,
``controller`` and ``signals``, each with its ``Connectors`` (the FMU's inputs and outputs, with
their types and units); the ``Connections`` of
:data:`orchestration.scenario.system.DEFAULT_CONNECTIONS` (``profile.X`` is ``signals.X``); a
``ParameterBinding`` per FMU with an inline ``ssv:ParameterSet`` holding the values the master sets:
the scenario's ``plant:`` and ``controller:`` overrides and the controller's
``Ts = step * controller_every`` (every parameter, a String one only where the scenario sets it);
``Units``; ``DefaultExperiment`` with the start (0) and stop time.

SSP 1.0 has no step size.  The Open Simulation Platform's annotations (type
``com.opensimulationplatform``, namespace :data:`OSP_NS`), which libcosim reads, give it: an
``osp:FixedStepAlgorithm`` with ``baseStepSize`` = the plant step ``h`` in the default experiment,
and an ``osp:StepSizeHint`` on a component stepped slower than ``h`` (the controller when
``Ts > h``; libcosim steps a component without one at the base step), each written so that libcosim
reads back the intended whole nanoseconds (:func:`seconds_text`), and ``numWorkerThreads`` =
:data:`WORKER_THREADS` (0).  OMSimulator reads only its own annotations (type :data:`OMS_TYPE`): the
System's first annotation gives its fixed-step master (``oms-ma``) and step ``h``; it refuses a
Component with ``Annotations`` (so a multi-rate package does not load there), an ``Annotations``
element at the root and ``ssv:String`` values (logged, the FMU's start value kept).  A fixed-step
engine steps every due unit from the values of the last communication point, which is the master's
``jacobi`` algorithm; an annotation of type :data:`SATMOTOR_TYPE` on the System records that, with
the scenario's own algorithm and the steps.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

from orchestration.packaging.fmu_model_description import SI_UNITS
from orchestration.scenario.problems import ProblemError
from orchestration.scenario.system import (
    CONTROLLER,
    DEFAULT_CONNECTIONS,
    LINK_CONNECTION,
    LINK_VOLTAGE,
    PLANT,
    PROFILE,
)

__all__ = ["NotExpressible", "ssd_xml", "seconds_text", "SSD_NS", "SSC_NS", "SSV_NS", "OSP_NS", "OMS_NS",
           "SIGNALS_UNIT", "COMPONENTS", "RESOURCES", "WORKER_THREADS"]

SSD_NS = "http://ssp-standard.org/SSP1/SystemStructureDescription"
SSC_NS = "http://ssp-standard.org/SSP1/SystemStructureCommon"
SSV_NS = "http://ssp-standard.org/SSP1/SystemStructureParameterValues"
OSP_NS = "http://opensimulationplatform.com/SSP/OSPAnnotations"
SATMOTOR_NS = "https://github.com/satmotor/satmotor/ssp"
OMS_NS = "https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd"
OSP_TYPE = "com.opensimulationplatform"
OMS_TYPE = "org.openmodelica"  # OMSimulator's vendor annotations
OMS_SOLVER = "oms-ma"  # OMSimulator's fixed-step master for co-simulation FMUs
SATMOTOR_TYPE = "org.satmotor.cosim"
SIGNALS_UNIT = "signals"  # the component of the ScenarioSignals FMU (the master's "profile" source)
COMPONENTS = (PLANT, CONTROLLER, SIGNALS_UNIT)
RESOURCES = {PLANT: "resources/SaturatedInductionMotor.fmu",
             CONTROLLER: "resources/BacksteppingController.fmu",
             SIGNALS_UNIT: "resources/ScenarioSignals.fmu"}

# libcosim matches the prefixed names (ssd:System, osp:Algorithm): these exact prefixes are written
PREFIXES = {"ssd": SSD_NS, "ssc": SSC_NS, "ssv": SSV_NS, "osp": OSP_NS, "oms": OMS_NS, "sm": SATMOTOR_NS}
for _prefix, _uri in PREFIXES.items():
    ET.register_namespace(_prefix, _uri)


# libcosim's worker threads (``osp:FixedStepAlgorithm numWorkerThreads``).  0: the calling thread
# steps the units one after the other.  libcosim's default is a pool of (hardware threads - 1)
# workers, which costs two or more thread switches per step: more than stepping these small units
# (bench/RESULTS.md, section libcosim)
WORKER_THREADS = 0


class NotExpressible(ProblemError):
    """The scenario has something an SSP package cannot express: ``file: field = value: reason``."""


def _q(ns, tag):
    return f"{{{ns}}}{tag}"


def _num(x):
    return repr(float(x))


NS = 1_000_000_000  # libcosim's time unit: integer nanoseconds


def seconds_text(seconds):
    """The shortest decimal text of ``seconds`` that libcosim reads back as the intended whole
    number of nanoseconds.  libcosim parses a double and truncates ``seconds * 1e9`` toward zero
    (``cosim::to_duration``), so ``6.5e-05`` would become 64 999 ns: a wrong base step, and a
    controller step hint that is no longer a whole multiple of it."""
    ns = round(seconds * NS)
    v = ns / NS
    while int(v * 1e9) < ns:
        v = math.nextafter(v, math.inf)
    return repr(v)


def _connectors(md):
    """``[(name, kind, type, unit)]`` of the inputs and outputs of a model description."""
    return [(v.name, v.causality, v.type, v.unit if v.type == "Real" else None)
            for v in md.modelVariables if v.causality in ("input", "output")]


def _start(v):
    """The start value of an fmpy ModelVariable as a Python value of its type."""
    if v.type == "Real":
        return float(v.start)
    if v.type in ("Integer", "Enumeration"):
        return int(v.start)
    if v.type == "Boolean":
        return v.start in (True, "true", "1")
    return "" if v.start is None else str(v.start)


def _parameter_set(values, types, name):
    ps = ET.Element(_q(SSV_NS, "ParameterSet"), {"version": "1.0", "name": name})
    params = ET.SubElement(ps, _q(SSV_NS, "Parameters"))
    for pname, value in values.items():
        p = ET.SubElement(params, _q(SSV_NS, "Parameter"), {"name": pname})
        vtype = types[pname]
        if vtype == "Real":
            text = _num(value)
        elif vtype == "Boolean":
            text = "true" if value else "false"
        else:
            text = str(value)
        ET.SubElement(p, _q(SSV_NS, vtype if vtype != "Enumeration" else "Integer"), {"value": text})
    return ps


def _annotation(parent, type_, ns, child_tag, attrs):
    anns = ET.SubElement(parent, _q(SSD_NS, "Annotations"))
    ann = ET.SubElement(anns, _q(SSC_NS, "Annotation"), {"type": type_})
    return ET.SubElement(ann, _q(ns, child_tag), attrs)


def _system_annotations(system, scenario, h, Ts):
    """The System's ``Annotations``: first OMSimulator's (it reads only the first ``ssc:Annotation``
    there, and takes a System without its ``oms:SimulationInformation`` for no kind of system at all:
    ``[NewSystem] internal error``): its fixed-step master at the base step ``h``; then ours."""
    anns = ET.SubElement(system, _q(SSD_NS, "Annotations"))
    oms = ET.SubElement(ET.SubElement(anns, _q(SSC_NS, "Annotation"), {"type": OMS_TYPE}),
                        _q(OMS_NS, "Annotations"))
    info = ET.SubElement(oms, _q(OMS_NS, "SimulationInformation"))
    ET.SubElement(info, _q(OMS_NS, "FixedStepMaster"), {"description": OMS_SOLVER, "stepSize": _num(h),
                                                        "relativeTolerance": "0.0001"})
    ET.SubElement(ET.SubElement(anns, _q(SSC_NS, "Annotation"), {"type": SATMOTOR_TYPE}),
                  _q(SATMOTOR_NS, "CoSimulation"), {
        "algorithm": "jacobi", "scenarioAlgorithm": scenario.algorithm, "step": _num(h), "Ts": _num(Ts),
        "controllerEvery": str(scenario.controller_every),
        "note": "a fixed-step engine (libcosim, Ecos, OMSimulator) steps every due unit from the values of "
                "the last communication point: satmotor-cosim run --algorithm jacobi"})


def _value(scenario_values, md, name):
    """A parameter's value: the scenario's, else the FMU's start value (None: no such parameter)."""
    if name in scenario_values:
        return scenario_values[name]
    v = next((v for v in md.modelVariables if v.name == name and v.causality == "parameter"), None)
    return None if v is None else _start(v)


def link_voltage_connection(scenario, model_descriptions, connections):
    """``(plant.v_dc -> controller.v_dc,)`` when no connection feeds the controller's ``v_dc`` and feeding
    it changes nothing: an ideal link (the plant's ``v_dc`` is its parameter ``V_dc``, constant) whose
    ``V_dc`` is the controller's (which the controller takes when its input is 0, unconnected).  So every
    input of the package is connected (an importer that reports an unconnected input, such as
    fmu-manipulation-toolbox, has none to report) and the results stay the bits of the master, which
    leaves the input at 0.  Else ``()``: the input stays unconnected (a plant and a controller with
    different ``V_dc``: connecting it would change what the controller does)."""
    target = f"{CONTROLLER}.{LINK_VOLTAGE}"
    if any(c.target == target for c in connections):
        return ()
    plant, ctrl = model_descriptions[PLANT], model_descriptions[CONTROLLER]
    if not any(v.name == LINK_VOLTAGE and v.causality == "output" for v in plant.modelVariables):
        return ()
    dc_link = _value(scenario.plant, plant, "dc_link")
    v_plant, v_ctrl = _value(scenario.plant, plant, "V_dc"), _value(scenario.controller, ctrl, "V_dc")
    if dc_link not in (None, "ideal") or v_plant is None or v_ctrl is None or float(v_plant) != float(v_ctrl):
        return ()
    return (LINK_CONNECTION,)


def ssd_xml(scenario, model_descriptions, connections=DEFAULT_CONNECTIONS, renamed=None, sources=None,
            worker_threads=WORKER_THREADS):
    """``SystemStructure.ssd`` (bytes) of ``scenario``; ``model_descriptions``: {component: fmpy
    ModelDescription} of ``plant``, ``controller`` and ``signals``; ``renamed``: {component:
    {parameter: value}} replacing scenario values (a table file packed into the FMU: its name);
    ``sources``: {component: the FMU's ``source``}, default :data:`RESOURCES`; ``worker_threads``:
    libcosim's ``numWorkerThreads`` (None: libcosim's default)."""
    file = scenario.path or scenario.name
    h, Ts = scenario.step, scenario.Ts
    connectors = {c: _connectors(model_descriptions[c]) for c in COMPONENTS}
    root = ET.Element(_q(SSD_NS, "SystemStructureDescription"), {"version": "1.0", "name": scenario.name})
    system = ET.SubElement(root, _q(SSD_NS, "System"), {
        "name": scenario.name, "description": scenario.description or f"satmotor scenario {scenario.name}"})
    elements = ET.SubElement(system, _q(SSD_NS, "Elements"))
    step_hint = {PLANT: h, CONTROLLER: Ts, SIGNALS_UNIT: h}
    overrides = {PLANT: dict(scenario.plant), CONTROLLER: {**scenario.controller, "Ts": Ts}}
    for comp, values in (renamed or {}).items():
        overrides[comp].update(values)
    used_units = []
    for comp in COMPONENTS:
        md = model_descriptions[comp]
        el = ET.SubElement(elements, _q(SSD_NS, "Component"), {
            "name": comp, "type": "application/x-fmu-sharedlibrary", "source": (sources or RESOURCES)[comp]})
        cons = ET.SubElement(el, _q(SSD_NS, "Connectors"))
        for name, kind, vtype, unit in connectors[comp]:
            con = ET.SubElement(cons, _q(SSD_NS, "Connector"), {"name": name, "kind": kind})
            ET.SubElement(con, _q(SSC_NS, vtype if vtype != "Enumeration" else "Integer"),
                          {"unit": unit} if unit else {})
            if unit and unit not in used_units:
                used_units.append(unit)
        if comp in overrides:  # every parameter: the scenario's value, else the FMU's start value
            params = [v for v in md.modelVariables if v.causality == "parameter"]
            types = {v.name: v.type for v in params}
            for pname, value in overrides[comp].items():
                if pname not in types:
                    raise NotExpressible(file, f"{comp}.{pname}", value, f"not a parameter of {md.modelName}")
            # a String only where the scenario sets it: OMSimulator 3.0 reads no ssv:String (an error each)
            values = {v.name: overrides[comp].get(v.name, _start(v)) for v in params
                      if v.type != "String" or v.name in overrides[comp]}
            bindings = ET.SubElement(el, _q(SSD_NS, "ParameterBindings"))
            pv = ET.SubElement(ET.SubElement(bindings, _q(SSD_NS, "ParameterBinding")),
                               _q(SSD_NS, "ParameterValues"))
            pv.append(_parameter_set(values, types, f"{scenario.name}.{comp}"))
        if step_hint[comp] != h:  # libcosim's default is the base step; OMSimulator refuses the element
            _annotation(el, OSP_TYPE, OSP_NS, "StepSizeHint", {"value": seconds_text(step_hint[comp])})

    cons_el = ET.SubElement(system, _q(SSD_NS, "Connections"))
    known = {(c, name): kind for c in COMPONENTS for name, kind, _, _ in connectors[c]}
    for conn in (*connections, *link_voltage_connection(scenario, model_descriptions, connections)):
        (su, sv), (tu, tv) = conn.source.split(".", 1), conn.target.split(".", 1)
        su = SIGNALS_UNIT if su == PROFILE else su
        if known.get((su, sv)) != "output" or known.get((tu, tv)) != "input":
            raise NotExpressible(file, "connections", f"{conn.source} -> {conn.target}",
                                 "not an output -> input connection of the plant, controller and signals "
                                 "FMUs")
        ET.SubElement(cons_el, _q(SSD_NS, "Connection"), {
            "startElement": su, "startConnector": sv, "endElement": tu, "endConnector": tv})

    _system_annotations(system, scenario, h, Ts)
    units = ET.SubElement(root, _q(SSD_NS, "Units"))
    for u in used_units:
        if SI_UNITS.get(u) is None:
            raise NotExpressible(file, "unit", u, "a connector unit without SI base-unit exponents")
        unit = ET.SubElement(units, _q(SSC_NS, "Unit"), {"name": u})
        ET.SubElement(unit, _q(SSC_NS, "BaseUnit"), {k: str(e) for k, e in SI_UNITS[u].items()})

    de = ET.SubElement(root, _q(SSD_NS, "DefaultExperiment"), {"startTime": "0.0",
                                                               "stopTime": _num(scenario.stop_time)})
    algo = _annotation(de, OSP_TYPE, OSP_NS, "Algorithm", {})
    threads = {} if worker_threads is None else {"numWorkerThreads": str(worker_threads)}
    ET.SubElement(algo, _q(OSP_NS, "FixedStepAlgorithm"), {"baseStepSize": seconds_text(h), **threads})
    ET.indent(root, space="  ")
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True).replace(
        b"<?xml version='1.0' encoding='UTF-8'?>", b'<?xml version="1.0" encoding="UTF-8"?>', 1) + b"\n"

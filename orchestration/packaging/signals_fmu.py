"""ScenarioSignals: a scenario's profiles as a native co-simulation FMU (FMI 2.0 or 3.0).

The FMU ``ScenarioSignals`` has three Real outputs, ``omega_ref`` [rad/s], ``psi_ref`` [Wb] and
``T_load`` [N m] (the scenario's ``profiles:``, named and united as the controller and plant inputs
they feed), and one fixed String parameter ``profiles_file`` (default ``profiles.txt``, in the
FMU's ``resources/``).  The C model is ``fmu/signals/native_model.c``; it reads the profiles file
at the end of initialization and evaluates, at each communication point it reaches, the formulas
of :mod:`orchestration.scenario.profiles` in the same floating-point order (the file format and the time
rule are documented at the top of the C file).  The master's time grid ``t_k = t0 + k h`` is the
file's ``grid`` line (the scenario's ``step``): a communication point within ``h/1000`` of a grid
point is taken as that grid point, so an importer that accumulates its time still reads
``profile.value(t_k)``; at a jump exactly on a grid time the value after the jump is output
(Python's ``t >= time``).

:data:`VARIABLES` is the model's variable table; the C tables (value references, start values, the
outputs' order and names) are generated from it by :mod:`orchestration.packaging.native.tables`, the
get/set accessors are the shared ``fmu/native/common/sm_values.c``.

:func:`profiles_text` writes the file from the scenario's profile objects (every kind:
constant, step, ramp, table, sine, csv and a sum of those); a profile it cannot write raises
:class:`UnsupportedProfile` naming the scenario file, the field and the value.  :func:`build`
compiles the FMU with :func:`orchestration.packaging.native.compiler.build_native_fmu`.
"""

from __future__ import annotations

import hashlib
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import satmotor
import satmotor.interface as itf
from orchestration.packaging.fmu_model_description import COPYRIGHT, LICENSE, SI_UNITS
from orchestration.packaging.native.compiler import GLUE_DIR, build_native_fmu
from orchestration.packaging.native.fmus import LINUX, PORTABLE_GLIBC
from orchestration.packaging.native.tables import model_files
from orchestration.scenario.problems import ProblemError
from orchestration.scenario.profiles import Constant, Csv, Ramp, Sine, Step, Sum, Table

__all__ = ["MODEL_NAME", "SIGNALS", "PROFILES_FILE", "MAX_TERMS", "MAX_POINTS", "VARIABLES",
           "UnsupportedProfile", "profiles_text", "model_description", "build"]

MODEL_NAME = "ScenarioSignals"
SIGNALS = ("omega_ref", "psi_ref", "T_load")  # output value references 0, 1, 2
PROFILES_FILE = "profiles.txt"
FORMAT_VERSION = 1
MAX_TERMS = 32  # SS_MAX_TERMS of the C model: terms per signal
MAX_POINTS = 8192  # SS_MAX_POINTS: table points of all signals together
SOURCE = GLUE_DIR.parents[1] / "signals" / "native_model.c"
GENERATION_TOOL = "satmotor native C glue"
DATE = "2026-01-01T00:00:00Z"  # fixed: reproducible builds
_UNITS = {v.name: (v.unit, v.description) for v in itf.CONTROLLER_INPUTS if v.name in SIGNALS}
PROFILES_FILE_DESCRIPTION = "the profiles file (a relative name not found as given: in the FMU's resources/)"
# the model's variables in value reference order (the C model's tables are generated from them by
# orchestration/packaging/native/tables.py); the time is the next value reference
VARIABLES = tuple(itf.Variable(n, "output", "Real", 0.0, *_UNITS[n]) for n in SIGNALS) + (
    itf.Variable("profiles_file", "parameter", "String", PROFILES_FILE, "", PROFILES_FILE_DESCRIPTION),)
VR_PROFILES_FILE, VR_TIME = len(SIGNALS), len(VARIABLES)


class UnsupportedProfile(ProblemError):
    """A profile the ScenarioSignals file cannot hold: ``file: field = value: reason``."""


def _num(x):
    return repr(float(x))  # shortest round-trip: C's strtod reads back the same double


def _term_lines(p, file, field):
    if isinstance(p, Constant):
        return [f"constant {_num(p.level)}"]
    if isinstance(p, Step):
        return [f"step {_num(p.time)} {_num(p.initial)} {_num(p.level)}"]
    if isinstance(p, Ramp):  # the slope as Python computed it (exactly, from the decimal numbers)
        return [f"ramp {_num(p.start)} {_num(p.end)} {_num(p.from_)} {_num(p.to)} {_num(p._slope)}"]
    if isinstance(p, Table | Csv):
        if len(p.times) > MAX_POINTS:
            raise UnsupportedProfile(file, field, f"{len(p.times)} points",
                                     f"a table holds at most {MAX_POINTS} points in the native FMU")
        return [f"table {len(p.times)}"] + [f"{_num(t)} {_num(v)}" for t, v in zip(p.times, p.values)]
    if isinstance(p, Sine):
        return ["sine " + " ".join(_num(x) for x in (p.amplitude, p.frequency, p.phase, p.offset, p.start))]
    raise UnsupportedProfile(file, field, p, "not a profile kind ScenarioSignals can hold "
                             "(constant, step, ramp, table, sine, csv, or a list of them)")


def _signal_lines(name, p, file):
    field = f"profiles.{name}"
    if isinstance(p, Sum):
        lines = []
        for i, part in enumerate(p.parts):
            if isinstance(part, Sum):
                raise UnsupportedProfile(file, f"{field}[{i}]", part,
                                         "a sum inside a sum: write one flat list")
            lines += _term_lines(part, file, f"{field}[{i}]")
        if len(p.parts) > MAX_TERMS:
            raise UnsupportedProfile(file, field, f"{len(p.parts)} terms",
                                     f"a signal holds at most {MAX_TERMS} terms in the native FMU")
        return lines
    return _term_lines(p, file, field)


def profiles_text(scenario):
    """The profiles file of ``scenario`` (format 1, see ``fmu/signals/native_model.c``)."""
    file = scenario.path or scenario.name
    lines = [f"satmotor-signals {FORMAT_VERSION}",
             f"# scenario {scenario.name}: the profiles of orchestration/scenario/profiles.py as terms added "
             "in order",
             f"grid {_num(scenario.step)}"]
    points = 0
    for name in SIGNALS:
        p = scenario.profiles.get(name, Constant(0.0))
        body = _signal_lines(name, p, file)
        points += sum(int(b.split()[1]) for b in body if b.startswith("table "))
        lines += [f"signal {name}", *body]
    if points > MAX_POINTS:
        raise UnsupportedProfile(file, "profiles", f"{points} table points",
                                 f"the native FMU holds at most {MAX_POINTS} table points in all")
    return "\n".join([*lines, "end", ""])


def _xml(root):
    ET.indent(root, space="\t")
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True).replace(
        b"<?xml version='1.0' encoding='UTF-8'?>", b'<?xml version="1.0" encoding="UTF-8"?>', 1
    ).decode() + "\n"


def model_description(scenario, profiles, fmi_version="2.0"):
    """modelDescription.xml (str, token ``{GUID}``) of the ScenarioSignals FMU of ``scenario``;
    ``profiles``: the text of its profiles file (its SHA-256 is in the description, so FMUs of
    different profiles have different GUIDs)."""
    fmi3 = fmi_version == "3.0"
    digest = hashlib.sha256(profiles.encode()).hexdigest()[:16]
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": fmi_version, "modelName": MODEL_NAME,
        ("instantiationToken" if fmi3 else "guid"): "{GUID}",
        "description": f"reference and load profiles of scenario {scenario.name} "
                       f"({PROFILES_FILE} sha256 {digest}...)",
        "author": itf.AUTHOR, "version": satmotor.__version__, "copyright": COPYRIGHT, "license": LICENSE,
        "generationTool": GENERATION_TOOL, "generationDateAndTime": DATE,
        "variableNamingConvention": "structured"})
    cs = {"modelIdentifier": MODEL_NAME, "needsExecutionTool": "false",
          "canHandleVariableCommunicationStepSize": "true", "canBeInstantiatedOnlyOncePerProcess": "false"}
    if fmi3:
        cs.update({"canGetAndSetFMUState": "true", "canSerializeFMUState": "true",
                   "providesIntermediateUpdate": "false", "canReturnEarlyAfterIntermediateUpdate": "false",
                   "hasEventMode": "false"})
    else:
        cs.update({"canInterpolateInputs": "false", "canNotUseMemoryManagementFunctions": "true",
                   "canGetAndSetFMUstate": "true", "canSerializeFMUstate": "true"})
    ET.SubElement(root, "CoSimulation", cs)
    units = ET.SubElement(root, "UnitDefinitions")
    names = [v.unit for v in VARIABLES if v.unit] + (["s"] if fmi3 else [])  # s: FMI 3.0's time
    for u in dict.fromkeys(names):
        ET.SubElement(ET.SubElement(units, "Unit", {"name": u}), "BaseUnit",
                      {k: str(e) for k, e in SI_UNITS[u].items()})
    cats = ET.SubElement(root, "LogCategories")
    for cat in ("logStatusError", "logEvents"):
        ET.SubElement(cats, "Category", {"name": cat})
    ET.SubElement(root, "DefaultExperiment", {"startTime": "0.0", "stopTime": _num(scenario.stop_time),
                                              "stepSize": _num(scenario.step)})
    mv = ET.SubElement(root, "ModelVariables")
    *outputs, profiles_file = VARIABLES  # the table the C model's tables are generated from
    for vr, v in enumerate(outputs):
        attrs = {"name": v.name, "valueReference": str(vr), "description": f"{v.description} [{v.unit}]",
                 "causality": "output", "variability": "continuous", "initial": "calculated"}
        if fmi3:
            ET.SubElement(mv, "Float64", {**attrs, "unit": v.unit})
        else:
            ET.SubElement(ET.SubElement(mv, "ScalarVariable", attrs), "Real", {"unit": v.unit})
    attrs = {"name": profiles_file.name, "valueReference": str(VR_PROFILES_FILE),
             "description": profiles_file.description,
             "causality": "parameter", "variability": "fixed"}
    if fmi3:
        ET.SubElement(ET.SubElement(mv, "String", attrs), "Start", {"value": profiles_file.start})
        ET.SubElement(mv, "Float64", {"name": "time", "valueReference": str(VR_TIME),
                                      "causality": "independent",
                                      "variability": "continuous", "description": "simulation time [s]",
                                      "unit": "s"})
    else:
        ET.SubElement(ET.SubElement(mv, "ScalarVariable", attrs), "String", {"start": profiles_file.start})
    ms = ET.SubElement(root, "ModelStructure")
    if fmi3:
        for tag in ("Output", "InitialUnknown"):
            for vr in range(len(SIGNALS)):
                ET.SubElement(ms, tag, {"valueReference": str(vr), "dependencies": "" if tag == "Output"
                                        else str(VR_PROFILES_FILE)})
    else:  # indices are 1-based positions: the outputs, then profiles_file
        for section, deps in (("Outputs", ""), ("InitialUnknowns", str(len(SIGNALS) + 1))):
            block = ET.SubElement(ms, section)
            for i in range(len(SIGNALS)):
                ET.SubElement(block, "Unknown", {"index": str(i + 1), "dependencies": deps})
    return _xml(root)


def sources():
    """The C files of the model besides the glue and the generated ``sm_vars.h`` / ``sm_vars.c``."""
    common = GLUE_DIR.parent / "common"
    return [SOURCE, common / "sm_values.h", common / "sm_values.c"]


def build(scenario, out_dir, fmi_version="2.0", platforms=None):
    """Write ``<out_dir>/ScenarioSignals.fmu`` for ``scenario`` (an
    :class:`orchestration.scenario.load.Scenario`); returns its path.  ``platforms``: as
    :func:`orchestration.packaging.native.compiler.build_native_fmu` (default: Linux x86_64).  Raises
    :class:`UnsupportedProfile` before anything is compiled for a profile the FMU cannot hold."""
    text = profiles_text(scenario)
    xml = model_description(scenario, text, fmi_version)
    plats = tuple(platforms or LINUX[fmi_version])
    with tempfile.TemporaryDirectory(prefix="ss_vars_") as tmp:
        files = [*sources(), *model_files(MODEL_NAME, tmp, VARIABLES)]
        path, _ = build_native_fmu(MODEL_NAME, files, xml, Path(out_dir) / f"{MODEL_NAME}.fmu",
                                   fmi_version, plats, resources={PROFILES_FILE: text},
                                   linux_glibc=PORTABLE_GLIBC if len(plats) > 1 else None)
    return path

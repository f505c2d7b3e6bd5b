"""The native FMUs' model descriptions (FMI 2.0 and 3.0) against the FMI schemas (fmpy validates
against the standard's XSD) and against the pythonfmu FMUs' descriptions: the same variables, value
references, types, start values, units, default experiment and model structure."""

import zipfile
from pathlib import Path

import pytest
from fmpy import read_model_description
from fmpy.validation import validate_model_description

from orchestration.packaging import fmus
from orchestration.packaging.native.model_description import fmi2, fmi3

NAMES = ("SaturatedInductionMotor", "BacksteppingController")
TOKEN = "{12345678-1234-5678-1234-567812345678}"
FMI3_TYPE = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "String": "String"}


def _read(tmp_path, name, xml):
    path = tmp_path / name
    path.write_bytes(xml)
    return read_model_description(str(path), validate=True)  # raises on a schema violation


def _pythonfmu(fmu_dir, name, tmp_path):
    plant, ctrl = fmus.paths(fmu_dir)
    with zipfile.ZipFile(plant if name == NAMES[0] else ctrl) as z:
        return _read(tmp_path, "pythonfmu.xml", z.read("modelDescription.xml"))


def _key(v, types=None):
    return (v.name, v.valueReference, v.causality, v.variability, v.initial,
            (types or {}).get(v.type, v.type), str(v.start), v.unit, v.description)


@pytest.mark.parametrize("name", NAMES)
def test_fmi2_description_is_the_pythonfmu_ones_but_needs_no_tool(name, fmu_dir, tmp_path):
    native = _read(tmp_path, "fmi2.xml", fmi2(name, TOKEN))
    assert validate_model_description(native) == []
    ref = _pythonfmu(fmu_dir, name, tmp_path)
    assert [_key(v) for v in native.modelVariables] == [_key(v) for v in ref.modelVariables]
    assert [(u.name, str(u.baseUnit)) for u in native.unitDefinitions] == \
        [(u.name, str(u.baseUnit)) for u in ref.unitDefinitions]
    for a, b in ((native.outputs, ref.outputs), (native.initialUnknowns, ref.initialUnknowns)):
        assert [(u.variable.name, [d.name for d in u.dependencies]) for u in a] == \
            [(u.variable.name, [d.name for d in u.dependencies]) for u in b]
    ex = ("startTime", "stopTime", "stepSize", "tolerance")
    assert [getattr(native.defaultExperiment, a) for a in ex] == \
        [getattr(ref.defaultExperiment, a) for a in ex]
    assert native.coSimulation.needsExecutionTool in (False, "false")
    assert native.coSimulation.canGetAndSetFMUstate and native.coSimulation.canSerializeFMUstate
    assert native.guid == TOKEN


@pytest.mark.parametrize("name", NAMES)
def test_fmi3_description_translates_the_fmi2_one(name, tmp_path):
    two = _read(tmp_path, "fmi2.xml", fmi2(name, TOKEN))
    three = _read(tmp_path, "fmi3.xml", fmi3(name, TOKEN))
    assert three.fmiVersion == "3.0" and validate_model_description(three) == []
    assert three.guid == TOKEN  # fmpy reads instantiationToken into guid
    by_name = {v.name: v for v in three.modelVariables}
    time = by_name.pop("time")
    assert time.causality == "independent" and time.valueReference == len(two.modelVariables)
    assert [_key(v, FMI3_TYPE) for v in two.modelVariables] == \
        [_key(by_name[v.name]) for v in two.modelVariables]
    for a, b in ((two.outputs, three.outputs), (two.initialUnknowns, three.initialUnknowns)):
        assert [(u.variable.name, [d.name for d in u.dependencies]) for u in a] == \
            [(u.variable.name, [d.name for d in u.dependencies]) for u in b]
    assert three.defaultExperiment.stepSize == two.defaultExperiment.stepSize
    assert {u.name for u in three.unitDefinitions} == {u.name for u in two.unitDefinitions}


def test_descriptions_are_deterministic():
    for name in NAMES:
        assert fmi2(name, TOKEN) == fmi2(name, TOKEN) and fmi3(name, TOKEN) == fmi3(name, TOKEN)
    assert Path(__file__).exists()


@pytest.mark.parametrize("version", ["2.0", "3.0"])
@pytest.mark.parametrize("name", NAMES)
def test_native_fmus_document_their_variables_and_their_own_flags(name, version, fmu_dir):
    """documentation/index.html of each native FMU: a row for every variable of its model description
    (FMI 3.0's independent ``time`` aside) with that variable's causality, and the capability flags
    its model description declares (not the pythonfmu FMU's)."""
    import html
    import re
    from xml.etree import ElementTree as ET

    path = fmu_dir / ("native" if version == "2.0" else "native-fmi3") / f"{name}.fmu"
    with zipfile.ZipFile(path) as z:
        doc, md = z.read("documentation/index.html").decode(), ET.fromstring(z.read("modelDescription.xml"))
    rows = {}
    for row in re.findall(r"<tr>(<td>.*?)</tr>", doc):
        cells = [html.unescape(c) for c in re.findall(r"<td>(.*?)</td>", row)]
        rows[cells[0]] = cells
    declared = {v.get("name"): v.get("causality") for v in md.find("ModelVariables")
                if v.get("causality") != "independent"}
    assert {n: r[1] for n, r in rows.items()} == declared
    flags = dict(re.findall(r"<li>(\w+) = ([\w.]+)</li>", doc))
    cs = {k: v for k, v in md.find("CoSimulation").attrib.items() if k != "modelIdentifier"}
    assert flags == cs and flags["needsExecutionTool"] == "false"

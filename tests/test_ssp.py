"""``export-ssp``: the SSP 1.0 package of a scenario (orchestration/tools/ssp.py).

Checked independently of the writer: the .ssd validates against the SSP 1.0 schemas FMPy ships
(and each inline parameter set against the parameter-values schema); the parameter values, read
back with ElementTree, are the scenario's (and the FMUs' start values elsewhere); the connections
are DEFAULT_CONNECTIONS; the three FMUs validate with fmpy; refusals exit 2 naming the file, the
field and the value and leave nothing at OUT.  Last, a small fixed-step engine written here from
libcosim's rules (``fixed_step_algorithm``: base step, decimation from the step-size hints, a
connection transferred when the step counter is a multiple of the lcm of both ends' decimation,
time in integer nanoseconds) runs the package: it gives the master's ``jacobi`` run bit for bit.
"""

from __future__ import annotations

import dataclasses
import math
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from fmpy.validation import validate_fmu

from orchestration.cli import commands as cli
from orchestration.packaging import fmus, ssd
from orchestration.run.master import run
from orchestration.scenario.load import load_scenario
from orchestration.scenario.system import DEFAULT_CONNECTIONS
from orchestration.tools import ssp

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = sorted((ROOT / "scenarios").glob("*.yaml"))
NS = {"ssd": ssd.SSD_NS, "ssc": ssd.SSC_NS, "ssv": ssd.SSV_NS, "osp": ssd.OSP_NS, "oms": ssd.OMS_NS}
REFUSED = {"noisy_measurements", "real_drive"}  # measurements: sections
DEFAULT = ROOT / "scenarios" / "ramp_rated_load.yaml"


@pytest.fixture(scope="module")
def default_ssp(fmu_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("ssp") / "default.ssp"
    assert cli.main(["export-ssp", str(DEFAULT), str(out), "--fmus", str(fmu_dir)]) == 0
    return out


@pytest.fixture(scope="module")
def signals_md(default_ssp, tmp_path_factory):
    d = tmp_path_factory.mktemp("sig")
    with zipfile.ZipFile(default_ssp) as z:
        z.extract(ssd.RESOURCES["signals"], d)
    return read_model_description(str(d / ssd.RESOURCES["signals"]))


def ssd_root(path):
    with zipfile.ZipFile(path) as z:
        return ET.fromstring(z.read("SystemStructure.ssd"))


def model_descriptions(fmu_dir, signals_md, variant="native"):
    plant, ctrl = fmus.paths(fmu_dir, variant)
    return {"plant": read_model_description(str(plant)), "controller": read_model_description(str(ctrl)),
            "signals": signals_md}


def typed_value(el):
    """(type, Python value) of an ssv:Real/Integer/Boolean/String element."""
    tag = el.tag.split("}")[1]
    v = el.get("value")
    return tag, {"Real": float, "Integer": int, "Boolean": lambda s: s == "true", "String": str}[tag](v)


def test_the_package_holds_the_ssd_and_three_fmus_that_validate(default_ssp, tmp_path):
    with zipfile.ZipFile(default_ssp) as z:
        assert sorted(z.namelist()) == sorted(["SystemStructure.ssd", *ssd.RESOURCES.values()])
        z.extractall(tmp_path)
    for comp, name in ssd.RESOURCES.items():
        assert validate_fmu(str(tmp_path / name)) == [], comp
        md = read_model_description(str(tmp_path / name))
        assert (md.fmiVersion, md.coSimulation.modelIdentifier) == ("2.0", Path(name).stem)


def test_the_ssd_validates_against_the_ssp_1_0_schemas_of_fmpy(default_ssp):
    from fmpy.ssp import ssd as fmpy_ssd
    from lxml import etree

    parsed = fmpy_ssd.read_ssd(str(default_ssp), validate=True)  # raises on a schema violation
    assert [c.name for c in parsed.system.elements] == list(ssd.COMPONENTS)
    # the inline parameter sets are 'lax' inside the .ssd schema: validate them on their own
    schema = etree.XMLSchema(file=str(Path(fmpy_ssd.__file__).parent / "schema" /
                                      "SystemStructureParameterValues.xsd"))
    with zipfile.ZipFile(default_ssp) as z:
        root = etree.fromstring(z.read("SystemStructure.ssd"))
    sets = root.findall(".//ssv:ParameterSet", namespaces=NS)
    assert len(sets) == 2
    for ps in sets:
        assert schema.validate(etree.ElementTree(ps)), schema.error_log


def test_libcosim_and_omsimulator_read_the_prefixed_names_they_match(default_ssp, fmu_dir, signals_md):
    """libcosim (boost property_tree) and OMSimulator (pugixml) match 'ssd:System', 'osp:Algorithm',
    'oms:FixedStepMaster' etc. literally; the step-size hint of a controller slower than the base step
    (deep_saturation: h = 50 us, Ts = 100 us) too."""
    with zipfile.ZipFile(default_ssp) as z:
        text = z.read("SystemStructure.ssd").decode()
    for literal in ("<ssd:SystemStructureDescription", "<ssd:System ", "<ssd:Component ", "<ssd:Connector ",
                    "<ssv:ParameterSet ", '<ssc:Annotation type="com.opensimulationplatform">',
                    '<osp:FixedStepAlgorithm baseStepSize="0.0001"',
                    '<ssc:Annotation type="org.openmodelica">', "<oms:Annotations>",
                    "<oms:SimulationInformation>",
                    '<oms:FixedStepMaster description="oms-ma" stepSize="0.0001"'):
        assert literal in text, literal
    sc = load_scenario(ROOT / "scenarios" / "deep_saturation.yaml")
    text = ssd.ssd_xml(sc, model_descriptions(fmu_dir, signals_md)).decode()
    assert text.count("<osp:StepSizeHint ") == 1 and '<osp:StepSizeHint value="0.0001"' in text


def omsimulator_reading(root):
    """What OMSimulator 3.0's SSP import (src/OMSimulatorLib, Model.cpp and System.cpp) takes from an
    .ssd, with its rules written out here: the root holds only System, Units, Enumerations and
    DefaultExperiment ("wrong xml schema detected" otherwise); the System's kind comes from the FIRST
    ssc:Annotation of its Annotations, which must be of type org.openmodelica and hold
    oms:Annotations/oms:SimulationInformation with a solver (none: "[NewSystem] internal error"); a
    Component holds only Connectors, ElementGeometry and ParameterBindings (anything else, an
    Annotations element too: "wrong xml schema").  Returns (solver, step size) or raises AssertionError
    naming what it would refuse."""
    allowed = {f"{{{ssd.SSD_NS}}}{t}" for t in ("System", "Units", "Enumerations", "DefaultExperiment")}
    assert all(el.tag in allowed for el in root), [el.tag for el in root if el.tag not in allowed]
    system = root.find("ssd:System", NS)
    first = system.find("ssd:Annotations/ssc:Annotation", NS)  # pugixml's child(): the first one
    assert first is not None and first.get("type") == "org.openmodelica", "[NewSystem] internal error"
    master = first.find("oms:Annotations/oms:SimulationInformation/oms:FixedStepMaster", NS)
    assert master is not None and master.get("description") == "oms-ma", "[NewSystem] internal error"
    kept = {f"{{{ssd.SSD_NS}}}{t}" for t in ("Connectors", "ElementGeometry", "ParameterBindings")}
    for c in system.findall("ssd:Elements/ssd:Component", NS):
        assert all(el.tag in kept for el in c), (c.get("name"), "wrong xml schema")
    return master.get("description"), float(master.get("stepSize"))


def test_omsimulator_can_read_the_default_package(default_ssp):
    assert omsimulator_reading(ssd_root(default_ssp)) == ("oms-ma", 1e-4)


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.stem)
def test_parameters_connections_steps_of_every_scenario(path, fmu_dir, signals_md):
    """The .ssd of each scenario, read back with ElementTree: every parameter of both FMUs (a String
    one only where the scenario sets it), the scenario's value where it sets one (Ts = step *
    controller_every), else the FMU's start value; the connections; the step sizes (no hint for a unit
    at the base step); the stop time; OMSimulator's reading of single-rate packages.  The scenarios
    with measurements are refused."""
    sc = load_scenario(path)
    if path.stem in REFUSED:
        with pytest.raises(ssp.NotExpressible, match=rf"^{path}: measurements\.(noise|quantization)\."):
            ssp.check_expressible(sc)
        return
    mds = model_descriptions(fmu_dir, signals_md)
    root = ET.fromstring(ssd.ssd_xml(sc, mds))
    comps = {c.get("name"): c for c in root.findall("ssd:System/ssd:Elements/ssd:Component", NS)}
    assert list(comps) == ["plant", "controller", "signals"]
    want = {"plant": dict(sc.plant), "controller": {**sc.controller, "Ts": sc.step * sc.controller_every}}
    for comp, overrides in want.items():
        got = {p.get("name"): typed_value(p[0]) for p in comps[comp].findall(".//ssv:Parameter", NS)}
        params = [v for v in mds[comp].modelVariables if v.causality == "parameter"
                  and (v.type != "String" or v.name in overrides)]  # a String only where the scenario sets it
        assert set(got) == {v.name for v in params}
        for v in params:
            vtype, value = got[v.name]
            assert vtype == v.type
            if v.name in overrides:
                assert value == overrides[v.name], (comp, v.name)
            else:  # the start value as the FMU's model description writes it
                start = ET.Element(f"{{{ssd.SSV_NS}}}{v.type}", {"value": v.start or ""})
                assert value == typed_value(start)[1], (comp, v.name)
    assert not comps["signals"].findall(".//ssv:Parameter", NS)
    conns = [(c.get("startElement"), c.get("startConnector"), c.get("endElement"), c.get("endConnector"))
             for c in root.findall("ssd:System/ssd:Connections/ssd:Connection", NS)]
    expected = []
    for c in DEFAULT_CONNECTIONS:
        (su, sv), (tu, tv) = c.source.split("."), c.target.split(".")
        expected.append(("signals" if su == "profile" else su, sv, tu, tv))
    # the controller's v_dc from the plant where that changes nothing: an ideal link (the plant's v_dc is
    # its V_dc) of the controller's V_dc (what the controller takes when its input is 0, unconnected)
    start = {(c, v.name): float(v.start) for c in ("plant", "controller") for v in mds[c].modelVariables
             if v.name == "V_dc"}
    v_plant = float(sc.plant.get("V_dc", start["plant", "V_dc"]))
    v_ctrl = float(sc.controller.get("V_dc", start["controller", "V_dc"]))
    if sc.plant.get("dc_link", "ideal") == "ideal" and v_plant == v_ctrl:
        expected.append(("plant", "v_dc", "controller", "v_dc"))
        fed = {(c[2], c[3]) for c in conns}  # then every input of both FMUs is connected
        assert {(u, v.name) for u in ("plant", "controller") for v in mds[u].modelVariables
                if v.causality == "input"} <= fed
    assert conns == expected
    hints = {n: c.find("ssd:Annotations/ssc:Annotation/osp:StepSizeHint", NS) for n, c in comps.items()}
    # a unit at the base step carries no hint (libcosim's default; OMSimulator refuses the element)
    assert {n: sc.step if h is None else float(h.get("value")) for n, h in hints.items()} == {
        "plant": sc.step, "controller": sc.Ts, "signals": sc.step}
    assert hints["plant"] is None and hints["signals"] is None
    assert (hints["controller"] is None) == (sc.Ts == sc.step)
    de = root.find("ssd:DefaultExperiment", NS)
    assert (float(de.get("startTime")), float(de.get("stopTime"))) == (0.0, sc.stop_time)
    base = de.find("ssd:Annotations/ssc:Annotation/osp:Algorithm/osp:FixedStepAlgorithm", NS)
    assert float(base.get("baseStepSize")) == sc.step
    assert base.get("numWorkerThreads") == "0"  # libcosim steps the units in its calling thread
    if sc.Ts == sc.step:  # OMSimulator's fixed-step master steps every unit at one step size
        assert omsimulator_reading(root) == ("oms-ma", sc.step)
    else:
        with pytest.raises(AssertionError, match="wrong xml schema"):
            omsimulator_reading(root)


def test_a_controller_with_another_v_dc_than_the_ideal_link_keeps_its_input_unconnected(fmu_dir, signals_md):
    """Fed from the plant, the controller would take the plant's V_dc instead of its own."""
    mds = model_descriptions(fmu_dir, signals_md)
    base = load_scenario(DEFAULT)
    for sc, linked in ((base, True), (dataclasses.replace(base, controller={"V_dc": 600.0}), False),
                       (dataclasses.replace(base, plant={"V_dc": 600.0}, controller={"V_dc": 600.0}), True)):
        root = ET.fromstring(ssd.ssd_xml(sc, mds))
        ends = [(c.get("startElement"), c.get("endElement"), c.get("endConnector"))
                for c in root.findall("ssd:System/ssd:Connections/ssd:Connection", NS)]
        assert (("plant", "controller", "v_dc") in ends) == linked, (sc.plant, sc.controller)


def test_connectors_carry_the_fmus_types_and_units(default_ssp, tmp_path):
    root = ssd_root(default_ssp)
    units = {u.get("name") for u in root.findall("ssd:Units/ssc:Unit", NS)}
    with zipfile.ZipFile(default_ssp) as z:
        z.extractall(tmp_path)
    for comp in root.findall("ssd:System/ssd:Elements/ssd:Component", NS):
        md = read_model_description(str(tmp_path / comp.get("source")))
        want = [(v.name, v.causality, v.type, v.unit) for v in md.modelVariables
                if v.causality in ("input", "output")]
        got = [(c.get("name"), c.get("kind"), c[0].tag.split("}")[1], c[0].get("unit"))
               for c in comp.findall("ssd:Connectors/ssd:Connector", NS)]
        assert got == want
        assert {u for *_, u in got if u} <= units


def test_the_export_is_reproducible(default_ssp, fmu_dir, tmp_path):
    again = tmp_path / "again.ssp"
    assert cli.main(["export-ssp", str(DEFAULT), str(again), "--fmus", str(fmu_dir)]) == 0
    assert again.read_bytes() == default_ssp.read_bytes()


def test_the_python_variant_packs_the_pythonfmu_fmus(fmu_dir, tmp_path):
    out = tmp_path / "py.ssp"
    args = ["export-ssp", str(DEFAULT), str(out), "--fmus", str(fmu_dir), "--variant", "python"]
    assert cli.main(args) == 0
    plant, _ = fmus.paths(fmu_dir, "python")
    with zipfile.ZipFile(out) as z:
        assert z.read(ssd.RESOURCES["plant"]) == plant.read_bytes()


# --- refusals ---------------------------------------------------------------------------------------

def refused(capsys, fmu_dir, scenario, out):
    code = cli.main(["export-ssp", str(scenario), str(out), "--fmus", str(fmu_dir)])
    err = capsys.readouterr().err
    assert code == 2, err
    assert not out.exists() and not [p for p in out.parent.iterdir() if out.name in p.name]
    return err


def test_a_measurements_section_is_refused_before_anything_is_written(capsys, fmu_dir, tmp_path):
    path = ROOT / "scenarios" / "noisy_measurements.yaml"
    err = refused(capsys, fmu_dir, path, tmp_path / "n.ssp")
    sc = load_scenario(path)
    name = sc.measurements.signals[0]
    assert err.startswith(f"{path}: measurements.noise.{name} = {dict(sc.measurements.noise)[name]!r}: ")


def table_scenario(tmp_path):
    i_mu = (0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.5, 9.0, 11.0, 14.0, 18.0)  # a saturating no-load curve
    rows = "".join(f"{i},{0.012 * i + 0.945 * i / (3.0 + i)}\n" for i in i_mu)
    (tmp_path / "curve.csv").write_text("i_mu,psi_m\n" + rows)
    text = DEFAULT.read_text().replace("plant: {}", "plant: {curve: table, table_file: curve.csv}").replace(
        "controller: {}", "controller: {curve: table, table_file: curve.csv}")
    (tmp_path / "t.yaml").write_text(text)
    return tmp_path / "t.yaml"


def test_a_table_file_is_refused_with_the_pythonfmu_fmus(capsys, fmu_dir, tmp_path):
    path, out = table_scenario(tmp_path), tmp_path / "t.ssp"
    code = cli.main(["export-ssp", str(path), str(out), "--fmus", str(fmu_dir), "--variant", "python"])
    err = capsys.readouterr().err
    assert code == 2 and not out.exists()
    # the value names the file (a Problem shortens a value beyond 80 characters: the tmp path's length varies)
    value = repr(str(tmp_path / "curve.csv"))
    shown = value if len(value) <= 80 else value[:77] + "..."
    assert err.startswith(f"{path}: plant.table_file = {shown}: a file outside the package"), err


@pytest.mark.slow
def test_a_table_file_travels_in_the_native_fmus_resources(fmu_dir, tmp_path):
    """Both FMUs carry curve.csv in resources/, the parameter is its base name, and the package runs
    as the master does with the file on disk (0.05 s, bit for bit)."""
    path, out = table_scenario(tmp_path), tmp_path / "t.ssp"
    assert cli.main(["export-ssp", str(path), str(out), "--fmus", str(fmu_dir)]) == 0
    root = ssd_root(out)
    with zipfile.ZipFile(out) as z:
        for comp in ("plant", "controller"):
            with zipfile.ZipFile(z.open(ssd.RESOURCES[comp])) as f:
                assert f.read("resources/curve.csv") == (tmp_path / "curve.csv").read_bytes()
            el = root.find(f"ssd:System/ssd:Elements/ssd:Component[@name='{comp}']", NS)
            values = {p.get("name"): p[0].get("value") for p in el.findall(".//ssv:Parameter", NS)}
            assert (values["curve"], values["table_file"]) == ("table", "curve.csv")
    assert_engine_equals_master(out, load_scenario(path), 0.05, fmu_dir, tmp_path / "run")


def test_a_profile_the_signals_fmu_cannot_hold_is_refused(capsys, fmu_dir, tmp_path):
    rows = "\n".join(f"{i * 1e-4!r},1.0" for i in range(8193))
    (tmp_path / "long.csv").write_text(rows + "\n")
    text = DEFAULT.read_text().replace("T_load: {type: step, time: 1.0, value: 26.71, initial: 0.0}",
                                       "T_load: {type: csv, file: long.csv}")
    (tmp_path / "l.yaml").write_text(text)
    err = refused(capsys, fmu_dir, tmp_path / "l.yaml", tmp_path / "l.ssp")
    assert err.startswith(f"{tmp_path / 'l.yaml'}: profiles.T_load = '8193 points': ")


def test_an_invalid_scenario_is_refused(capsys, fmu_dir, tmp_path):
    (tmp_path / "bad.yaml").write_text(DEFAULT.read_text().replace("stop_time: 1.5", "stop_time: -1.0"))
    err = refused(capsys, fmu_dir, tmp_path / "bad.yaml", tmp_path / "bad.ssp")
    assert "stop_time = -1.0" in err


def test_an_unwritable_out_is_refused_and_an_old_file_is_kept(capsys, fmu_dir, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    code = cli.main(["export-ssp", str(DEFAULT), str(blocker / "x.ssp"), "--fmus", str(fmu_dir)])
    assert code == 2 and str(blocker / "x.ssp") in capsys.readouterr().err
    old = tmp_path / "old.ssp"
    old.write_bytes(b"previous")
    refused_path = ROOT / "scenarios" / "noisy_measurements.yaml"
    assert cli.main(["export-ssp", str(refused_path), str(old), "--fmus", str(fmu_dir)]) == 2
    assert old.read_bytes() == b"previous"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file", "old.ssp"]


# --- running the package: a fixed-step engine with libcosim's rules ---------------------------------

class FixedStepEngine:
    """Runs an SSP package as libcosim's fixed_step_algorithm does (see the module docstring)."""

    def __init__(self, ssp_path, workdir):
        with zipfile.ZipFile(ssp_path) as z:
            z.extractall(workdir)
        root = ET.parse(workdir / "SystemStructure.ssd").getroot()
        algo = root.find("ssd:DefaultExperiment/ssd:Annotations/ssc:Annotation/osp:Algorithm/"
                         "osp:FixedStepAlgorithm", NS)
        self.base_ns = round(float(algo.get("baseStepSize")) * 1e9)
        self.units = {}
        for c in root.findall("ssd:System/ssd:Elements/ssd:Component", NS):
            hint_el = c.find("ssd:Annotations/ssc:Annotation/osp:StepSizeHint", NS)  # none: the base step
            hint = self.base_ns / 1e9 if hint_el is None else float(hint_el.get("value"))
            src = workdir / c.get("source")
            md = read_model_description(str(src))
            fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(src)), instanceName=c.get("name"),
                            modelIdentifier=md.coSimulation.modelIdentifier)
            fmu.instantiate()
            fmu.setupExperiment(startTime=0.0)
            vr = {v.name: v.valueReference for v in md.modelVariables}
            for p in c.findall(".//ssv:Parameter", NS):
                vtype, value = typed_value(p[0])
                ref = [vr[p.get("name")]]
                {"Real": fmu.setReal, "Integer": fmu.setInteger, "Boolean": fmu.setBoolean,
                 "String": fmu.setString}[vtype](ref, [value])
            fmu.enterInitializationMode()
            fmu.exitInitializationMode()
            self.units[c.get("name")] = (fmu, vr, max(1, round(hint * 1e9 / self.base_ns)))
        self.connections = [(c.get("startElement"), c.get("startConnector"), c.get("endElement"),
                             c.get("endConnector"))
                            for c in root.findall("ssd:System/ssd:Connections/ssd:Connection", NS)]
        self.counter = 0
        self.transfer()

    def transfer(self):
        for se, sc, ee, ec in self.connections:
            (src, svr, sdf), (dst, dvr, ddf) = self.units[se], self.units[ee]
            if self.counter % math.lcm(sdf, ddf) == 0:
                dst.setReal([dvr[ec]], src.getReal([svr[sc]]))

    def step(self):
        for fmu, _, df in self.units.values():
            if self.counter % df == 0:  # time in integer nanoseconds, as libcosim's time_point
                fmu.doStep(self.counter * self.base_ns / 1e9, df * self.base_ns / 1e9)
        self.counter += 1
        self.transfer()

    def get(self, unit, names):
        fmu, vr, _ = self.units[unit]
        return fmu.getReal([vr[n] for n in names])

    def close(self):
        for fmu, _, _ in self.units.values():
            fmu.terminate()
            fmu.freeInstance()


def assert_engine_equals_master(package, scenario, stop, fmu_dir, workdir):
    sc = dataclasses.replace(scenario, stop_time=stop)
    plant, ctrl = fmus.paths(fmu_dir, "native")
    master = run(sc, str(plant), str(ctrl), algorithm="jacobi")
    assert master.ok, master.message
    names = ["i_s_alpha", "i_s_beta", "psi_r_alpha", "omega_m", "T_e"]
    engine = FixedStepEngine(package, workdir)
    n = round(stop / sc.step)
    got = [engine.get("plant", names)]
    for _ in range(n):
        engine.step()
        got.append(engine.get("plant", names))
    engine.close()
    want = master.frame[[f"plant.{v}" for v in names]].to_numpy().tolist()
    every = round(sc.record.interval / sc.step)  # the master records every `every` steps
    assert len(want) == n // every + 1
    assert got[::every] == want


@pytest.mark.slow
@pytest.mark.parametrize("name, stop", [("ramp_rated_load", 0.3), ("deep_saturation", 0.15)])
def test_a_fixed_step_engine_running_the_package_gives_the_master_jacobi_run_to_the_bit(
        name, stop, fmu_dir, tmp_path):
    """ramp_rated_load over pre-magnetization, the switch to the law and the start of the ramp;
    deep_saturation: h = 50 us, the controller every 2 steps (decimation 2)."""
    path = ROOT / "scenarios" / f"{name}.yaml"
    out = tmp_path / "p.ssp"
    assert cli.main(["export-ssp", str(path), str(out), "--fmus", str(fmu_dir)]) == 0
    assert_engine_equals_master(out, load_scenario(path), stop, fmu_dir, tmp_path / "x")


def test_a_failure_while_writing_leaves_nothing_and_keeps_an_old_file(fmu_dir, tmp_path, monkeypatch):
    old = tmp_path / "p.ssp"
    old.write_bytes(b"previous")
    plant, ctrl = fmus.paths(fmu_dir, "native")

    def disk_full(src, dst, *args):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(ssp.shutil, "copyfileobj", disk_full)
    with pytest.raises(OSError, match="cannot write the SSP package: no space left on device"):
        ssp.export(load_scenario(DEFAULT), old, plant, ctrl)
    assert old.read_bytes() == b"previous" and sorted(tmp_path.iterdir()) == [old]


def test_the_package_gets_the_usual_file_permissions(default_ssp):
    import os

    umask = os.umask(0o022)
    os.umask(umask)
    assert default_ssp.stat().st_mode & 0o777 == 0o666 & ~umask


@pytest.mark.slow
@pytest.mark.parametrize("name, stop", [("ramp_rated_load", 0.3), ("deep_saturation", 0.15)])
def test_libcosim_loads_the_package_and_agrees_with_the_master(name, stop, fmu_dir, tmp_path):
    """libcosim (libcosimpy, if installed) runs the .ssp as it is: the algorithm and step sizes from
    the OSP annotations, the parameters from the bindings.  Its plant outputs equal the master's
    jacobi run to 1e-11 of each output's largest magnitude (seen: 4e-14; not to the bit, because
    libcosim passes each step size as the difference of two double times converted from integer
    nanoseconds, which differs from h in the last bits); from the first step on, the signals are
    profile.value(k h) exactly."""
    libcosimpy = pytest.importorskip("libcosimpy")
    import numpy as np
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimObserver import CosimObserver

    del libcosimpy
    path = ROOT / "scenarios" / f"{name}.yaml"
    out = tmp_path / "p.ssp"
    assert cli.main(["export-ssp", str(path), str(out), "--fmus", str(fmu_dir)]) == 0
    sc = dataclasses.replace(load_scenario(path), stop_time=stop)
    plant, ctrl = fmus.paths(fmu_dir, "native")
    md = read_model_description(str(plant))
    names = [v.name for v in md.modelVariables if v.causality == "output"]
    refs = [v.valueReference for v in md.modelVariables if v.causality == "output"]
    ex = CosimExecution.from_ssp_file(str(out))
    obs = CosimObserver.create_last_value()
    ex.add_observer(obs)
    ip, isig = ex.slave_index_from_instance_name("plant"), ex.slave_index_from_instance_name("signals")
    n = round(stop / sc.step)
    got, signals = [], []
    for _ in range(n):
        assert ex.step(1)
        got.append(obs.last_real_values(ip, refs))
        signals.append(obs.last_real_values(isig, [0, 1, 2]))
    master = run(sc, str(plant), str(ctrl), algorithm="jacobi")
    assert master.ok, master.message
    every = round(sc.record.interval / sc.step)
    want = master.frame[[f"plant.{v}" for v in names]].to_numpy()[1:]
    got = np.array(got)[every - 1::every]
    assert got.shape == want.shape
    assert np.all(np.abs(got - want) <= 1e-11 * np.max(np.abs(want), axis=0))
    assert signals == [[sc.profiles[s].value(k * sc.step) for s in ("omega_ref", "psi_ref", "T_load")]
                       for k in range(1, n + 1)]


def test_connections_the_package_cannot_hold_are_refused(fmu_dir, signals_md, tmp_path):
    from orchestration.scenario.system import Connection

    sc = load_scenario(DEFAULT)
    mds = model_descriptions(fmu_dir, signals_md)
    for bad in (Connection("profile.speed_ref", "controller.omega_ref"),  # no such signal
                Connection("plant.omega_m", "plant.T_load"),  # fine: an output to an input
                Connection("controller.omega_ref", "plant.T_load")):  # an input as the source
        conns = (*DEFAULT_CONNECTIONS, bad)
        if bad.source == "plant.omega_m":
            root = ET.fromstring(ssd.ssd_xml(sc, mds, conns))
            # and the link voltage (plant.v_dc -> controller.v_dc: an ideal link of the controller's V_dc)
            assert len(root.findall("ssd:System/ssd:Connections/ssd:Connection", NS)) == len(conns) + 1
            continue
        with pytest.raises(ssp.NotExpressible, match=rf"^{DEFAULT}: connections = "
                                                     rf"'{bad.source} -> {bad.target}': "):
            ssd.ssd_xml(sc, mds, conns)
    plant, ctrl = fmus.paths(fmu_dir, "native")
    with pytest.raises(ssp.NotExpressible):
        ssp.export(sc, tmp_path / "c.ssp", plant, ctrl, (*DEFAULT_CONNECTIONS, bad))
    assert list(tmp_path.iterdir()) == []

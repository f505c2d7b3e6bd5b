"""The native FMUs (C; FMI 2.0 in native/, FMI 3.0 in native-fmi3/) against the pythonfmu FMUs and
the FMI contract: validation, every library scenario through the master (the pythonfmu run is the
reference), a bad parameter (fmi2Error / fmi3Error, never fatal; a new instance works), non-finite
inputs (discard with a message), the FMU state (bit-identical round trip; the other FMU's blob
refused), many instances in one process."""

import ctypes
import math
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu

from orchestration.packaging import fmus
from orchestration.run.fmu_instance import FMUInstance
from orchestration.run.master import run
from orchestration.scenario.load import load_scenario
from satmotor.interface import CONTROLLER_PARAMETERS, PLANT_PARAMETERS

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[1]
LIBRARY = sorted((ROOT / "scenarios").glob("*.yaml"))
NATIVE = ("native", "native-fmi3")


def _paths(fmu_dir):
    return [p for v in NATIVE for p in fmus.paths(fmu_dir, v)]


def test_every_native_fmu_validates_and_needs_no_tool(fmu_dir):
    from fmu_manipulation_toolbox.assistant.fmutools import check_fmu

    for path in _paths(fmu_dir):
        assert validate_fmu(str(path)) == [], path
        md = read_model_description(str(path))
        assert md.coSimulation.needsExecutionTool in (False, "false")
        if md.fmiVersion == "2.0":
            report = check_fmu(path)
            assert report["compliant"] and report["error_count"] == 0, report


@pytest.mark.parametrize("variant", NATIVE)
@pytest.mark.parametrize("path", LIBRARY, ids=lambda p: p.stem)
def test_every_library_scenario_matches_the_pythonfmu_run(path, variant, fmu_dir):
    sc = load_scenario(path)
    ref = run(sc, *map(str, fmus.paths(fmu_dir, "python")))
    got = run(sc, *map(str, fmus.paths(fmu_dir, variant)))
    assert ref.ok and got.ok, (ref.message, got.message)
    a, b = got.frame, ref.frame
    assert list(a.columns) == list(b.columns) and len(a) == len(b)
    worst = max(np.max(np.abs(a[c].to_numpy() - b[c].to_numpy()))
                / max(np.max(np.abs(b[c].to_numpy())), 1e-300) for c in b.columns)
    assert worst <= 1e-9, worst


def _open(path, name="inst"):
    return FMUInstance(str(path), name)


@pytest.mark.parametrize("variant", NATIVE)
def test_a_bad_parameter_is_an_error_with_its_name_and_a_new_instance_works(variant, fmu_dir):
    plant_path, _ = fmus.paths(fmu_dir, variant)
    inst = _open(plant_path, "bad")
    inst.set_parameters({"J": 0.0})
    with pytest.raises(Exception) as exc:
        inst.initialize(0.0)
    assert exc.value.status == 3  # fmi2Error / fmi3Error, not fatal
    assert "J = 0.0: must be a finite number > 0" in inst.first_error()
    assert not inst.fatal
    inst.close()
    good = _open(plant_path, "good")
    good.initialize(0.0)
    good.do_step(0.0, 1e-4)
    good.close()


# every String parameter with a closed set of values (satmotor.interface Variable.choices):
# (unit: 0 plant, 1 controller; name; choices)
_TABLES = (PLANT_PARAMETERS, CONTROLLER_PARAMETERS)
CHOICE_PARAMETERS = [(j, v.name, v.choices) for j, table in enumerate(_TABLES) for v in table if v.choices]


@pytest.mark.parametrize("variant", NATIVE)
@pytest.mark.parametrize("unit, parameter, choices", CHOICE_PARAMETERS,
                         ids=[f"{('plant', 'ctrl')[u]}-{n}" for u, n, _ in CHOICE_PARAMETERS])
def test_a_string_parameter_outside_its_choices_is_an_error_naming_them(variant, fmu_dir, unit, parameter,
                                                                        choices):
    """The generated parser's refusal (sm_choice_parse) reaches the host: fmi2Error / fmi3Error at
    initialization, the message naming the parameter, the value and every allowed value."""
    inst = _open(fmus.paths(fmu_dir, variant)[unit], "bad")
    bad = choices[-1].capitalize()
    inst.set_parameters({parameter: bad})
    with pytest.raises(Exception) as exc:
        inst.initialize(0.0)
    assert exc.value.status == 3 and not inst.fatal
    assert f"{parameter} = {bad!r}: must be one of {', '.join(choices)}" in inst.first_error()
    inst.close()


@pytest.mark.parametrize("variant", NATIVE)
def test_a_non_finite_input_is_a_discard_naming_the_input(variant, fmu_dir):
    _, ctrl_path = fmus.paths(fmu_dir, variant)
    inst = _open(ctrl_path)
    inst.initialize(0.0)
    vr = inst.vr(["omega_m"])
    (inst.slave.setFloat64 if inst.fmi3 else inst.slave.setReal)(vr, [math.nan])
    with pytest.raises(Exception) as exc:
        inst.do_step(0.0, 1e-4)
    assert exc.value.status == 2
    assert "omega_m = nan: must be a finite number" in inst.first_error()
    inst.close()


def _slave(path, name):
    md = read_model_description(str(path))
    from fmpy import extract

    d = extract(str(path))
    kind = FMU3Slave if md.fmiVersion.startswith("3") else FMU2Slave
    s = kind(guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier,
             instanceName=name)
    s.instantiate()
    if md.fmiVersion.startswith("3"):
        s.enterInitializationMode()
    else:
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
    s.exitInitializationMode()
    return s, md


def _step_outputs(s, md, k0, k1):
    outs = [v.valueReference for v in md.modelVariables if v.causality == "output"
            and v.type in ("Real", "Float64")]
    inputs = {v.name: v.valueReference for v in md.modelVariables if v.causality == "input"}
    get = s.getFloat64 if md.fmiVersion.startswith("3") else s.getReal
    set_ = s.setFloat64 if md.fmiVersion.startswith("3") else s.setReal
    rows = []
    for k in range(k0, k1):
        if "v_s_alpha" in inputs:  # the plant: a rotating voltage
            set_([inputs["v_s_alpha"], inputs["v_s_beta"]], [200.0 * math.cos(300 * k * 1e-4),
                                                            200.0 * math.sin(300 * k * 1e-4)])
        else:  # the controller: a magnetized machine's measurements and set-points
            set_([inputs["psi_r_alpha"], inputs["i_s_alpha"], inputs["psi_ref"], inputs["omega_ref"]],
                 [0.9, 5.0, 0.95, 50.0])
        s.doStep(k * 1e-4, 1e-4)
        rows.append(get(outs))
    return rows


@pytest.mark.parametrize("variant", NATIVE)
def test_fmu_state_round_trip_is_bit_identical_and_the_other_fmus_blob_is_refused(variant, fmu_dir):
    plant_path, ctrl_path = fmus.paths(fmu_dir, variant)
    for path in (plant_path, ctrl_path):
        s, md = _slave(path, "a")
        _step_outputs(s, md, 0, 20)
        state = s.getFMUState()
        blob = bytes(s.serializeFMUState(state))
        first = _step_outputs(s, md, 20, 40)
        s.setFMUState(state)
        assert _step_outputs(s, md, 20, 40) == first
        s.setFMUState(s.deserializeFMUState(blob))
        assert _step_outputs(s, md, 20, 40) == first
        other_path = ctrl_path if path == plant_path else plant_path
        o, _ = _slave(other_path, "b")
        foreign = bytes(o.serializeFMUState(o.getFMUState()))
        with pytest.raises(FMICallException):
            s.setFMUState(s.deserializeFMUState(foreign))
        with pytest.raises(FMICallException):
            s.setFMUState(s.deserializeFMUState(blob[: len(blob) // 2]))
        assert _step_outputs(s, md, 40, 42) is not None  # the instance lives on
        for inst in (o, s):
            inst.terminate()
            inst.freeInstance()


@pytest.mark.parametrize("variant", NATIVE)
def test_many_instances_in_one_process_are_independent(variant, fmu_dir):
    plant_path, _ = fmus.paths(fmu_dir, variant)
    insts = []
    for j in range(20):
        s, md = _slave(plant_path, f"p{j}")
        insts.append((s, md))
    alone, _ = _slave(plant_path, "alone")
    ref = _step_outputs(alone, md, 0, 30)
    for k in range(0, 30, 10):  # interleaved, 10 steps each in turn
        for s, m in insts:
            got = _step_outputs(s, m, k, k + 10)
            assert got == ref[k:k + 10]
    for s, _ in insts + [(alone, md)]:
        s.terminate()
        s.freeInstance()
    assert ctypes.sizeof(ctypes.c_double) == 8


@pytest.mark.parametrize("variant", NATIVE)
def test_the_native_fmus_under_valgrind_touch_no_bad_memory(variant, fmu_dir, tmp_path):
    """A short real_drive run (observer, delay, noise) of both native FMUs through the master under
    valgrind: no error in the FMU binaries, no access to freed memory, a clean exit."""
    from test_process_exit import VALGRIND, python_child, run_under_valgrind

    if VALGRIND is None:
        pytest.skip("valgrind is not installed (scripts/system_packages.sh installs it)")
    plant, ctrl = fmus.paths(fmu_dir, variant)
    scenario = ROOT / "scenarios" / "real_drive.yaml"
    child = python_child(f"""
        import dataclasses, sys
        sys.path.insert(0, {str(ROOT)!r})
        from orchestration.run.master import run
        from orchestration.scenario.load import load_scenario
        sc = dataclasses.replace(load_scenario({str(scenario)!r}), stop_time=0.02)
        r = run(sc, {str(plant)!r}, {str(ctrl)!r})
        print(r.status, len(r.frame))
    """)
    runs = run_under_valgrind({variant: (child, {})}, tmp_path)
    r = runs[variant]
    assert r.returncode == 0 and r.stdout.split()[0] == "ok", r.describe()
    in_fmu = [e for e in r.errors if e["stack"] and "/binaries/" in e["stack"][0]["obj"]]
    assert not in_fmu and not r.exit_errors, r.describe()


def test_a_c_host_without_python_loads_the_native_plant_and_gets_the_python_numbers(fmu_dir, tmp_path):
    """A small C host (tests/native_c_host.c) dlopens the native FMI 2.0 plant in an empty environment
    (no Python, no PATH), steps it 100 times and prints outputs: the plain-Python unit's to the bit."""
    import subprocess
    import zipfile

    from bench.floor_host import build_c_host
    from satmotor.interface import PlantUnit

    host = build_c_host(ROOT / "tests" / "native_c_host.c", tmp_path / "host", flags=())
    plant_path, _ = fmus.paths(fmu_dir, "native")
    unzipped = tmp_path / "plant"
    with zipfile.ZipFile(plant_path) as z:
        z.extractall(unzipped)
    md = read_model_description(str(plant_path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    lib = unzipped / "binaries" / "linux64" / "SaturatedInductionMotor.so"
    outs = ["i_s_alpha", "i_s_beta", "omega_m", "T_e", "psi_r_alpha"]
    args = [str(host), str(lib), md.guid, (unzipped / "resources").as_uri(), "100", "1e-4",
            f"{vr['v_s_alpha']}=150", f"{vr['v_s_beta']}=-40", f"{vr['T_load']}=5", f"{vr['B_2']}=0.001",
            "--", *(str(vr[n]) for n in outs)]
    r = subprocess.run(args, capture_output=True, text=True, env={}, timeout=60)
    assert r.returncode == 0, r.stderr
    unit = PlantUnit({"B_2": 0.001})
    for k in range(100):
        unit.step(k * 1e-4, 1e-4, (150.0, -40.0, 5.0))
    want = dict(zip(PlantUnit.OUTPUTS, unit.outputs()))
    assert [float(x) for x in r.stdout.split()] == [want[n] for n in outs]


def test_no_global_mutable_state_in_the_core_or_the_models(tmp_path):
    """No writable data (bss/data/common symbols) in any object of the C core and of the two models
    (with their generated tables and the shared value accessors): every instance independent."""
    import shutil
    import subprocess

    from orchestration.packaging.native import compiler as native_build
    from orchestration.packaging.native import fmus as native_fmus

    if shutil.which("gcc") is None or shutil.which("nm") is None:
        pytest.skip("needs gcc and nm")
    inc = native_build.fmi_headers_dir()
    for name, unit in native_fmus.NAMES.items():
        gen = tmp_path / unit
        gen.mkdir()
        generated = native_fmus.generated(name, gen)
        srcs = [p for p in [*native_fmus.sources(name), *generated] if p.suffix == ".c"]
        dirs = {p.parent for p in native_fmus.sources(name)} | {gen, native_build.GLUE_DIR}
        for src in srcs:
            obj = gen / (src.stem + ".o")
            includes = [f"-I{d}" for d in sorted(dirs)]
            subprocess.run(["gcc", "-std=c99", "-O2", "-fPIC", "-c", f"-I{inc}", *includes, str(src), "-o",
                            str(obj)], check=True, capture_output=True)
            out = subprocess.run(["nm", "-f", "sysv", str(obj)], capture_output=True, text=True,
                                 check=True).stdout
            rows = [[c.strip() for c in line.split("|")] for line in out.splitlines() if line.count("|") == 6]
            writable = [r for r in rows if r[2] in "bBdDcC" and not r[6].startswith(".data.rel.ro")]
            assert writable == [], (src.name, writable)


@pytest.mark.parametrize("version", ["2.0", "3.0"])
def test_a_table_curve_reads_its_file_from_the_fmus_resources(version, tmp_path):
    """A native plant built with a no-load CSV in its resources, table_file = the bare file name: the
    same trajectory as the plain-Python unit reading that CSV."""
    from conftest import no_load_table

    from orchestration.packaging.native import fmus as native_fmus
    from satmotor.interface import PlantUnit

    i_mu, psi = no_load_table()
    csv = "i_mu,psi_m\n" + "".join(f"{a!r},{b!r}\n" for a, b in zip(i_mu, psi))
    path = native_fmus.build("SaturatedInductionMotor", tmp_path, version,
                             resources={"noload.csv": csv.encode()})
    inst = FMUInstance(str(path), "table")
    inst.set_parameters({"curve": "table", "table_file": "noload.csv", "psi_r0": 0.6})
    inst.initialize(0.0)
    vin = inst.vr(["v_s_alpha", "v_s_beta", "T_load"])
    outs = ["i_s_alpha", "i_mu", "omega_m"]
    set_ = inst.slave.setFloat64 if inst.fmi3 else inst.slave.setReal
    get = inst.slave.getFloat64 if inst.fmi3 else inst.slave.getReal
    (tmp_path / "noload.csv").write_text(csv)
    unit = PlantUnit({"curve": "table", "table_file": str(tmp_path / "noload.csv"), "psi_r0": 0.6})
    for k in range(200):
        u = (120.0 * math.cos(250 * k * 1e-4), 120.0 * math.sin(250 * k * 1e-4), 2.0)
        set_(vin, list(u))
        inst.do_step(k * 1e-4, 1e-4)
        unit.step(k * 1e-4, 1e-4, u)
    want = dict(zip(PlantUnit.OUTPUTS, unit.outputs()))
    assert get(inst.vr(outs)) == [want[n] for n in outs]
    inst.close()


@pytest.mark.parametrize("unit", [0, 1], ids=["plant", "controller"])
@pytest.mark.parametrize("variant", NATIVE)
def test_a_table_file_whose_resolved_path_does_not_fit_is_an_error_naming_it(variant, unit, fmu_dir):
    """table_file that does not exist as given is looked up in the FMU's resources by its base name;
    a base name that makes that path longer than the parameter's buffer is refused with an error
    naming table_file (the string itself fits: under 1024 bytes), and the instance is not fatal."""
    inst = _open(fmus.paths(fmu_dir, variant)[unit], "long")
    name = "x" * 1000 + ".csv"  # no such file, and longer than a file name may be
    inst.set_parameters({"curve": "table", "table_file": name})
    with pytest.raises(Exception) as exc:
        inst.initialize(0.0)
    assert exc.value.status == 3
    first = inst.first_error()
    assert first.startswith("table_file: the path in the FMU's resources is "), first
    assert "bytes long, more than 1023: /" in first, first
    assert not inst.fatal
    inst.close()

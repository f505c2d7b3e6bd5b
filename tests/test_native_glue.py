"""The native C FMI glue (fmu/native/fmi) with the first-order-lag test model (fmu/native/testmodel).

Builds FMI 2.0 and 3.0 co-simulation FMUs of x' = (u - x)/tau once per session with
orchestration.packaging.native.compiler and checks them through fmpy (validation, simulation against the exact
discrete solution), fmpy's low-level FMU2Slave/FMU3Slave (errors, wrong states, FMU state, many
instances) and a C host compiled with -fsanitize=address,undefined.
"""

from __future__ import annotations

import math
import re
import shutil
import subprocess
import zipfile
from ctypes import byref, c_double, c_int, c_size_t, c_uint, c_void_p, cast, create_string_buffer
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave, defaultCallbacks, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu

from orchestration.packaging.native import compiler as native_build
from orchestration.packaging.native import tables as native_tables
from satmotor.interface import Variable

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "fmu" / "native" / "testmodel" / "model.c"
COMMON = native_build.GLUE_DIR.parent / "common"  # sm_values.c: the value accessors of every native model
VR = {"time": 0, "u": 1, "hold": 2, "tau": 3, "n_sub": 4, "label": 5, "y": 6, "steps": 7, "rising": 8}
# the test model's table: its C value references, value store and start values are generated from it
TABLE = (Variable("time", "independent", "Real", None, "s", "simulation time"),
         Variable("u", "input", "Real", 0.0, "1", "input"),
         Variable("hold", "input", "Boolean", False, "", "x is frozen while true"),
         Variable("tau", "parameter", "Real", 1.0, "s", "time constant, > 0"),
         Variable("n_sub", "parameter", "Integer", 1, "1", "sub-steps per communication step, >= 1"),
         Variable("label", "parameter", "String", "lag", "", "a label, at most 63 bytes"),
         Variable("y", "output", "Real", 0.0, "1", "x"),
         Variable("steps", "output", "Integer", 0, "1", "number of completed steps"),
         Variable("rising", "output", "Boolean", False, "", "x < u"))
LABEL_MAX = 64  # bytes of the label, the NUL included


def test_the_table_numbers_the_variables_as_the_model_descriptions():
    assert {v.name: vr for vr, v in enumerate(TABLE)} == VR


def model_sources(out_dir):
    """The test model's C files: model.c, the shared value accessors and its generated tables (written
    into ``out_dir``)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    return [MODEL, COMMON / "sm_values.h", COMMON / "sm_values.c",
            *native_tables.model_files("lag", out_dir, TABLE, LABEL_MAX)]


def model_c_files(out_dir):
    """``(the .c files, the -I flags)`` to compile the test model outside an FMU build."""
    files = model_sources(out_dir)
    return [str(f) for f in files if f.suffix == ".c"], [f"-I{d}" for d in sorted({f.parent for f in files})]
HEADER_MODEL_ID_OFFSET = 24  # magic[8], format u32, phase u32, data size u64

LOG_CATEGORIES = ("logEvents", "logStatusWarning", "logStatusDiscard", "logStatusError")


def model_description(version: str, identifier: str = "lag") -> str:
    """The test model's modelDescription.xml, written by hand (GUID/token left to the build)."""
    cats = "".join(f'<Category name="{c}"/>' for c in LOG_CATEGORIES)
    if version == "2.0":
        def sv(name, causality, variability, typ, extra="", start=None):
            s = "" if start is None else f' start="{start}"'
            return (f'<ScalarVariable name="{name}" valueReference="{VR[name]}" causality="{causality}" '
                    f'variability="{variability}"{extra}><{typ}{s}/></ScalarVariable>')
        variables = [
            sv("time", "independent", "continuous", "Real"),
            sv("u", "input", "continuous", "Real", start="0"),
            sv("hold", "input", "discrete", "Boolean", start="false"),
            sv("tau", "parameter", "fixed", "Real", ' initial="exact"', "1"),
            sv("n_sub", "parameter", "fixed", "Integer", ' initial="exact"', "1"),
            sv("label", "parameter", "fixed", "String", ' initial="exact"', "lag"),
            sv("y", "output", "continuous", "Real", ' initial="calculated"'),
            sv("steps", "output", "discrete", "Integer", ' initial="calculated"'),
            sv("rising", "output", "discrete", "Boolean", ' initial="calculated"'),
        ]
        outs = "".join(f'<Unknown index="{VR[n] + 1}"/>' for n in ("y", "steps", "rising"))
        return (
            '<?xml version="1.0" encoding="UTF-8"?>\n'
            f'<fmiModelDescription fmiVersion="2.0" modelName="{identifier}" guid="{{GUID}}" '
            'generationTool="satmotor native_build" variableNamingConvention="structured" '
            'numberOfEventIndicators="0">'
            f'<CoSimulation modelIdentifier="{identifier}" needsExecutionTool="false" '
            'canHandleVariableCommunicationStepSize="true" canGetAndSetFMUstate="true" '
            'canSerializeFMUstate="true"/>'
            f'<LogCategories>{cats}</LogCategories>'
            '<DefaultExperiment startTime="0" stopTime="2" stepSize="0.1"/>'
            f'<ModelVariables>{"".join(variables)}</ModelVariables>'
            f'<ModelStructure><Outputs>{outs}</Outputs><InitialUnknowns>{outs}</InitialUnknowns>'
            '</ModelStructure></fmiModelDescription>\n')
    variables = [
        '<Float64 name="time" valueReference="0" causality="independent" variability="continuous"/>',
        '<Float64 name="u" valueReference="1" causality="input" variability="continuous" start="0"/>',
        '<Boolean name="hold" valueReference="2" causality="input" variability="discrete" start="false"/>',
        '<Float64 name="tau" valueReference="3" causality="parameter" variability="fixed" start="1"/>',
        '<Int32 name="n_sub" valueReference="4" causality="parameter" variability="fixed" start="1"/>',
        '<String name="label" valueReference="5" causality="parameter" variability="fixed">'
        '<Start value="lag"/></String>',
        '<Float64 name="y" valueReference="6" causality="output" variability="continuous"/>',
        '<Int32 name="steps" valueReference="7" causality="output" variability="discrete"/>',
        '<Boolean name="rising" valueReference="8" causality="output" variability="discrete"/>',
    ]
    outs = "".join(f'<Output valueReference="{VR[n]}"/>' for n in ("y", "steps", "rising"))
    inits = "".join(f'<InitialUnknown valueReference="{VR[n]}"/>' for n in ("y", "steps", "rising"))
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<fmiModelDescription fmiVersion="3.0" modelName="{identifier}" instantiationToken="{{GUID}}" '
        'generationTool="satmotor native_build" variableNamingConvention="structured">'
        f'<CoSimulation modelIdentifier="{identifier}" needsExecutionTool="false" '
        'canHandleVariableCommunicationStepSize="true" canGetAndSetFMUState="true" '
        'canSerializeFMUState="true" hasEventMode="false" providesIntermediateUpdate="false"/>'
        f'<LogCategories>{cats}</LogCategories>'
        '<DefaultExperiment startTime="0" stopTime="2" stepSize="0.1"/>'
        f'<ModelVariables>{"".join(variables)}</ModelVariables>'
        f'<ModelStructure>{outs}{inits}</ModelStructure></fmiModelDescription>\n')


def _build(tmp: Path, version: str, identifier: str = "lag", name: str | None = None):
    out = tmp / f"{name or identifier}_fmi{version[0]}.fmu"
    path, token = native_build.build_native_fmu(
        identifier, model_sources(tmp / f"gen_{name or identifier}_{version[0]}"),
        model_description(version, identifier), out, fmi_version=version,
        resources={"note.txt": "test resource\n"})
    return {"path": path, "token": token, "dir": extract(str(path), str(tmp / f"{path.stem}_x")),
            "identifier": identifier}


@pytest.fixture(scope="session")
def fmus(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("native_glue")
    return {v: {"lag": _build(tmp, v), "other": _build(tmp, v, "lagb")} for v in ("2.0", "3.0")}


class Host:
    """An instance through fmpy's low-level API, collecting the log messages."""

    def __init__(self, fmu, version, name="inst"):
        self.version, self.messages = version, []
        cls = FMU2Slave if version == "2.0" else FMU3Slave
        self.slave = cls(guid=fmu["token"], unzipDirectory=fmu["dir"], modelIdentifier=fmu["identifier"],
                         instanceName=name)
        if version == "2.0":
            self.callbacks = fmi2CallbackFunctions()
            self.callbacks.logger = fmi2CallbackLoggerTYPE(self._log2)
            self.callbacks.allocateMemory = defaultCallbacks.allocateMemory
            self.callbacks.freeMemory = defaultCallbacks.freeMemory
            self.slave.instantiate(callbacks=self.callbacks)
        else:
            self.slave.instantiate(logMessage=self._log3)

    def _log2(self, env, name, status, category, message):
        self.messages.append((status, message.decode()))

    def _log3(self, env, status, category, message):
        self.messages.append((status, message.decode()))

    def call(self, method, *args):
        """Call a method of the slave; the FMI status (0 OK ... 3 error)."""
        try:
            getattr(self.slave, method)(*args)
            return 0
        except FMICallException as e:
            return e.status

    def raw(self, fname, *args):
        """Call an FMI function directly (NULL pointers allowed); the status it returned."""
        return self.slave._functions[fname](self.slave.component, *args)

    def init(self, **params):
        for k, v in params.items():
            self.set(k, v)
        if self.version == "2.0":
            self.slave.setupExperiment(startTime=0.0)
        self.slave.enterInitializationMode()
        self.slave.exitInitializationMode()

    def set(self, name, value):
        vr = [VR[name]]
        if isinstance(value, bool):
            return self.call("setBoolean", vr, [value])
        if isinstance(value, int):
            return self.call("setInteger" if self.version == "2.0" else "setInt32", vr, [value])
        if isinstance(value, str):
            return self.call("setString", vr, [value])
        return self.call("setReal" if self.version == "2.0" else "setFloat64", vr, [value])

    def y(self):
        return (self.slave.getReal if self.version == "2.0" else self.slave.getFloat64)([VR["y"]])[0]

    def step(self, t, h):
        return self.call("doStep", t, h)

    def serialize(self):
        s = self.slave.getFMUState()
        blob = (self.slave.serializeFMUstate if self.version == "2.0" else self.slave.serializeFMUState)(s)
        self.slave.freeFMUState(s)
        return blob

    def deserialize(self, blob):
        s = self.slave
        return (s.deSerializeFMUstate if self.version == "2.0" else s.deserializeFMUState)(blob)

    def last(self):
        return self.messages[-1][1] if self.messages else ""

    def free(self):
        self.slave.freeInstance()


VERSIONS = ("2.0", "3.0")


@pytest.mark.parametrize("version", VERSIONS)
def test_package_layout_exports_and_reproducibility(fmus, version, tmp_path):
    fmu = fmus[version]["lag"]
    folder = "linux64" if version == "2.0" else "x86_64-linux"
    with zipfile.ZipFile(fmu["path"]) as z:
        names = z.namelist()
        assert names == sorted(names)
        assert all(i.date_time == (1980, 1, 1, 0, 0, 0) for i in z.infolist())
    assert f"binaries/{folder}/lag.so" in names
    v = version[0]
    for n in ("fg_model.h", "fg_instance.c", "fg_state.c", f"fmi{v}_glue.c", "model.c", f"fmi{v}Functions.h"):
        assert f"sources/{n}" in names
    assert "resources/note.txt" in names
    assert fmu["token"].startswith("{") and len(fmu["token"]) == 38
    if shutil.which("nm"):  # only the FMI functions are exported
        so = Path(fmu["dir"]) / "binaries" / folder / "lag.so"
        out = subprocess.run(["nm", "-D", "--defined-only", str(so)], capture_output=True, text=True).stdout
        syms = [line.split()[-1] for line in out.splitlines() if line.strip()]
        assert syms and all(s.startswith(f"fmi{version[0]}") for s in syms), syms
        assert f"fmi{version[0]}DoStep" in syms
    again = _build(tmp_path, version)  # same inputs -> byte-identical FMU
    assert again["path"].read_bytes() == fmu["path"].read_bytes()


@pytest.mark.parametrize("version", VERSIONS)
def test_validate_fmu_reports_nothing(fmus, version):
    assert validate_fmu(str(fmus[version]["lag"]["path"])) == []


@pytest.mark.parametrize("version", VERSIONS)
def test_simulate_matches_exact_discrete_solution(fmus, version):
    tau, u = 0.3, 1.5
    res = simulate_fmu(str(fmus[version]["lag"]["path"]), stop_time=2.0, output_interval=0.05,
                       start_values={"u": u, "tau": tau, "n_sub": 3, "label": "step response"},
                       output=["y", "steps", "rising"])
    t = res["time"]
    assert len(t) == 41 and t[-1] == pytest.approx(2.0)
    x, expected = 0.0, [0.0]
    for k in range(1, len(t)):  # x_{k+1} = u + (x_k - u) exp(-h/tau), the exact step of a constant input
        x = u + (x - u) * math.exp(-(t[k] - t[k - 1]) / tau)
        expected.append(x)
    for k in range(len(t)):
        assert res["y"][k] == pytest.approx(expected[k], rel=1e-12, abs=1e-14)
        assert res["y"][k] == pytest.approx(u * (1 - math.exp(-t[k] / tau)), rel=1e-9, abs=1e-12)
    assert list(res["steps"]) == list(range(len(t)))
    assert all(res["rising"])


@pytest.mark.parametrize("version", VERSIONS)
def test_bad_parameter_is_an_error_naming_it(fmus, version):
    h = Host(fmus[version]["lag"], version)
    assert h.set("tau", -0.5) == 0
    if version == "2.0":
        h.slave.setupExperiment(startTime=0.0)
    h.slave.enterInitializationMode()
    assert h.call("exitInitializationMode") == 3
    assert "tau" in h.last() and "-0.5" in h.last(), h.messages
    assert h.step(0.0, 0.1) == 3  # the instance is in the error state
    h.free()
    h2 = Host(fmus[version]["lag"], version, "second")
    h2.init(tau=0.5, u=1.0)
    assert h2.step(0.0, 0.1) == 0
    assert h2.y() == pytest.approx(1 - math.exp(-0.2), rel=1e-14)
    h2.free()


@pytest.mark.parametrize("version", VERSIONS)
def test_nan_input_discards_with_a_message(fmus, version):
    h = Host(fmus[version]["lag"], version)
    h.init(u=1.0)
    assert h.step(0.0, 0.1) == 0
    assert h.set("u", float("nan")) == 0
    assert h.step(0.1, 0.1) == 2
    assert "non-finite input u" in h.last() and "nan" in h.last()
    assert h.step(0.1, 0.1) == 3  # no stepping on after a discard
    assert "not allowed" in h.last()
    assert h.y() == pytest.approx(1 - math.exp(-0.1))  # outputs still readable
    assert h.call("terminate") == 0
    h.free()


@pytest.mark.parametrize("version", VERSIONS)
def test_calls_in_the_wrong_state_are_errors(fmus, version):
    h = Host(fmus[version]["lag"], version)
    v = version[0]
    assert h.step(0.0, 0.1) == 3
    assert f"fmi{v}DoStep" in h.last() and "not allowed" in h.last()
    assert h.call("exitInitializationMode") == 3
    getter = "getReal" if v == "2" else "getFloat64"
    assert h.call(getter, [VR["y"]]) == 3
    assert h.set("y", 1.0) == 3 and "'y'" in h.last() and "not settable" in h.last()
    vrs = (c_uint * 1)(99)
    vals = (c_double * 1)()
    if v == "2":
        assert h.raw("fmi2GetReal", None, c_size_t(1), None) == 3
        assert h.raw("fmi2SetReal", vrs, c_size_t(1), vals) == 3
        assert "unknown value reference 99" in h.last()
        assert h.raw("fmi2GetDirectionalDerivative", None, 0, None, 0, None, None) == 3
    else:
        assert h.raw("fmi3GetFloat64", None, c_size_t(1), None, c_size_t(1)) == 3
        assert h.raw("fmi3SetFloat64", vrs, c_size_t(1), vals, c_size_t(1)) == 3
        assert "unknown value reference 99" in h.last()
        assert h.raw("fmi3EnterEventMode") == 3 and "not supported" in h.last()
        assert h.raw("fmi3GetFloat32", None, c_size_t(0), None, c_size_t(0)) == 3
    assert h.set("tau", 2.0) == 0  # still usable: nothing above changed the phase
    h.init(u=1.0)
    assert h.set("tau", 3.0) == 3
    assert "tau" in h.last() and "fixed parameter" in h.last()
    assert h.set("n_sub", 2) == 3 and h.set("label", "x") == 3
    assert h.set("u", 0.5) == 0 and h.set("hold", True) == 0  # inputs may change between steps
    assert h.step(0.0, 0.1) == 0 and h.y() == 0.0  # held
    assert h.call("enterInitializationMode") == 3
    assert h.step(0.5, 0.1) == 3 and "differs from the FMU time" in h.last()
    assert h.call("terminate") == 0
    assert h.step(0.1, 0.1) == 3
    assert h.call("reset") == 0
    h.init(tau=2.0, u=1.0)  # back to instantiated with start values
    assert h.step(0.0, 0.1) == 0 and h.y() == pytest.approx(1 - math.exp(-0.05), rel=1e-14)
    fn = h.slave._functions[f"fmi{v}DoStep"]  # a NULL instance (before free: that unloads the library)
    if v == "2":
        assert fn(None, 0.0, 0.1, c_int(1)) == 3
    else:
        assert fn(None, 0.0, 0.1, True, None, None, None, None) == 3
    h.free()
    bad = dict(fmus[version]["lag"], token="{00000000-0000-0000-0000-000000000000}")
    with pytest.raises(Exception, match="nstantiate"):
        Host(bad, version, "wrong_guid")


@pytest.mark.parametrize("version", VERSIONS)
def test_state_round_trip_and_foreign_blobs(fmus, version):
    h = Host(fmus[version]["lag"], version)
    h.init(tau=0.4, u=2.0, label="state test")
    t = 0.0
    for _ in range(5):
        assert h.step(t, 0.1) == 0
        t += 0.1
    blob = h.serialize()
    cont = []
    for k in range(5):
        h.step(t + 0.1 * k, 0.1)
        cont.append(h.y())
    state = h.deserialize(blob)
    h.slave.setFMUState(state)
    h.slave.freeFMUState(state)
    assert h.serialize() == blob  # bit-identical
    again = []
    for k in range(5):
        assert h.step(t + 0.1 * k, 0.1) == 0
        again.append(h.y())
    assert again == cont  # bit-identical continuation
    assert h.slave.getString([VR["label"]])[0] == b"state test" or \
        h.slave.getString([VR["label"]])[0] == "state test"

    other = Host(fmus[version]["other"], version, "other")
    other.init()
    other.step(0.0, 0.1)
    foreign = other.serialize()
    other.free()
    assert len(foreign) == len(blob)
    before = h.serialize()
    fname = "fmi2DeSerializeFMUstate" if version == "2.0" else "fmi3DeserializeFMUState"
    patched = bytearray(blob)
    patched[HEADER_MODEL_ID_OFFSET] ^= 0x20
    for bad, words in ((foreign, ("another model", "lagb")), (blob[:-1], ("truncated",)),
                       (blob[:10], ("truncated",)), (bytes(patched), ("another model",)),
                       (b"x" * len(blob), ("magic",))):
        buf = cast(create_string_buffer(bad, len(bad)), h.slave._functions[fname].argtypes[1])
        st = c_void_p()
        assert h.raw(fname, buf, c_size_t(len(bad)), byref(st)) == 3
        assert st.value is None
        assert all(w in h.last() for w in words), (words, h.last())
    assert h.serialize() == before  # the instance is unchanged
    h.free()


@pytest.mark.parametrize("version", VERSIONS)
def test_fifty_instances_are_independent(fmus, version):
    hosts = [Host(fmus[version]["lag"], version, f"i{k}") for k in range(50)]
    taus = [0.1 + 0.02 * k for k in range(50)]
    for h, tau in zip(hosts, taus):
        h.init(tau=tau, u=1.0, n_sub=1 + hosts.index(h) % 3)
    t = 0.0
    for _ in range(10):
        for h in hosts:
            assert h.step(t, 0.05) == 0
        t += 0.05
    for h, tau in zip(hosts, taus):
        assert h.y() == pytest.approx(1 - math.exp(-t / tau), rel=1e-12)
    hosts[7].set("u", float("nan"))
    assert hosts[7].step(t, 0.05) == 2
    assert hosts[8].step(t, 0.05) == 0  # a neighbour is not affected
    assert all(not h.messages or h is hosts[7] for h in hosts)
    for h in hosts:
        h.free()


HOST_C = Path(__file__).with_name("native_glue_host.c")


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")
@pytest.mark.parametrize("version", VERSIONS)
def test_sanitizers_clean(tmp_path, version):
    """A C host with the glue and the model compiled in, under ASan+UBSan (leaks included)."""
    exe = tmp_path / "host"
    inc = native_build.fmi_headers_dir()
    model, model_inc = model_c_files(tmp_path / "gen")
    cmd = ["gcc", "-std=c99", "-g", "-O1", "-Wall", "-Wextra", "-Werror", "-pedantic",
           "-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer",
           f"-I{inc}", f"-I{native_build.GLUE_DIR}", *model_inc, "-DMODEL_IDENTIFIER=lag",
           '-DINSTANTIATION_TOKEN="{asan}"', *(["-DHOST_FMI3"] if version == "3.0" else []),
           str(HOST_C), str(native_build.GLUE_DIR / f"fmi{version[0]}_glue.c"),
           str(native_build.GLUE_DIR / "fg_instance.c"), str(native_build.GLUE_DIR / "fg_state.c"), *model,
           "-o", str(exe), "-lm"]
    subprocess.run(cmd, check=True, capture_output=True)
    r = subprocess.run([str(exe)], capture_output=True, text=True, timeout=60,
                       env={"ASAN_OPTIONS": "detect_leaks=1:abort_on_error=0",
                            "UBSAN_OPTIONS": "print_stacktrace=1"})
    assert r.returncode == 0, r.stdout + r.stderr
    assert "OK" in r.stdout and "AddressSanitizer" not in r.stderr and "runtime error" not in r.stderr


@pytest.mark.skipif(shutil.which("valgrind") is None or shutil.which("gcc") is None, reason="needs valgrind")
def test_valgrind_clean(tmp_path):
    """The same host, built as shipped (-O2), under valgrind memcheck."""
    exe = tmp_path / "host"
    model, model_inc = model_c_files(tmp_path / "gen")
    subprocess.run(["gcc", "-std=c99", "-O2", f"-I{native_build.fmi_headers_dir()}",
                    f"-I{native_build.GLUE_DIR}", *model_inc,
                    "-DMODEL_IDENTIFIER=lag", '-DINSTANTIATION_TOKEN="{vg}"', str(HOST_C),
                    str(native_build.GLUE_DIR / "fmi2_glue.c"), str(native_build.GLUE_DIR / "fg_instance.c"),
                    str(native_build.GLUE_DIR / "fg_state.c"), *model, "-o", str(exe), "-lm"],
                   check=True, capture_output=True)
    r = subprocess.run(["valgrind", "--error-exitcode=99", "--leak-check=full", "--errors-for-leak-kinds=all",
                        str(exe)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "ERROR SUMMARY: 0 errors" in r.stderr


CROSS = {"2.0": ("linux64", "win64", "darwin64"),
         "3.0": ("x86_64-linux", "x86_64-windows", "x86_64-darwin", "aarch64-darwin")}
# a thin 64-bit Mach-O (FMI 3.0's x86_64-darwin, aarch64-darwin) or a fat one (FMI 2.0's darwin64:
# x86_64 and arm64, big-endian FAT_MAGIC)
MAGIC = {".so": (b"\x7fELF",), ".dll": (b"MZ",), ".dylib": (b"\xcf\xfa\xed\xfe", b"\xca\xfe\xba\xbe")}


@pytest.mark.slow
@pytest.mark.skipif(not native_build.zig_available(), reason="needs `pip install ziglang`")
@pytest.mark.parametrize("version", VERSIONS)
def test_cross_compiled_fmu(tmp_path, version):
    """zig cc builds for Windows and macOS: valid FMU, right binary formats, only FMI symbols named,
    reproducible. (The binaries cannot be run here.)"""
    paths = [native_build.build_native_fmu("lag", model_sources(tmp_path / "gen"), model_description(version),
                                           tmp_path / f"{k}.fmu",
                                           version, CROSS[version])[0] for k in range(2)]
    assert paths[0].read_bytes() == paths[1].read_bytes()
    assert validate_fmu(str(paths[0])) == []
    with zipfile.ZipFile(paths[0]) as z:
        bins = {n: z.read(n) for n in z.namelist() if n.startswith("binaries/")}
    assert len(bins) == len(CROSS[version])
    folder = tmp_path / "x"
    extract(str(paths[0]), str(folder))
    for name, data in bins.items():
        want = MAGIC[Path(name).suffix][1:] if "/darwin64/" in name else MAGIC[Path(name).suffix][:1]
        assert data.startswith(want), name  # darwin64 fat, the others thin
        syms = exported_symbols(folder / name)
        if syms is not None:
            syms = [s.removeprefix("_") for s in syms if s not in MACHO_LINKER_SYMBOLS]
            v = version[0]
            assert f"fmi{v}DoStep" in syms and all(s.startswith(f"fmi{v}") for s in syms), (name, syms)


MACHO_LINKER_SYMBOLS = ("___dso_handle", "__mh_dylib_header")


def exported_symbols(binary: Path) -> list[str] | None:
    """The exported symbols of an ELF/Mach-O (llvm-nm) or PE (objdump -p) library; None without the tools."""
    if binary.suffix == ".dll":
        if not shutil.which("objdump"):
            return None
        out = subprocess.run(["objdump", "-p", str(binary)], capture_output=True, text=True).stdout
        table = out.split("[Ordinal/Name Pointer] Table", 1)[-1].split("\n\n", 1)[0]
        return [line.split("]")[-1].strip() for line in table.splitlines() if "]" in line]
    if not shutil.which("llvm-nm"):
        return None
    out = subprocess.run(["llvm-nm", "--defined-only", "--extern-only", str(binary)], capture_output=True,
                         text=True).stdout
    return [line.split()[-1] for line in out.splitlines() if line.strip()]


@pytest.mark.skipif(shutil.which("gcc") is None or shutil.which("nm") is None, reason="needs gcc and nm")
def test_no_global_mutable_state(tmp_path):
    """No writable data (bss/data/common symbols) in the objects of the glue and the test model (with
    its generated tables and the shared value accessors), but the one documented exception: the
    registry of live instances ``fg_live`` (a lock and a list head, file-local) in fg_instance.c, which
    makes a double freeInstance harmless (docs/fmus.md, "Double freeInstance")."""
    inc = native_build.fmi_headers_dir()
    model, model_inc = model_c_files(tmp_path / "gen")
    for src in [*native_build.GLUE_DIR.glob("*.c"), *map(Path, model)]:
        obj = tmp_path / (src.stem + ".o")
        # the Scheduled Execution glue needs its clock (orchestration/packaging/native/clocked.py)
        clock = (["-DFG_SCHEDULED_EXECUTION", "-DFG_CLOCK_VR=9", "-DFG_CLOCK_INTERVAL=0.001"]
                 if src.name == "fmi3_se_glue.c" else [])
        subprocess.run(["gcc", "-std=c99", "-O2", "-fPIC", "-c", f"-I{inc}", f"-I{native_build.GLUE_DIR}",
                        *model_inc, *clock, "-DMODEL_IDENTIFIER=lag", '-DINSTANTIATION_TOKEN="{x}"', str(src),
                        "-o", str(obj)], check=True, capture_output=True)
        out = subprocess.run(["nm", "-f", "sysv", str(obj)], capture_output=True, text=True,
                             check=True).stdout
        rows = [[c.strip() for c in line.split("|")] for line in out.splitlines() if line.count("|") == 6]
        # name|value|class|type|size|line|section; .data.rel.ro is read-only after relocation (const tables
        # of pointers, with -fPIC)
        writable = [r for r in rows if r[2] in "bBdDcC" and not r[6].startswith(".data.rel.ro")]
        if src.name == "fg_instance.c":
            assert [(r[0], r[2]) for r in writable] == [("fg_live", "b")], writable  # local, zero-initialized
            continue
        assert writable == [], (src.name, writable)


@pytest.mark.parametrize("version", VERSIONS)
def test_debug_logging_and_percent_in_messages(fmus, version):
    """Debug (OK) messages only with logging on; FMI 2 messages are printf formats, so '%' is doubled."""
    h = Host(fmus[version]["lag"], version)
    h.init(label="100% lag")
    assert h.messages == []  # logging off: no OK-level message
    h.free()
    h = Host(fmus[version]["lag"], version, "verbose")
    h.call("setDebugLogging", True, [])
    h.init(label="100% lag")
    assert h.messages and h.messages[-1][0] == 0
    assert ("100%% lag" if version == "2.0" else "100% lag") in h.last()
    h.free()


@pytest.mark.parametrize("version", VERSIONS)
def test_simulate_step_input_at_half_time(fmus, version):
    """A step of u from 0 to 1 at t = 0.5 through fmpy's input table (set by the master between steps)."""
    tau = 0.2
    sig = np.array([(0.0, 0.0), (0.5, 0.0), (0.5, 1.0), (2.0, 1.0)],
                   dtype=[("time", np.float64), ("u", np.float64)])
    res = simulate_fmu(str(fmus[version]["lag"]["path"]), stop_time=2.0, output_interval=0.1,
                       start_values={"tau": tau}, input=sig, output=["u", "y"])
    t, u, y = res["time"], res["u"], res["y"]
    assert set(np.unique(u)) == {0.0, 1.0}
    x = 0.0
    for k in range(1, len(t)):  # the row at t_k holds the u the master set at t_{k-1} for the step to t_k
        x = u[k] + (x - u[k]) * math.exp(-(t[k] - t[k - 1]) / tau)
        assert y[k] == pytest.approx(x, rel=1e-12, abs=1e-15)
    t_step = t[np.argmax(u > 0.5) - 1]  # the communication point at which u became 1
    assert t_step == pytest.approx(0.5)
    after = t > t_step
    np.testing.assert_allclose(y[after], 1 - np.exp(-(t[after] - t_step) / tau), rtol=1e-9)
    assert np.all(y[~after] == 0.0)


@pytest.mark.slow
@pytest.mark.skipif(not native_build.zig_available(), reason="needs `pip install ziglang`")
def test_portable_linux_binary_with_zig(tmp_path):
    """linux_glibc='2.17': zig cc links against glibc 2.17; the FMU runs here and gives the same result."""
    path, _ = native_build.build_native_fmu("lag", model_sources(tmp_path / "gen"), model_description("2.0"),
                                            tmp_path / "lag.fmu",
                                            "2.0", linux_glibc="2.17")
    folder = tmp_path / "x"
    extract(str(path), str(folder))
    if shutil.which("objdump"):
        out = subprocess.run(["objdump", "-T", str(folder / "binaries" / "linux64" / "lag.so")],
                             capture_output=True, text=True).stdout
        versions = {tuple(map(int, v.split("."))) for v in set(re.findall(r"GLIBC_(\d+\.\d+)", out))}
        assert versions and max(versions) <= (2, 17), versions
    res = simulate_fmu(str(path), stop_time=1.0, output_interval=0.1, start_values={"u": 1.0, "tau": 0.5})
    np.testing.assert_allclose(res["y"], 1 - np.exp(-res["time"] / 0.5), rtol=1e-12, atol=1e-15)

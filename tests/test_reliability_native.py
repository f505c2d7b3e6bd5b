"""Reliability of the native FMUs (issue 23, the C side), FMI 2.0 and 3.0.

Most cases run in ``tests/reliability_host.c``, a C host with the glue and one native model (plant,
controller, ScenarioSignals) compiled in under AddressSanitizer + UBSan (leaks included): corrupted
serialized states, FMU states left to ``freeInstance``, a double ``freeInstance``, random FMI call
sequences, and the readers of the files a user supplies (the ``table`` curve's CSV, the ScenarioSignals
profiles) fed random, truncated, huge and malformed files.  The rest goes through fmpy on the built FMUs
(``SATMOTOR_TEST_FMUS``): the bounded work per ``doStep`` (the plant's ``max_substeps``, the controller's
``max_samples``, also the pythonfmu FMUs) and the plausibility warnings.  Every host run prints its
counts; they are echoed (``-s``) for the record.
"""

from __future__ import annotations

import math
import os
import random
import re
import shutil
import subprocess
import time
from pathlib import Path

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave, defaultCallbacks, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
from fmpy.fmi3 import FMU3Slave

from orchestration.packaging import signals_fmu
from orchestration.packaging.native import compiler as native_build
from orchestration.packaging.native import fmus as native_fmus
from orchestration.packaging.native import model_exchange
from orchestration.packaging.native import tables as native_tables
from satmotor.interface import MAX_STEP_SAMPLES, MAX_SUBSTEPS, PlantUnit

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")

HOST_C = Path(__file__).with_name("reliability_host.c")
VERSIONS = ("2.0", "3.0")
PLANT, CONTROLLER, SIGNALS = "SaturatedInductionMotor", "BacksteppingController", signals_fmu.MODEL_NAME
ME = model_exchange.NAME  # the plant built for model exchange (the host's -DHOST_ME)
#: the native FMU kinds the random call sequences cover: co-simulation plant, controller and profiles
#: FMU, the model-exchange plant (each FMI 2.0 and 3.0)
KINDS = (PLANT, CONTROLLER, SIGNALS, ME)
#: sequences per kind and FMI version in the default run (make test-slow: the sanitizers' build); the
#: environment variable asks for more (e.g. 20000 for a night)
FUZZ_SEQUENCES = 300
FUZZ_MANY = int(os.environ.get("SATMOTOR_FUZZ_SEQUENCES", "3000"))
SANITIZER_ENV = {"ASAN_OPTIONS": "detect_leaks=1:abort_on_error=0:halt_on_error=1",
                 "UBSAN_OPTIONS": "print_stacktrace=1:halt_on_error=1", "PATH": os.environ.get("PATH", "")}
REPORT = re.compile(r"ERROR: (AddressSanitizer|LeakSanitizer)|runtime error:")


@pytest.fixture(scope="module")
def host(tmp_path_factory):
    """``host(model, version)``: the path of the sanitized host for that model (built once)."""
    root = tmp_path_factory.mktemp("reliability")
    built = {}

    def get(model, version):
        if (model, version) not in built:
            d = root / f"{model}-{version}"
            gen = d / "gen"
            gen.mkdir(parents=True)
            extra, glue = [], [*native_build.glue_files(version)]
            if model == SIGNALS:
                files = [*signals_fmu.sources(),
                         *native_tables.model_files(model, gen, signals_fmu.VARIABLES)]
            elif model == ME:
                files = [*model_exchange.sources(), *model_exchange.generated(gen)]
                extra = [*model_exchange.EXTRA_CFLAGS, "-DHOST_ME"]
                glue.append(model_exchange._glue(version))
            else:
                files = [*native_fmus.sources(model), *native_fmus.generated(model, gen)]
            incs = sorted({f"-I{Path(f).parent}" for f in files})
            exe = d / "host"
            cmd = ["gcc", "-std=c99", "-g", "-O1", "-Wall", "-Wextra", "-Werror", "-pedantic",
                   "-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer",
                   f"-I{native_build.fmi_headers_dir()}", f"-I{native_build.GLUE_DIR}", *incs,
                   f"-DMODEL_IDENTIFIER={model}", '-DINSTANTIATION_TOKEN="{reliability}"',
                   *(["-DHOST_FMI3"] if version == "3.0" else []), *extra, str(HOST_C),
                   *[str(f) for f in glue if f.suffix == ".c"],
                   *[str(f) for f in files if str(f).endswith(".c")], "-o", str(exe), "-lm"]
            r = subprocess.run(cmd, capture_output=True, text=True)
            assert r.returncode == 0, r.stderr[-4000:]
            built[model, version] = exe
        return built[model, version]
    return get


def run(exe, *args, timeout=600):
    """(stdout, stderr) of a clean run: exit 0 and no sanitizer report; the result line is echoed."""
    r = subprocess.run([str(exe), *map(str, args)], capture_output=True, text=True, timeout=timeout,
                       env=SANITIZER_ENV)
    assert r.returncode == 0 and not REPORT.search(r.stderr), (r.stdout[-2000:], r.stderr[-4000:])
    print(f"{exe.parent.name}: {r.stdout.strip().splitlines()[-1]}")
    return r.stdout, r.stderr


def counts(line):
    return {k: float(v) for k, v in re.findall(r"(\w+)=([-0-9.e]+)", line)}


# --- FMU states: integrity, tracking, double free -----------------------------------------------------

@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("model", (PLANT, CONTROLLER))
def test_every_corrupted_state_is_refused_with_a_message(host, model, version):
    """300 trials each: a random data region behind the intact header, one flipped bit anywhere,
    truncated, bytes appended.  Before the checksum 200 of 300 random data regions were taken."""
    out, _ = run(host(model, version), "corrupt", 300, 23)
    c = counts(out.splitlines()[-1])
    assert c["trials"] == 300
    assert c["random_data_accepted"] == c["bitflip_accepted"] == c["truncated_accepted"] == 0, c
    assert c["wrong_size_accepted"] == 0 and c["unlogged"] == 0, c  # and the intact state still replays


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("model", (PLANT, CONTROLLER))
def test_states_left_to_free_instance_leak_nothing(host, model, version):
    """400 states made by get/deserialize and never freed by the host: freeInstance frees them
    (LeakSanitizer); another instance's, a freed and a made-up state handle are refused."""
    run(host(model, version), "leak")


def test_leak_sanitizer_is_on(host):
    """The control: a block leaked on purpose is reported (so a clean run above means something)."""
    r = subprocess.run([str(host(PLANT, "2.0")), "leakcontrol"], capture_output=True, text=True, timeout=60,
                       env=SANITIZER_ENV)
    assert r.returncode != 0 and "LeakSanitizer" in r.stderr and "4242 byte" in r.stderr, r.stderr[-2000:]


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("model", (PLANT, CONTROLLER))
def test_a_second_free_instance_is_harmless(host, model, version):
    """freeInstance twice on the same pointer (with a state held): no use after free, the other
    instance steps on.  Before: heap-use-after-free in the instance's name."""
    run(host(model, version), "doublefree")


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("model", (PLANT, CONTROLLER))
def test_fmi_misuse_is_refused_and_the_instance_recovers(host, model, version):
    """Bad token, NULL name, calls before initialization or after terminate, a fixed parameter or an
    output set, an unknown value reference, NULL arrays and instances, non-finite start time, step size
    and communication point: errors; a NaN or infinite input: a discard, after which getters and
    setting a saved state work, and the instance steps on."""
    run(host(model, version), "misuse")


# --- random FMI call sequences ---------------------------------------------------------------------------

def fuzz(host, model, version, sequences, seed, tmp_path):
    """The profiles FMU gets a valid profiles file after most instantiations (else it never steps)."""
    extra = []
    if model == SIGNALS:
        (tmp_path / "profiles.txt").write_bytes(PROFILES)
        extra = [f"profiles_file={tmp_path / 'profiles.txt'}"]
    out, _ = run(host(model, version), "fuzz", sequences, seed, *extra, timeout=3600)
    c = counts(out.splitlines()[-1])
    assert c["sequences"] == sequences and c["calls_over_2s"] == 0, c
    assert c["steps_ok"] > 10 * sequences, c  # the sequences reach the stepping, not only the refusals
    return c


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("model", KINDS)
def test_random_call_sequences_under_sanitizers(host, model, version, tmp_path):
    """300 random sequences of 20-200 calls (instantiate with good and bad tokens, free and double free,
    wrong-phase calls, NaN/inf/huge values, unknown value references, NULL arguments, FMU states own,
    foreign, freed and corrupted; for model exchange also event and continuous-time mode, time, states
    and derivatives in any phase, with wrong sizes, NULL arrays and non-finite states): no crash, no
    sanitizer report, no call over 2 s."""
    fuzz(host, model, version, FUZZ_SEQUENCES, 1, tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("model", KINDS)
def test_random_call_sequences_many_under_sanitizers(host, model, version, tmp_path):
    """SATMOTOR_FUZZ_SEQUENCES sequences (default 3000) of another seed."""
    fuzz(host, model, version, FUZZ_MANY, 2, tmp_path)


@pytest.mark.parametrize("version", VERSIONS)
def test_model_exchange_states_corrupted_leaked_and_freed_twice_under_sanitizers(host, version):
    """The model-exchange plant's FMU states as the co-simulation ones': every corrupted blob refused
    with a message, states left to freeInstance freed (LeakSanitizer), a second freeInstance harmless."""
    c = counts(run(host(ME, version), "corrupt", 300, 23)[0].splitlines()[-1])
    assert c["random_data_accepted"] == c["bitflip_accepted"] == c["truncated_accepted"] == 0, c
    assert c["wrong_size_accepted"] == 0 and c["unlogged"] == 0, c
    run(host(ME, version), "leak")
    run(host(ME, version), "doublefree")


# --- the readers of user files ---------------------------------------------------------------------------

TABLE_CSV = (b"i_mu,psi_m\n1.0,0.275\n2.0,0.488\n3.0,0.684\n4.0,0.813\n5.0,0.918\n6.0,0.983\n7.0,1.059\n"
             b"8.0,1.160\n9.1,1.170\n")
PROFILES = (b"satmotor-signals 1\ngrid 0.0001\nsignal omega_ref\nconstant 0\nramp 0.1 0.5 0 100 250\n"
            b"signal psi_ref\nstep 0.01 0.2 0.9\nsine 0.01 50 0 0 0.2\nsignal T_load\ntable 3\n0 0\n0.5 5\n"
            b"1 10\nend\n")


def garbage_files(good: bytes, folder: Path, rng: random.Random, huge_line: bytes, n: int):
    """Random, truncated, huge and malformed variants of ``good`` in ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    blobs = [good]
    blobs += [bytes(rng.randrange(256) for _ in range(rng.randrange(1, 2000))) for _ in range(n)]  # random
    blobs += [good[:k] for k in range(len(good))]  # truncated at every length
    for _ in range(n):  # malformed: bytes replaced, inserted, deleted, lines swapped
        b = bytearray(good)
        for _ in range(rng.randrange(1, 6)):
            k = rng.randrange(len(b))
            op = rng.randrange(3)
            if op == 0:
                b[k] = rng.choice(b"0123456789.,-+eE \t\n#x\x00\xff,;")
            elif op == 1:
                b[k:k] = rng.choice([b"nan", b"inf", b"1e309", b"-", b",", b"\n\n", b"\xef\xbb\xbf",
                                     b"9" * 400])
            else:
                del b[k]
        blobs.append(bytes(b))
    blobs.append(b"\xef\xbb\xbf" + good)  # a BOM
    blobs.append(good.replace(b"\n", b"\r\n"))
    blobs.append(huge_line * 200_000)  # huge: ~2-4 MB of rows
    blobs.append(b"1" * 3_000_000)  # huge: one line
    paths = []
    for k, b in enumerate(blobs):
        p = folder / f"f{k:04d}"
        p.write_bytes(b)
        paths.append(p)
    return paths


@pytest.mark.parametrize("version", VERSIONS)
def test_table_curve_reader_survives_garbage_files(host, tmp_path, version):
    """The plant with curve = table reads each file at initialization: accepted or refused with a
    message, never a sanitizer report; a few steps follow an accepted one."""
    paths = garbage_files(TABLE_CSV, tmp_path, random.Random(23), b"1.5,0.4\n", 150)
    out, _ = run(host(PLANT, version), "file", "table_file", "curve=table", *paths)
    c = counts(out.splitlines()[-1])
    assert c["files"] == len(paths) and c["accepted"] >= 1 and c["refused"] >= len(paths) // 2, c


@pytest.mark.parametrize("version", VERSIONS)
def test_profiles_reader_survives_garbage_files(host, tmp_path, version):
    paths = garbage_files(PROFILES, tmp_path, random.Random(24), b"constant 1\n", 150)
    out, _ = run(host(SIGNALS, version), "file", "profiles_file", "-", *paths)
    c = counts(out.splitlines()[-1])
    assert c["files"] == len(paths) and c["accepted"] >= 1 and c["refused"] >= len(paths) // 2, c


# --- bounded work per doStep; plausibility warnings (the built FMUs) -----------------------------------

FMUS = Path(os.environ.get("SATMOTOR_TEST_FMUS", "build/fmus"))
VARIANTS = {"native-2.0": FMUS / "native" / f"{PLANT}.fmu",
            "native-3.0": FMUS / "native-fmi3" / f"{PLANT}.fmu",
            "pythonfmu": FMUS / f"{PLANT}.fmu"}


class Plant:
    """One plant instance through fmpy, its log kept."""

    def __init__(self, variant, tmp_path, model=PLANT, **params):
        path = VARIANTS[variant].with_name(f"{model}.fmu")
        if not path.exists():
            pytest.skip(f"{path} not built")
        md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.fmi3 = md.fmiVersion.startswith("3")
        self.log = []
        cls = FMU3Slave if self.fmi3 else FMU2Slave
        self.s = cls(guid=md.guid, unzipDirectory=extract(str(path), str(tmp_path / f"{variant}-{id(self)}")),
                     modelIdentifier=md.coSimulation.modelIdentifier, instanceName="p")
        if self.fmi3:
            self.s.instantiate(logMessage=self._log3)
            self.s.enterInitializationMode(startTime=0.0)
        else:
            self.callbacks = fmi2CallbackFunctions()
            self.callbacks.logger = fmi2CallbackLoggerTYPE(self._log2)
            self.callbacks.allocateMemory = defaultCallbacks.allocateMemory
            self.callbacks.freeMemory = defaultCallbacks.freeMemory
            self.s.instantiate(callbacks=self.callbacks, loggingOn=True)  # pythonfmu logs only then
            self.s.setupExperiment(startTime=0.0)
            self.s.enterInitializationMode()
        for k, v in params.items():
            (self._seti if isinstance(v, int) else self.set)(k, v)
        self.s.exitInitializationMode()

    def _log2(self, env, name, status, category, message):
        self.log.append((status, message.decode()))

    def _log3(self, env, status, category, message):
        self.log.append((status, message.decode() if isinstance(message, bytes) else message))

    def set(self, name, value):
        (self.s.setFloat64 if self.fmi3 else self.s.setReal)([self.vr[name]], [value])

    def _seti(self, name, value):
        (self.s.setInt32 if self.fmi3 else self.s.setInteger)([self.vr[name]], [value])

    def get(self, *names):
        return (self.s.getFloat64 if self.fmi3 else self.s.getReal)([self.vr[n] for n in names])

    def step(self, t, h):
        """0, or the failing status (2 discard, 3 error)."""
        try:
            self.s.doStep(t, h)
            return 0
        except FMICallException as exc:
            return exc.status


@pytest.fixture
def plant(tmp_path):
    made = []

    def make(variant, model=PLANT, **params):
        if variant == "pythonfmu":
            pytest.importorskip("pythonfmu")
        p = Plant(variant, tmp_path, model, **params)
        made.append(p)
        return p
    yield make
    for p in made:
        p.s.freeInstance()


@pytest.mark.parametrize("variant", VARIANTS)
def test_a_step_beyond_max_substeps_is_discarded_at_once(plant, variant):
    """doStep(0, 1000 s) (10^7 sub-steps of h_int = 1e-4 s: 37 s before) is a discard, quickly, naming
    the step size, the sub-steps and the limit; a step of exactly max_substeps sub-steps is taken."""
    p = plant(variant)
    p.set("v_s_alpha", 100.0)
    t0 = time.perf_counter()
    assert p.step(0.0, 1000.0) == 2
    assert time.perf_counter() - t0 < 0.5
    msg = [m for st, m in p.log if st == 2][-1]
    assert "communicationStepSize = 1000.0" in msg and "needs 10000000 RK4 sub-steps" in msg, msg
    assert f"max_substeps = {MAX_SUBSTEPS}" in msg, msg
    q = plant(variant, max_substeps=40)
    assert q.step(0.0, 40 * 1e-4) == 0  # exactly at the limit
    assert q.step(40e-4, 41 * 1e-4) == 2
    assert "needs 41 RK4 sub-steps" in [m for st, m in q.log if st == 2][-1]


@pytest.mark.parametrize("variant", VARIANTS)
def test_a_controller_step_beyond_max_samples_is_discarded_at_once(plant, variant):
    """The controller's doStep(0, 1000 s) (10^7 samples of Ts = 1e-4 s: 89 s on the pythonfmu
    controller, 1.3 s on the native one before) is a discard, at once, naming the step size, the
    samples and the limit; a step of exactly max_samples samples is taken, one more is not."""
    c = plant(variant, CONTROLLER)
    t0 = time.perf_counter()
    assert c.step(0.0, 1000.0) == 2
    assert time.perf_counter() - t0 < 0.5
    msg = [m for st, m in c.log if st == 2][-1]
    assert "communicationStepSize = 1000.0" in msg and "needs 10000000 samples of Ts = 0.0001 s" in msg, msg
    assert f"more than max_samples = {MAX_STEP_SAMPLES}" in msg, msg
    q = plant(variant, CONTROLLER, max_samples=40)
    assert q.step(0.0, 40 * 1e-4) == 0  # exactly at the limit
    assert q.step(40e-4, 41 * 1e-4) == 2
    assert "needs 41 samples" in [m for st, m in q.log if st == 2][-1]


@pytest.mark.parametrize("variant", ("native-2.0", "native-3.0"))
@pytest.mark.parametrize("model, name", [(PLANT, "max_substeps"), (CONTROLLER, "max_samples")])
def test_a_work_bound_below_one_is_refused_at_initialization(plant, variant, model, name):
    with pytest.raises(FMICallException):
        plant(variant, model, **{name: 0})


def test_plant_unit_checks_max_substeps_as_the_native_plant():
    u = PlantUnit({"max_substeps": 3})
    u.step(0.0, 3e-4, (1.0, 0.0, 0.0))
    with pytest.raises(ValueError, match=r"communicationStepSize = 0.00031: needs 4 RK4 sub-steps of "
                                         r"h_int = 0.0001 s, more than max_substeps = 3"):
        u.step(3e-4, 3.1e-4, (1.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="max_substeps = 0"):
        PlantUnit({"max_substeps": 0})


def warnings_of(log):
    return [m for st, m in log if st == 1]


@pytest.mark.parametrize("variant", ("native-2.0", "native-3.0", "pythonfmu"))
def test_implausible_inputs_warn_once_and_change_nothing(plant, variant):
    """A 5000 V rotating voltage (2.3 x the bound 4 V_dc) on a rotor started at 2000 rad/s: one warning
    each for the voltage, the speed and the current over 300 steps; the outputs bit for bit those of a
    run with the checks off (0).  The texts and the values they quote are PlantUnit's."""
    names = ("i_s_alpha", "i_s_beta", "psi_r_alpha", "omega_m", "T_e")
    runs = []
    for params in ({}, {"v_warn": 0.0, "i_warn": 0.0, "omega_warn": 0.0}):
        p = plant(variant, omega_m0=2000.0, **params)
        rows = []
        for k in range(300):
            w = 314.159 * k * 1e-4
            p.set("v_s_alpha", 5000.0 * math.cos(w))
            p.set("v_s_beta", 5000.0 * math.sin(w))
            assert p.step(k * 1e-4, 1e-4) == 0
            rows.append(p.get(*names))
        runs.append((rows, warnings_of(p.log)))
    (on, warned), (off, silent) = runs
    assert on == off  # bit-identical (floats compared exactly)
    assert silent == []
    assert len(warned) == 3, warned
    assert "implausible input at t = 0.0 s: |v_s| = 5000.0 V exceeds v_warn = 2160.0 V" in warned[0]
    assert "|omega_m|" in warned[1] and "omega_warn = 1500.0 rad/s" in warned[1]
    assert "|i_s|" in warned[2] and "i_warn = 300.0 A" in warned[2]
    u = PlantUnit({"omega_m0": 2000.0})  # the Python unit: the same texts, the same values
    for k in range(300):
        w = 314.159 * k * 1e-4
        u.step(k * 1e-4, 1e-4, (5000.0 * math.cos(w), 5000.0 * math.sin(w), 0.0))
    assert u.warnings == warned


def test_a_plausible_run_warns_nothing():
    u = PlantUnit({})
    for k in range(2000):
        w = 314.159 * k * 1e-4
        u.step(k * 1e-4, 1e-4, (300.0 * math.cos(w), 300.0 * math.sin(w), 0.0))
    assert u.warnings == []

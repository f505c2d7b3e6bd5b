"""The controller's communication step rule (ControllerUnit.samples, sm_controller_samples), both FMU
variants alike: a step of n Ts (to a few ulps of the times involved) runs n samples with the inputs held;
a remainder of at most 1e-6 Ts that ends at the host's stop time (or anywhere, when the host declared
none) runs none; any other step is refused
with a message naming Ts and the step.

Expected values come from a second formulation: n steps of Ts each (the controller does not read t, so
a step of n Ts with inputs held must give the same outputs bit for bit), and the rule written out in
exact rational arithmetic here (fractions.Fraction) for the boundary cases."""

import ctypes
import math
import sys
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.fmi1 import FMICallException

sys.path.insert(0, str(Path(__file__).resolve().parent))
from native_core import ControllerParams, MotorParams, build, declare, params  # noqa: E402

from satmotor.errors import ParameterError  # noqa: E402
from satmotor.interface import CONTROLLER_OUTPUTS, STEP_ULPS, ControllerUnit  # noqa: E402

TS = 1e-4
# constant inputs of a magnetized, turning machine (those of tests/test_native_windows.py)
INPUTS = {"psi_r_alpha": 0.9, "i_s_alpha": 5.0, "psi_ref": 0.95, "omega_ref": 50.0}
OUT = [v.name for v in CONTROLLER_OUTPUTS if v.type == "Real"]
VARIANTS = {"python": "BacksteppingController.fmu", "native": "native/BacksteppingController.fmu",
            "native-fmi3": "native-fmi3/BacksteppingController.fmu"}
EPS = sys.float_info.epsilon


def _inputs():
    values = [0.0] * len(ControllerUnit.INPUTS)
    for name, v in INPUTS.items():
        values[ControllerUnit.INPUTS.index(name)] = v
    return tuple(values)


# --- the rule ----------------------------------------------------------------------------------------

def _exact_samples(Ts, t, dt, stop=math.inf):
    """The rule in exact arithmetic (the floating-point tolerance makes it fuzzy only within 8 ulps)."""
    q = Fraction(dt) / Fraction(Ts)
    n = math.floor(q + Fraction(1, 2))
    tol = Fraction(STEP_ULPS) * Fraction(EPS) * max(n * Fraction(Ts), abs(Fraction(t)), abs(Fraction(t + dt)))
    if n >= 1 and abs(Fraction(dt) - n * Fraction(Ts)) <= tol:
        return n
    if n == 0 and Fraction(dt) <= Fraction(1, 10**6) * Fraction(Ts) and (
            stop == math.inf or abs(Fraction(t + dt) - Fraction(stop)) <= tol):
        return 0
    return -1


def _ulps(x, k):
    for _ in range(abs(k)):
        x = math.nextafter(x, math.inf if k > 0 else -math.inf)
    return x


CASES = [  # (t, dt, stop time, samples)
    (0.0, TS, math.inf, 1), (0.0, 2 * TS, math.inf, 2), (0.3, 7 * TS, math.inf, 7),
    (0.0, _ulps(TS, 4), math.inf, 1), (0.0, _ulps(TS, -4), math.inf, 1),  # a few ulps off: one sample
    (0.0, 1.5 * TS, math.inf, -1), (0.0, 0.5 * TS, math.inf, -1), (0.0, 0.999 * TS, math.inf, -1),
    (0.0, 1.001 * TS, math.inf, -1), (0.0, 2.0001 * TS, math.inf, -1),
    (0.7, 0.7999 - 0.7, math.inf, 999),  # fmpy's step: the difference of two grid times
    (10.0, (10.0 + TS) - 10.0, math.inf, 1),  # 1.2e-12 off Ts: the ulps of t = 10 s
    (1.0 - 1.49e-13, 1.49e-13, 1.0, 0),  # OMSimulator's clipped final step, ending at its stop time
    (1.0 - 1.49e-13, 1.49e-13, math.inf, 0),  # the same without a stop time (OMSimulator declares none)
    (0.5, 2e-6 * TS, math.inf, -1),  # more than 1e-6 Ts: refused, stop time or not
    (0.5, 1.49e-13, 1.0, -1),  # a remainder that does not end at the stop time: refused
    (1.0 - 0.4 * TS, 0.4 * TS, 1.0, -1),  # a real fraction of a sample before the stop time: refused
]


@pytest.mark.parametrize("t, dt, stop, n", CASES)
def test_the_rule_in_python_as_written_out_exactly(t, dt, stop, n):
    u = ControllerUnit({})
    u.stop_time = stop
    assert _exact_samples(TS, t, dt, stop) == n
    assert u.samples(t, dt) == n


@pytest.fixture(scope="module")
def lib():
    return declare(ctypes.CDLL(str(build(()))))  # the signatures read from the headers


def _c_unit(lib, values, stop=math.inf):
    buf = ctypes.create_string_buffer(lib.sm_controller_size())
    msg = ctypes.create_string_buffer(256)
    status = lib.sm_controller_init(buf, params(lib, ControllerParams, values),
                                    params(lib, MotorParams, values), msg, 256)
    assert status == 0, msg.value
    # stop_time follows Ts in sm_controller: the double before the outputs array at the struct's end
    n_out = len(CONTROLLER_OUTPUTS)
    ctypes.c_double.from_buffer(buf, lib.sm_controller_size() - 8 * n_out - 8).value = stop
    return buf


def _c_out(lib, buf):
    n = len(CONTROLLER_OUTPUTS)
    return list((ctypes.c_double * n).from_buffer(buf, lib.sm_controller_size() - 8 * n))


def test_c_and_python_count_the_same_samples_for_every_step(lib):
    """The boundary cases and 20 000 random steps near whole multiples (within +-40 ulps) and near the
    stop time, for several Ts and times."""
    rng = np.random.default_rng(21)
    checked = 0
    for Ts in (1e-4, 5e-5, 4e-5, 1e-3, 3.3e-4):
        py = ControllerUnit({"Ts": Ts})
        stop = 1.0
        py.stop_time = stop
        c = _c_unit(lib, {"Ts": Ts}, stop)
        cases = [(t, dt) for t, dt, s, _ in CASES if s in (math.inf, stop)]
        for _ in range(4000):
            n = int(rng.integers(0, 12))
            t = float(rng.choice([0.0, float(rng.uniform(0, 20)), stop - n * Ts]))
            dt = _ulps(n * Ts if n else stop - t, int(rng.integers(-40, 41)))
            cases.append((t, dt))
        for t, dt in cases:
            assert lib.sm_controller_samples(c, t, dt) == py.samples(t, dt), (Ts, t, dt)
            checked += 1
    assert checked > 20000


def test_a_step_of_n_ts_is_n_steps_of_ts_bit_for_bit_in_python_and_c(lib):
    inputs = _inputs()
    arr = (ctypes.c_double * len(inputs))(*inputs)
    msg = ctypes.create_string_buffer(256)
    ref, one = ControllerUnit({}), ControllerUnit({})
    c = _c_unit(lib, {})
    t = 0.0
    for n in (1, 2, 3, 5, 2, 1, 7):
        for k in range(n):
            ref.step(t + k * TS, TS, inputs)
        one.step(t, n * TS, inputs)
        assert lib.sm_controller_step(c, t, n * TS, arr, msg, 256) == 0, msg.value
        t += n * TS
        assert list(one.outputs()) == list(ref.outputs())
        assert _c_out(lib, c) == [float(x) for x in ref.outputs()]
    assert ref.outputs()[0] != 0.0  # the voltages moved


def test_a_refused_step_names_ts_and_the_step_and_changes_nothing(lib):
    u = ControllerUnit({})
    u.step(0.0, TS, _inputs())
    before = u.get_state()
    with pytest.raises(ParameterError) as exc:
        u.step(TS, 1.5 * TS, _inputs())
    text = "communicationStepSize = 0.00015000000000000001: must be a whole multiple of the sample period " \
           "Ts = 0.0001 s"
    assert str(exc.value) == text
    assert u.get_state() == before
    c = _c_unit(lib, {})
    arr = (ctypes.c_double * len(_inputs()))(*_inputs())
    msg = ctypes.create_string_buffer(256)
    assert lib.sm_controller_step(c, 0.0, TS, arr, msg, 256) == 0
    raw = bytes(c)
    assert lib.sm_controller_step(c, TS, 1.5 * TS, arr, msg, 256) != 0
    assert msg.value.decode() == text
    assert bytes(c) == raw


@pytest.mark.parametrize("dt, n", [(41 * TS, 41), (41.3 * TS, 41), (1000.0, 10_000_000), (1e300, 1e300 / TS)])
def test_a_step_beyond_max_samples_is_refused_naming_the_bound_in_python_and_c(lib, dt, n):
    """max_samples = 40: a step of 41 Ts, or of any length above 40.5 Ts (a whole multiple or not),
    is refused before any sample, naming the samples it needs and the bound; the same text in C.  A
    step of 40 Ts is taken."""
    values = {"max_samples": 40}
    u, c = ControllerUnit(values), _c_unit(lib, values)
    arr = (ctypes.c_double * len(_inputs()))(*_inputs())
    msg = ctypes.create_string_buffer(256)
    u.step(0.0, 40 * TS, _inputs())
    assert lib.sm_controller_step(c, 0.0, 40 * TS, arr, msg, 256) == 0, msg.value
    before, raw = u.get_state(), bytes(c)
    with pytest.raises(ParameterError) as exc:
        u.step(40 * TS, dt, _inputs())
    text = (f"communicationStepSize = {dt!r}: needs {float(n):.17g} samples of Ts = 0.0001 s, more than "
            "max_samples = 40: take shorter communication steps or raise max_samples")
    assert str(exc.value) == text
    assert u.get_state() == before
    assert lib.sm_controller_step(c, 40 * TS, dt, arr, msg, 256) != 0
    assert msg.value.decode() == text
    assert bytes(c) == raw


@pytest.mark.parametrize("value", [0, -3])
def test_max_samples_below_one_is_refused_in_python_and_c(lib, value):
    with pytest.raises(ParameterError) as exc:
        ControllerUnit({"max_samples": value})
    text = f"max_samples = {value}: must be an integer >= 1"
    assert str(exc.value) == text
    buf = ctypes.create_string_buffer(lib.sm_controller_size())
    msg = ctypes.create_string_buffer(256)
    assert lib.sm_controller_init(buf, params(lib, ControllerParams, {"max_samples": value}),
                                  params(lib, MotorParams, {}), msg, 256) != 0
    assert msg.value.decode() == text


def test_a_failing_sample_in_a_long_step_leaves_the_controller_as_before():
    """The drive fails on the second sample of a step of 3 Ts (made to): the state before the step
    stays, as for a refused single sample."""
    u = ControllerUnit({})
    u.step(0.0, TS, _inputs())
    before, out = u.get_state(), u.outputs()
    real, calls = u.drive.step, []

    def failing(*args):
        calls.append(1)
        if len(calls) == 2:
            raise ParameterError("psi_ref", 5.0, "made to fail")
        return real(*args)

    u.drive.step = failing
    with pytest.raises(ParameterError):
        u.step(TS, 3 * TS, _inputs())
    assert len(calls) == 2 and u.get_state() == before and u.outputs() == out


# --- through fmpy: every variant -----------------------------------------------------------------------

def _simulate(path, step, Ts=TS, stop=0.01):
    return simulate_fmu(str(path), start_time=0.0, stop_time=stop, output_interval=step,
                        start_values={**INPUTS, "Ts": Ts}, output=OUT)


@pytest.mark.parametrize("variant", sorted(VARIANTS))
@pytest.mark.parametrize("Ts, n", [(TS, 2), (4e-5, 5)])  # 2e-4 s: the FMU Compliance Checker's default step
def test_simulate_fmu_with_a_step_of_n_ts_equals_the_run_at_ts(fmu_dir, variant, Ts, n):
    """fmpy's simulate_fmu with a communication step of n Ts (fmpy passes the difference of two grid
    times: off n Ts by ulps) against the same run at Ts, every n-th row: bit-identical (the inputs are
    start values, held, so the master holds them over the step as the run at Ts does)."""
    path = fmu_dir / VARIANTS[variant]
    fine = _simulate(path, Ts, Ts)
    coarse = _simulate(path, n * Ts, Ts)
    assert len(coarse) == 51 and len(fine) == 50 * n + 1
    for name in OUT:
        assert np.array_equal(coarse[name], fine[name][::n]), name
    assert np.ptp(coarse["v_s_alpha"]) > 1.0  # the output moved over the run


class _Host:
    """A low-level fmpy instance of either FMI version, with its log."""

    def __init__(self, path, stop=None):
        from fmpy import extract, instantiate_fmu, read_model_description
        self.log = []
        md = read_model_description(str(path))
        self.major = int(md.fmiVersion[0])
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        logger = (lambda env, status, cat, msg: self.log.append(msg.decode())) if self.major == 3 else \
            (lambda comp, env, status, cat, msg: self.log.append(msg.decode()))
        self.fmu = instantiate_fmu(extract(str(path)), md, logger=logger, debug_logging=True)
        if self.major == 3:
            self.fmu.enterInitializationMode(startTime=0.0, stopTime=stop)
        else:
            self.fmu.setupExperiment(startTime=0.0, stopTime=stop)
            self.fmu.enterInitializationMode()
        names = list(INPUTS)
        (self.fmu.setFloat64 if self.major == 3 else self.fmu.setReal)([self.vr[n] for n in names],
                                                                        [INPUTS[n] for n in names])
        self.fmu.exitInitializationMode()

    def out(self):
        return (self.fmu.getFloat64 if self.major == 3 else self.fmu.getReal)([self.vr[n] for n in OUT])


@pytest.mark.parametrize("variant", sorted(VARIANTS))
def test_a_host_with_accumulated_time_and_a_clipped_last_step(fmu_dir, variant):
    """OMSimulator's way: t += h, then a last step of t_stop - t (9.4e-14 s after 10 000 steps of 1e-4;
    OMSimulator's was 1.49e-13 s):
    zero samples, status OK, the outputs of the exact-grid run, with the stop time given or not (OMSimulator
    declares none); a remainder of 2e-6 Ts is refused."""
    path = fmu_dir / VARIANTS[variant]
    stop, steps = 1.0, 10000
    exact = _Host(path, stop)
    for k in range(steps):
        exact.fmu.doStep(k * TS, TS)
    drifting = _Host(path, stop)
    t = 0.0
    for _ in range(steps):
        drifting.fmu.doStep(t, TS)
        t += TS
    assert 0 < stop - t < 1e-6 * TS  # the accumulated time falls short of the stop time
    free = _Host(path, None)  # no stop time given
    t = 0.0
    for _ in range(steps):
        free.fmu.doStep(t, TS)
        t += TS
    # the state of the instance without a stop time, set into the one with: its own stop time holds
    blob = free.fmu.serializeFMUState(free.fmu.getFMUState())
    fmu = drifting.fmu
    deserialize = fmu.deserializeFMUState if drifting.major == 3 else fmu.deSerializeFMUstate
    drifting.fmu.setFMUState(deserialize(blob))
    drifting.fmu.doStep(t, stop - t)  # OK: fmpy raises for a discard
    assert drifting.out() == exact.out()
    before = free.out()
    free.fmu.doStep(t, stop - t)  # OK: zero samples
    assert free.out() == before == exact.out()
    with pytest.raises(FMICallException):  # (the native FMUs' refusal is an error: the last call here)
        free.fmu.doStep(stop, 2e-6 * TS)
    assert "must be a whole multiple of the sample period Ts = 0.0001 s" in "\n".join(free.log)
    for h in (exact, drifting, free):
        h.fmu.freeInstance()


def test_the_fmi3_controller_declares_its_sample_period(fmu_dir):
    """FMI 3.0: CoSimulation/@fixedInternalStepSize is the start value of Ts (docs/fmus.md); fmpy takes it
    as the communication step when none is given."""
    from fmpy import read_model_description
    md = read_model_description(str(fmu_dir / VARIANTS["native-fmi3"]))
    ts = next(v for v in md.modelVariables if v.name == "Ts")
    assert float(md.coSimulation.fixedInternalStepSize) == float(ts.start) == TS
    res = simulate_fmu(str(fmu_dir / VARIANTS["native-fmi3"]), stop_time=0.01, start_values=INPUTS)
    assert np.allclose(np.diff(res["time"]), TS, rtol=1e-9, atol=0)

"""The fmpy master's stepping loop (``orchestration.run.master._loop``) handed to the compiled engine.

:func:`loop` takes what the master's loop takes (the instantiated, initialized units, their ports,
the wiring, the profiles, the recorder, the stop request, the measurement noise), fills the engine's
:class:`Config` and :class:`State` (layout of ``se_config`` / ``se_state`` in ``sm_engine.c``) once,
and calls ``se_advance`` until the run ends.  Between two calls Python hands each full chunk of
rows to the recorder (``Recorder.append_rows``: its observer computes the metrics, the same code as
the fmpy master's, on chunks of the same rows), draws the next block of measurement noise with
numpy (:meth:`MeasurementNoise.draw`, the master's own draws) and looks at the stop request.  A
failed FMI call is raised as the fmpy master raises it (``FMUInstance.step_failed`` for a doStep,
``check`` for a get or set), so the run result says the same.

What the engine cannot run raises :class:`Unsupported` naming the feature (the scenario file is
refused before it runs by :func:`orchestration.run.c_engine.problems`).
"""

from __future__ import annotations

import functools
from ctypes import CDLL, POINTER, Structure, byref, c_char, c_char_p, c_double, c_int32, c_int64, c_void_p

import numpy as np

from orchestration.run.c_engine.build import library_path
from orchestration.run.fmu_instance import check
from orchestration.run.step_plans import input_port
from orchestration.run.wiring import resolve
from orchestration.scenario.profiles import Constant, Csv, Ramp, Sine, Step, Sum, Table
from orchestration.scenario.recording import record_steps
from orchestration.scenario.system import CONTROLLER, PLANT, PROFILE

__all__ = ["Unsupported", "loop", "profile_table"]

ABI = 1  # SE_ABI of sm_engine.c
DONE, ROWS_FULL, NOISE_EMPTY, FAILED = 0, 1, 2, -1
CALLS = ("get_real", "set_real", "get_int", "get_bool", "step")  # the order of se_unit.fn (F_*)
SOURCE_KIND = {PLANT: 0, CONTROLLER: 1, PROFILE: 2}
TERM_NUMBERS = 5  # numbers per profile term (sm_engine.c)


class Unsupported(ValueError):
    """Something the compiled engine does not run (the message names it)."""


class Unit(Structure):
    _fields_ = [("instance", c_void_p), ("fmi3", c_int32), ("name", c_char_p), ("fn", c_void_p * 5),
                ("fn_name", c_char_p * 5)]


class Inputs(Structure):
    _fields_ = [("n", c_int32), ("vr", c_void_p), ("src_kind", c_void_p), ("src_index", c_void_p)]


class Config(Structure):
    _fields_ = [("plant", Unit), ("ctrl", Unit), ("n_steps", c_int64), ("every", c_int64),
                ("ctrl_every", c_int64), ("t0", c_double), ("h", c_double), ("Ts", c_double),
                ("jacobi", c_int32), ("n_po", c_int32), ("n_co", c_int32), ("n_ci", c_int32),
                ("n_cb", c_int32),
                ("vr_po", c_void_p), ("vr_co", c_void_p), ("vr_ci", c_void_p), ("vr_cb", c_void_p),
                ("p_in", Inputs), ("c_in", Inputs), ("n_prof", c_int32), ("prof_first", c_void_p),
                ("prof_n", c_void_p), ("prof_sum", c_void_p), ("term_kind", c_void_p),
                ("term_first", c_void_p),
                ("term_points", c_void_p), ("term_a", c_void_p), ("pt_t", c_void_p), ("pt_v", c_void_p),
                ("n_meas", c_int32), ("n_noisy", c_int32), ("meas_index", c_void_p), ("meas_col", c_void_p),
                ("meas_q", c_void_p), ("n_cols", c_int32)]


class State(Structure):
    _fields_ = [("k", c_int64), ("started", c_int32), ("pvals", c_void_p), ("cvals", c_void_p),
                ("held", c_void_p), ("ivals", c_void_p), ("bvals", c_void_p), ("p_invals", c_void_p),
                ("c_invals", c_void_p), ("fv", c_void_p), ("mvals", c_void_p), ("mrow", c_void_p),
                ("noise", c_void_p), ("noise_rows", c_int64), ("noise_next", c_int64),
                ("failed_unit", c_int32), ("failed_status", c_int32), ("failed_function", c_int32),
                ("failed_time", c_double), ("message", c_char * 256)]


@functools.cache
def library():
    """The engine's library, loaded once per process (it keeps no state: every run passes its own)."""
    lib = CDLL(str(library_path()))
    lib.se_abi.restype = c_int32
    if lib.se_abi() != ABI:
        raise RuntimeError(f"{library_path()}: engine ABI {lib.se_abi()}, this Python side speaks {ABI}")
    lib.se_advance.restype = c_int32
    lib.se_advance.argtypes = (POINTER(Config), POINTER(State), c_void_p, c_int64, POINTER(c_int64))
    return lib


class _Arrays:
    """The numpy arrays the structures point into (kept alive for the run)."""

    def __init__(self):
        self.kept = []

    def __call__(self, values, dtype):
        a = np.ascontiguousarray(np.asarray(values, dtype=dtype))
        if a.size == 0:
            a = np.zeros(1, dtype=dtype)  # a valid pointer even for an empty list
        self.kept.append(a)
        return a.ctypes.data


def profile_table(funcs, names):
    """The engine's profile table of the value functions ``funcs`` (bound ``value`` methods of
    :mod:`orchestration.scenario.profiles` objects; ``names`` for the messages):
    ``(first, count, is_sum, kind, first_point, n_points, numbers, point_times, point_values)``."""
    first, count, is_sum, kinds, tfirst, tn, nums, pts_t, pts_v = [], [], [], [], [], [], [], [], []
    for name, f in zip(names, funcs):
        obj = getattr(f, "__self__", None)
        parts = obj.parts if isinstance(obj, Sum) else (obj,)
        first.append(len(kinds))
        count.append(len(parts))
        is_sum.append(int(isinstance(obj, Sum)))
        for p in parts:
            t_first, n_pts = 0, 0
            if isinstance(p, Constant):
                kind, a = 1, [p.level]
            elif isinstance(p, Step):
                kind, a = 2, [p.time, p.level, p.initial]
            elif isinstance(p, Ramp):
                kind, a = 3, [p.start, p.from_, p._slope, p._lo, p._hi]
            elif isinstance(p, (Table, Csv)):
                kind, a, t_first, n_pts = 4, [], len(pts_t), len(p.times)
                pts_t += p.times
                pts_v += p.values
            elif isinstance(p, Sine):
                kind, a = 5, [p.start, p.offset, p.amplitude, p._w, p.phase]
            else:
                what = type(p).__name__ if p is not None else repr(f)
                raise Unsupported(f"profile {name}: {what} is not a "
                                  "profile kind the c engine evaluates (constant, step, ramp, table, csv, "
                                  "sine and their sums)")
            kinds.append(kind)
            tfirst.append(t_first)
            tn.append(n_pts)
            nums += [float(x) for x in a] + [0.0] * (TERM_NUMBERS - len(a))
    return first, count, is_sum, kinds, tfirst, tn, nums, pts_t, pts_v


def _unit(inst, name):
    from ctypes import cast

    fns = [inst.calls[c] for c in CALLS]
    u = Unit(inst.handle.value, int(inst.fmi3), name.encode())
    for i, fn in enumerate(fns):
        u.fn[i] = cast(inst.slave.dll[fn], c_void_p).value
        u.fn_name[i] = fn.encode()
    return u


def _inputs(arr, inst, unit, connections, outputs, profiles, prof):
    port, _ = input_port(inst, unit, connections, outputs, profiles, prof)  # the master's order
    srcs = resolve(connections, unit, list(port.names), outputs, profiles)
    kinds = [SOURCE_KIND[s.unit] for s in srcs]
    index = [s.ref if s.unit != PROFILE else next(i for i, f in enumerate(prof) if f is s.ref) for s in srcs]
    return Inputs(len(srcs), arr(inst.vr(port.names), np.uint32), arr(kinds, np.int32), arr(index, np.int32))


def loop(sc, jacobi, plant, ctrl, p_out, c_out, c_disc, connections, profiles, rec, stop, measure=None):
    """:func:`orchestration.run.master._loop` on the compiled engine: (the last communication point
    reached [s], whether the run reached its stop time)."""
    for inst in (plant, ctrl):
        tool = inst.md.generationTool or ""
        if "pythonfmu" in tool.lower():
            raise Unsupported(f"{inst.name} FMU {inst.path}: a pythonfmu FMU ({tool}); the c engine runs the "
                              "native FMUs (--variant native or native-fmi3), the pythonfmu ones run with "
                              "--engine fmpy")
    lib = library()
    arr = _Arrays()
    cfg = _config(arr, sc, jacobi, plant, ctrl, p_out, c_out, c_disc, connections, profiles, measure)
    st = _state(arr, cfg, ctrl.fmi3)
    n, h = cfg.n_steps, cfg.h
    chunk = max(1, int(rec.chunk_rows))
    rows = np.empty((chunk, cfg.n_cols))
    got = c_int64(0)
    noise, filled, width = None, 0, 8 * cfg.n_cols
    while True:  # whole chunks to the recorder, as the fmpy master flushes them (the metrics fold per chunk)
        code = lib.se_advance(byref(cfg), byref(st), rows.ctypes.data + filled * width, chunk - filled,
                              byref(got))
        filled += got.value
        if filled and (filled == chunk or code in (DONE, FAILED)):
            rec.append_rows(rows[:filled])
            filled = 0
        if code == DONE:
            return 0.0 + n * h, True
        if code == FAILED:
            _raise(st, (plant, ctrl))
        if code == NOISE_EMPTY:
            noise = measure.draw()  # kept referenced until the next block
            st.noise, st.noise_rows, st.noise_next = noise.ctypes.data, len(noise), 0
        if stop.signum:
            if filled:
                rec.append_rows(rows[:filled])
            return 0.0 + st.k * h, False


def _config(arr, sc, jacobi, plant, ctrl, p_out, c_out, c_disc, connections, profiles, measure):
    """The run's :class:`Config` (its arrays kept by ``arr``)."""
    n, every = record_steps(sc)
    names = sorted(profiles)
    prof = [profiles[p] for p in names]
    outputs = {PLANT: p_out.names, CONTROLLER: c_out.names}
    n_int, n_bool = len(c_disc.int_values), len(c_disc.bool_values)
    cfg = Config(plant=_unit(plant, PLANT), ctrl=_unit(ctrl, CONTROLLER), n_steps=n, every=every,
                 ctrl_every=sc.controller_every, t0=0.0, h=sc.step, Ts=sc.Ts, jacobi=int(jacobi),
                 n_po=p_out.n, n_co=c_out.n, n_ci=n_int, n_cb=n_bool)
    cfg.vr_po = arr(plant.vr(p_out.names), np.uint32)
    cfg.vr_co = arr(ctrl.vr(c_out.names), np.uint32)
    cfg.vr_ci = arr(ctrl.vr(c_disc.names[:n_int]), np.uint32)
    cfg.vr_cb = arr(ctrl.vr(c_disc.names[n_int:]), np.uint32)
    cfg.p_in = _inputs(arr, plant, PLANT, connections, outputs, profiles, prof)
    cfg.c_in = _inputs(arr, ctrl, CONTROLLER, connections, outputs, profiles, prof)
    first, count, is_sum, kinds, tfirst, tn, nums, pts_t, pts_v = profile_table(prof, names)
    cfg.n_prof = len(prof)
    cfg.prof_first, cfg.prof_n, cfg.prof_sum = (arr(x, np.int32) for x in (first, count, is_sum))
    cfg.term_kind, cfg.term_first, cfg.term_points = (arr(x, np.int32) for x in (kinds, tfirst, tn))
    cfg.term_a, cfg.pt_t, cfg.pt_v = (arr(x, np.float64) for x in (nums, pts_t, pts_v))
    if measure is not None:
        ops = measure.ops
        cfg.n_meas, cfg.n_noisy = len(ops), measure.n_noisy
        cfg.meas_index = arr([i for i, _, _ in ops], np.int32)
        cfg.meas_col = arr([j for _, j, _ in ops], np.int32)
        cfg.meas_q = arr([q for _, _, q in ops], np.float64)
    cfg.n_cols = 1 + p_out.n + c_out.n + n_int + n_bool + len(prof) + cfg.n_meas
    return cfg


def _state(arr, cfg, fmi3):
    """A :class:`State` at the start of the run: its buffers (kept by ``arr``), sized by ``cfg``."""
    st = State()
    sizes = (("pvals", cfg.n_po), ("cvals", cfg.n_co), ("held", cfg.n_co), ("p_invals", cfg.p_in.n),
             ("c_invals", cfg.c_in.n), ("fv", cfg.n_prof), ("mvals", cfg.n_po), ("mrow", cfg.n_meas))
    for field, size in sizes:
        setattr(st, field, arr(np.zeros(size), np.float64))
    st.ivals = arr(np.zeros(cfg.n_ci), np.int32)
    st.bvals = arr(np.zeros(cfg.n_cb), np.uint8 if fmi3 else np.int32)  # fmi3Boolean: bool, fmi2Boolean: int
    return st


def _raise(st, units):
    """Raise the FMICallException of the failed call, as the fmpy master does."""
    inst = units[st.failed_unit]
    call = CALLS[st.failed_function]
    if call == "step":
        inst.step_failed(st.failed_status, st.failed_time)
    check(inst.calls[call], st.failed_status)
    raise RuntimeError(st.message.decode())  # pragma: no cover - check raised

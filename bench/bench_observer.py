"""Per-step cost of the controller unit by flux and speed source: the open-loop current model (the
observer before), the closed-loop observer (the default observer now) and the sensorless drive,
against the measured flux; the Python unit (``satmotor.interface.ControllerUnit.step``, what the
pythonfmu FMU runs) and the C unit (``sm_controller_step`` of the native core through ctypes, what the
native FMUs run, plus one ctypes call's overhead).

The inputs are those of a plain-Python closed loop (``PlantUnit`` + ``ControllerUnit``) of the default
scenario (ramp to 100 rad/s, rated load from 1 s; 1.5 s, Ts = 100 us) with each configuration,
recorded and replayed into a fresh unit; the best of ``--repeats`` replays is kept.  CPU time of the
process (``time.process_time``): on a shared machine the wall time also holds the waits for a core.

Run ``python -m bench observer`` (needs gcc for the C core, as the tests do); prints a Markdown
table (us per step).
"""

from __future__ import annotations

import argparse
import ctypes
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from native_core import ControllerParams, MotorParams, build, params  # noqa: E402

from bench.common import measured, write_section  # noqa: E402
from satmotor.interface import ControllerUnit, PlantUnit  # noqa: E402

TS = 1e-4
CONFIGS = {
    "measured flux (the seed)": {},
    "observer: current_model (before)": {"flux_source": "observer", "observer": "current_model"},
    "observer: closed_loop (now the default observer)": {"flux_source": "observer"},
    "closed_loop, speed_source: estimated": {"flux_source": "observer", "speed_source": "estimated"},
}


def record(values, t_end=1.5):
    plant, ctrl = PlantUnit({}), ControllerUnit(values)
    rows = []
    for k in range(round(t_end / TS)):
        t = k * TS
        o = plant.outputs()
        w = 100.0 * min(max((t - 0.2) / 0.5, 0.0), 1.0)
        load = 26.71 if t >= 1.0 else 0.0
        inputs = (o[0], o[1], o[4], o[5], o[2], o[3], o[6], w, 0.95, load, 0.0)
        ctrl.step(t, TS, inputs)
        rows.append((t, inputs))
        out = ctrl.outputs()
        plant.step(t, TS, (out[0], out[1], load))
    return rows


def time_python(values, rows, repeats):
    best = float("inf")
    for _ in range(repeats):
        u = ControllerUnit(values)
        t0 = time.process_time()
        for t, inputs in rows:
            u.step(t, TS, inputs)
        best = min(best, time.process_time() - t0)
    return best / len(rows)


def time_c(lib, values, rows, repeats):
    arrays = [(t, (ctypes.c_double * 11)(*inputs)) for t, inputs in rows]
    msg = ctypes.create_string_buffer(256)
    best = float("inf")
    for _ in range(repeats):
        buf = ctypes.create_string_buffer(lib.sm_controller_size())
        c_params, m_params = params(lib, ControllerParams, values), params(lib, MotorParams, values)
        assert lib.sm_controller_init(buf, c_params, m_params, msg, 256) == 0, msg.value
        step = lib.sm_controller_step
        t0 = time.process_time()
        for t, arr in arrays:
            step(buf, t, TS, arr, msg, 256)
        best = min(best, time.process_time() - t0)
    return best / len(arrays)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--no-write", action="store_true", help="do not rewrite bench/RESULTS.md")
    args = ap.parse_args(argv)
    lib = ctypes.CDLL(str(build()))
    lib.sm_controller_size.restype = ctypes.c_size_t
    lib.sm_controller_init.argtypes = [ctypes.c_void_p, ctypes.POINTER(ControllerParams),
                                       ctypes.POINTER(MotorParams), ctypes.c_char_p, ctypes.c_size_t]
    lib.sm_controller_step.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_double,
                                       ctypes.POINTER(ctypes.c_double), ctypes.c_char_p, ctypes.c_size_t]
    load0 = os.getloadavg()[0]
    lines = ["| configuration | Python unit [us/step] | C unit via ctypes [us/step] |", "|---|---|---|"]
    print("\n".join(lines))
    for name, values in CONFIGS.items():
        rows = record(values)
        py = time_python(values, rows, args.repeats)
        c = time_c(lib, values, rows, args.repeats)
        lines.append(f"| {name} | {1e6 * py:.1f} | {1e6 * c:.2f} |")
        print(lines[-1], flush=True)
    if not args.no_write:
        head = ["## The flux observer's cost per controller step (`python -m bench observer`)", "",
                measured(load0) + f" Best of {args.repeats} replays, CPU time.", ""]
        write_section("observer", "\n".join(head + lines))


if __name__ == "__main__":
    main()

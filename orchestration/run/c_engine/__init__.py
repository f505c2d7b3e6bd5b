"""The compiled stepping engine, ``run --engine c``: the fmpy master's loop in one small C library.

* ``sm_engine.c`` -- the loop over ``t_k = t0 + k h``: the profiles, the controller and the plant through
  their FMI 2.0 / 3.0 C API, the wiring, Gauss-Seidel and Jacobi, multi-rate, the measurement model,
  rows into a preallocated buffer.  No allocation, no global state.
* :mod:`~orchestration.run.c_engine.build` -- the library compiled once per source into a cache.
* :mod:`~orchestration.run.c_engine.stepper` -- the fmpy master's ``_loop`` handed to the library.

:func:`run` is :func:`orchestration.run.master.run` with the engine's loop: the same instantiation,
parameters, initialization, recorder and metrics, so the results are those of the fmpy master bit for
bit (``tests/test_c_engine.py``).  :func:`problems` says what the engine does not run (the pythonfmu
FMUs), before anything runs.
"""

from __future__ import annotations

from functools import partial

from orchestration.run import master
from orchestration.run.c_engine.stepper import Unsupported, loop

__all__ = ["run", "problems", "VARIANTS", "Unsupported"]

VARIANTS = ("native", "native-fmi3")  # the FMUs the engine runs (orchestration.packaging.fmus.VARIANTS)

run = partial(master.run, loop=loop)


def problems(variant):
    """What keeps the engine from running the FMUs of ``variant``: a list of messages (empty: none)."""
    if variant not in VARIANTS:
        return [f"--variant {variant}: the c engine runs the native FMUs ({', '.join(VARIANTS)}); the "
                f"{variant} FMUs run with --engine fmpy"]
    return []

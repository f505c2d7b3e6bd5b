"""The compiled stepping engine, ``run --engine c``: the fmpy master's loop in one small C library.

* ``sm_engine.c`` -- the loop over ``t_k = t0 + k h``: the profiles, the controller and the plant through
  their FMI 2.0 / 3.0 C API, the wiring, Gauss-Seidel and Jacobi, multi-rate, the measurement model,
  rows into a preallocated buffer.  No allocation, no global state.
* :mod:`~orchestration.run.c_engine.build` -- the library compiled once per source into a cache.
* :mod:`~orchestration.run.c_engine.stepper` -- the fmpy master's ``_loop`` handed to the library.
* :mod:`~orchestration.run.c_engine.prepared` -- the FMUs extracted and their descriptions read once per
  content, into the same cache.

:func:`run` is :func:`orchestration.run.master.run` with the engine's loop: the same instantiation,
parameters, initialization, recorder and metrics, so the results are those of the fmpy master bit for
bit (``tests/test_c_engine.py``).  :func:`problems` says what the engine does not run (the pythonfmu
FMUs), before anything runs.
"""

from __future__ import annotations

from orchestration.run import master
from orchestration.run.c_engine.prepared import prepared
from orchestration.run.c_engine.stepper import Unsupported, loop

__all__ = ["run", "problems", "VARIANTS", "Unsupported"]

VARIANTS = ("native", "native-fmi3")  # the FMUs the engine runs (orchestration.packaging.fmus.VARIANTS)


def run(scenario, plant_fmu, controller_fmu, unzip_dirs=None, descriptions=None, **kw):
    """:func:`orchestration.run.master.run` with the engine's loop; without ``unzip_dirs`` the FMUs'
    extracted copies and descriptions come from the engine's cache
    (:func:`~orchestration.run.c_engine.prepared.prepared`)."""
    if unzip_dirs is None:
        unzip_dirs, mds = zip(*(prepared(p) for p in (plant_fmu, controller_fmu)))
        descriptions = descriptions or mds
    return master.run(scenario, plant_fmu, controller_fmu, unzip_dirs=unzip_dirs, descriptions=descriptions,
                      loop=loop, **kw)


def problems(variant):
    """What keeps the engine from running the FMUs of ``variant``: a list of messages (empty: none)."""
    if variant not in VARIANTS:
        return [f"--variant {variant}: the c engine runs the native FMUs ({', '.join(VARIANTS)}); the "
                f"{variant} FMUs run with --engine fmpy"]
    return []

"""Running a scenario: the plant and controller FMUs stepped together.

* :mod:`~orchestration.run.master` -- the fmpy master, FMPy's way: :func:`run` (the stepping loop),
  with :mod:`~orchestration.run.wiring` (the scenario's connections resolved once),
  :mod:`~orchestration.run.step_plans` (what the loop calls per step, built once),
  the recorder :mod:`orchestration.results.recorder` (in memory or streamed to disk),
  :mod:`~orchestration.run.measurement_noise` and
  :mod:`~orchestration.run.fmu_instance` (one FMU instance, its log, its unzip directory).
* :mod:`~orchestration.run.result` -- :class:`RunResult`, what every engine gives back.
* :mod:`~orchestration.run.libcosim_engine` -- the same scenario on OSP's libcosim (C++ engine),
  reading its results through :mod:`~orchestration.run.libcosim_readers`.
* :mod:`~orchestration.run.reference` -- the plain-Python loop (no FMI) the master is checked against.
"""

"""The co-simulation tools around the two FMUs, one sub-package per job.

Dependencies point one way, from the top of this list to the bottom (no import cycle, between
modules or between sub-packages: tests/test_no_cycles.py):

* :mod:`orchestration.cli` -- the command line (``satmotor-cosim``, ``python -m orchestration``):
  the verbs, ``batch`` and its warm children.
* :mod:`orchestration.tools` -- ``export-ssp`` (SSP 1.0 packages) and ``fit-curve`` (a magnetizing
  curve from a no-load test).
* :mod:`orchestration.study` -- a study's analyses of its variants' results: sensitivity indices, the
  summary, ``sensitivity.png`` and ``report.html`` (the designs that draw the variants are the sweep's,
  in :mod:`orchestration.scenario`).
* :mod:`orchestration.check` -- the FMU checker, a product of its own: it checks anyone's FMUs
  (it uses only :mod:`orchestration.process`).
* :mod:`orchestration.run` -- the fmpy master (wiring, stepping loop), the libcosim engine, the
  plain-Python reference loop, the run result; it records into the results' recorder.
* :mod:`orchestration.results` -- what a run leaves behind: the recorder (in memory or streamed to the
  time-series files), metrics, the results files, the figure.
* :mod:`orchestration.packaging` -- every FMU and generated artefact: pythonfmu and native FMUs, model
  descriptions, C variable tables, the SSP system description, cross builds, reference results,
  the variable tables of the docs.
* :mod:`orchestration.scenario` -- YAML in: a validated scenario, every problem with file, field
  and value; the time profiles; the system a scenario runs (units, connections, measurements) and
  what a run records; feasibility.
* :mod:`orchestration.process` -- what every long-running command shares: Ctrl-C/SIGTERM as a stop
  request, a clean process exit, process titles.
"""

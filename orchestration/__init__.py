"""Co-simulation of the saturated induction motor FMU with the backstepping controller FMU.

* :mod:`orchestration.profiles` -- time profiles of the set-points and the load torque.
* :mod:`orchestration.scenario` -- YAML scenario files: schema, validation, loading.
* :mod:`orchestration.master` -- the fmpy co-simulation master (Gauss-Seidel or Jacobi).
* :mod:`orchestration.results`, :mod:`orchestration.batch`, :mod:`orchestration.cli` -- results
  files and metrics, batches of scenarios, the command line (``python -m orchestration``).
"""

__all__ = ["profiles", "scenario", "master", "results", "batch", "cli", "fmus", "fmu_instance", "plots"]

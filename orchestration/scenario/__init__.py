"""YAML in: a scenario checked before anything runs, every problem of a file at once.

* :mod:`~orchestration.scenario.problems` -- :class:`Problem` (file, field, value, what is wrong),
  :class:`Note` (allowed, but said), the :class:`Checker` that collects them, :class:`ProblemError`.
* :mod:`~orchestration.scenario.load` -- the scenario schema: :func:`load_scenario`, :class:`Scenario`,
  :class:`ScenarioError`.
* :mod:`~orchestration.scenario.validate` -- :func:`check_scenario_file`, :func:`validate_scenario_file`:
  every problem of a file and of its sweep's variants, never raising.
* :mod:`~orchestration.scenario.profiles` -- the time profiles of the set-points and the load.
* :mod:`~orchestration.scenario.sweep` -- the ``sweep:`` section: a grid or Monte Carlo draws of
  variants, expanded before anything runs; :mod:`~orchestration.scenario.variants` -- a sweep file
  read and every variant checked (``load_sweep``), or one variant (``load_variant``);
  :mod:`~orchestration.scenario.priors` -- a parameter's prior ``{from: fit.yaml}`` read and checked;
  :mod:`~orchestration.scenario.correlation` -- the correlated draws of the normal parameters.
* :mod:`~orchestration.scenario.plausibility` -- notes for inputs far outside the motor's range.
* :mod:`~orchestration.scenario.system` -- the system a scenario runs: units, connections, the
  measured signals and the ``measurements:`` section.
* :mod:`~orchestration.scenario.recording` -- the columns a run records and which ones it keeps.
* :mod:`~orchestration.scenario.feasibility` -- physics checks (reachable flux, the torque the
  current limit allows, recording size).
* :mod:`~orchestration.scenario.presets` -- ``motor: {preset: NAME, ...}``: a named motor expanded.
"""

"""YAML in: a scenario checked before anything runs, every problem of a file at once.

* :mod:`~orchestration.scenario.problems` -- :class:`Problem` (file, field, value, what is wrong),
  the :class:`Checker` that collects them, :class:`ProblemError`.
* :mod:`~orchestration.scenario.load` -- the scenario schema: :func:`load_scenario`,
  :func:`validate_scenario_file`, :class:`Scenario`, :class:`ScenarioError`.
* :mod:`~orchestration.scenario.profiles` -- the time profiles of the set-points and the load.
* :mod:`~orchestration.scenario.feasibility` -- physics checks (reachable flux, recording size).
"""

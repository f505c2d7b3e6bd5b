"""Studies: a list of runs (a sweep's variants) and an analysis of their results; runs know nothing
of studies.

* which variants a sensitivity study runs (Saltelli's sampling for Sobol' indices, Morris trajectories)
  is the sweep's own part: :mod:`orchestration.scenario.designs`, beside the sweep that draws them.
* :mod:`~orchestration.study.analyses` -- the indices of every metric for every varied parameter.
* :mod:`~orchestration.study.summary` -- per metric the distribution and the fraction outside the
  acceptance bounds, the variants that failed or missed.
* :mod:`~orchestration.study.figures` -- ``sensitivity.png``.
* :mod:`~orchestration.study.report` -- every file of a study (``batch`` calls
  :func:`~orchestration.study.report.write_study` for every sweep), ``report.html``.
"""

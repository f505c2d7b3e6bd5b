"""What a run leaves behind: metrics, the results files and the figure.

* :mod:`~orchestration.results.writer` -- the results directory of a run: time series (CSV,
  Parquet), ``metrics.json``, the acceptance check.
* :mod:`~orchestration.results.plots` -- the figure.
* :mod:`~orchestration.results.figure_process` -- a helper process that imports matplotlib and draws
  while the run steps.
"""

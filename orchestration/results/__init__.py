"""What a run leaves behind: metrics, the results files and the figure.

* :mod:`~orchestration.results.writer` -- the results directory of a run: time series (CSV,
  Parquet), ``metrics.json``, the acceptance check.
* :mod:`~orchestration.results.plots` -- the figure.
* :mod:`~orchestration.results.figure_process` -- a helper process that imports matplotlib and draws
  while the run steps.
* :mod:`~orchestration.results.atomic` -- every result file written whole or not at all (temporary
  name, rename), the ``running`` status's owner (pid, host, start), the one line of an OSError.
* :mod:`~orchestration.results.batch_summary` -- a batch's ``summary.csv``, whole at every moment.
"""

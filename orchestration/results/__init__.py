"""What a run leaves behind: the recorded rows, metrics, the results files and the figure.

* :mod:`~orchestration.results.recorder` -- the rows a run records, in memory (the library use) or
  streamed to ``timeseries.csv`` / ``.parquet`` as the run goes; the record levels.  The engines of
  :mod:`orchestration.run` record into it (this package imports nothing of ``run``).
* :mod:`~orchestration.results.writer` -- the results directory of a run: time series (CSV,
  Parquet), ``metrics.json``, the acceptance check.
* :mod:`~orchestration.results.running` -- what the results need, gathered as the run goes: the
  metrics (:class:`satmotor.metrics.RunningMetrics`) and the figure's bounded copy.
* :mod:`~orchestration.results.sweep_table` -- a sweep's table (CSV, Parquet) and figure.
* :mod:`~orchestration.results.plots` -- the figure.
* :mod:`~orchestration.results.figure_process` -- a helper process that imports matplotlib and draws
  while the run steps.
* :mod:`~orchestration.results.atomic` -- every result file written whole or not at all (temporary
  name, rename), the ``running`` status's owner (pid, host, start), the one line of an OSError.
* :mod:`~orchestration.results.batch_summary` -- a batch's ``summary.csv``, whole at every moment.
* :mod:`~orchestration.results.reserve` -- room kept on the disk for a batch's final tables.
"""

"""The command line: ``satmotor-cosim {build,run,batch,validate,check,export-ssp,fit-curve}``, also
``python -m orchestration``.

* :mod:`~orchestration.cli.commands` -- the verbs and their exit codes; exports :func:`main`.
* :mod:`~orchestration.cli.batch` -- many scenarios in child processes (locally or on Dask), one
  summary row each.
* :mod:`~orchestration.cli.warm_children` -- batch children forked from a server that has imported
  the run path once.
* :mod:`~orchestration.cli.scheduler` -- ``batch --scheduler``: whether a Dask scheduler answers,
  found out within seconds.
"""

from orchestration.cli.commands import main

__all__ = ["main"]

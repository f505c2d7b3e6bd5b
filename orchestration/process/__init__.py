"""What every long-running command shares (imports nothing of the project).

* :mod:`~orchestration.process.interrupts` -- SIGINT/SIGTERM as a stop request; children that die
  with their parent.
* :mod:`~orchestration.process.clean_exit` -- ending a process without running native exit code.
* :mod:`~orchestration.process.title` -- a helper process's name in ``ps``.
"""

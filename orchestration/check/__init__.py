"""The FMU checker (``satmotor-cosim check``): a product of its own, for anyone's FMI 2.0 and 3.0
co-simulation FMUs.

* :mod:`~orchestration.check.checker` -- the checks and their verdicts (``run``, JUnit output).
* :mod:`~orchestration.check.probes` -- the run-time probes, each in a child process of its own.
"""

"""satmotor: saturated induction motor physics and backstepping control, FMI-agnostic.

Imports numpy only.  See the README for the model conventions.
"""

__version__ = "0.1.0"

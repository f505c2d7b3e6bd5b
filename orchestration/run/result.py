"""What a run gives back, whichever engine ran it (the fmpy master or libcosim): the
:class:`RunResult` and the one-line message of a failed FMU call."""

from __future__ import annotations

from dataclasses import dataclass

from orchestration.results.recorder import Recorder

__all__ = ["RunResult", "failure_message"]


@dataclass
class RunResult:
    """Outcome of one run: the recorder and how the run ended."""

    scenario: object
    recorder: Recorder
    status: str  # ok, discard, error, fatal (FMI status of the failing call), setup, or interrupted
    message: str
    t_end: float  # [s] last communication point reached (where a failure happened)
    wall_time: float  # [s]
    failed_unit: str = ""  # "plant" or "controller" when an FMU failed
    warnings: tuple = ()  # (unit, message) of what the FMUs logged at warning level (fmpy master)

    @property
    def ok(self):
        return self.status == "ok"

    @property
    def frame(self):
        """The recorded rows as a DataFrame."""
        return self.recorder.frame()


def failure_message(unit, exc, inst):
    """``unit: what failed -- the FMU's first error message``."""
    first = inst.first_error() if inst else ""
    return f"{unit}: {exc}" + (f" -- {first}" if first else "")

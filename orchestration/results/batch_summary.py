"""A batch's ``summary.csv``, whole at every moment, from the start of the batch to its end.

Before any run starts the file is written with one row per scenario: those that cannot run with
their message, the others ``running`` with the batch's pid, host and start
(:func:`orchestration.results.atomic.owner`).  Each finished scenario replaces its row and the whole
file is written again, under a temporary name renamed onto ``summary.csv``
(:mod:`orchestration.results.atomic`): a batch killed at any moment (even by SIGKILL) leaves a
complete table where each row is either a result or ``running`` with a pid that a later reader finds
gone (:func:`orchestration.results.atomic.stale_reason`).  When even that cannot be written (a full
disk), the batch goes on; at the end it prints the table on standard error instead, and says why
(the batch keeps room for the final table: :mod:`orchestration.results.reserve`).

A child of the batch (``run --batch-rows``) also prints one :func:`report_line` per run on its standard
output: the run's status and message, read by :func:`reported` when the run's ``metrics.json`` could
not be written (a full disk), so that its row still names the cause.
"""

from __future__ import annotations

import json
import sys

from orchestration.results import atomic


def csv_text(rows):
    """The CSV text of ``rows`` (dicts), sorted by their ``file``, as pandas writes it."""
    import pandas as pd

    return pd.DataFrame(list(rows)).sort_values("file").reset_index(drop=True).to_csv(index=False)


def running_row(file, name, owner):
    """The row of a scenario the batch (``owner``: :func:`orchestration.results.atomic.owner`) has not
    finished yet."""
    return {"file": str(file), "scenario": name, "status": "running", "exit_code": 0,
            "message": f"no result yet: batch process {owner['pid']} on {owner['host']}, started "
                       f"{owner['started']}", **owner}


class SummaryFile:
    """``summary.csv`` at ``path``, rewritten whole by :meth:`write`; :attr:`error` is the last
    OSError (None after a write that succeeded)."""

    def __init__(self, path):
        self.path = path
        self.error = None

    def write(self, rows):
        """Write ``rows``; True when written, False (and :attr:`error` set) when not."""
        try:
            atomic.write_text(self.path, csv_text(rows))
        except OSError as exc:
            self.error = exc
            return False
        self.error = None
        return True

    def write_or_print(self, rows, stream=None):
        """:meth:`write`, or when that fails, one line saying why and the CSV text on ``stream``
        (standard error): the summary is never lost.  True when written to the file."""
        if self.write(rows):
            return True
        stream = stream or sys.stderr
        print(f"{self.path} could not be written ({atomic.describe(self.error, self.path)}); "
              "the summary follows here:", file=stream)
        stream.write(csv_text(rows))
        stream.flush()
        return False


REPORT_PREFIX = "satmotor-batch-row "  # a line a batch's child prints per run (``run --batch-rows``)
_REPORTED = ("scenario", "status", "message", "write_failed")


def report_line(summary):
    """The line ``run --batch-rows`` prints for a run's ``summary`` (:func:`reported` reads it back)."""
    return REPORT_PREFIX + json.dumps({k: summary[k] for k in _REPORTED if k in summary})


def reported(stdout):
    """``{scenario name: {status, message[, write_failed]}}`` of the :func:`report_line` lines in a
    child's standard output (a line cut or garbled is skipped)."""
    out = {}
    for line in (stdout or "").splitlines():
        if not line.startswith(REPORT_PREFIX):
            continue
        try:
            d = json.loads(line[len(REPORT_PREFIX):])
        except ValueError:
            continue
        if isinstance(d, dict) and isinstance(d.get("scenario"), str) and isinstance(d.get("status"), str):
            out[d["scenario"]] = d
    return out

"""Room kept on the results' disk for a batch's last words: its final ``summary.csv`` and sweep tables.

A batch whose runs fill the disk (or a quota) could otherwise not write the table that says so: the
``summary.csv`` on disk would keep the rows ``running`` it had before the runs.  So the batch sets
room aside before the first run, :class:`Reserve`: a hidden file ``.satmotor-reserve`` of
:func:`size_for` bytes in ``--out`` (allocated, not sparse: ``posix_fallocate``, else written with
bytes that no compressing filesystem can shrink), and gives it back (:meth:`Reserve.release`) once every
run has ended, just before the final summary and the sweeps' tables are written.  The runs meet the
full disk earlier by that much; the batch's own files then fit.  Best effort: a reserve that cannot be
made (a disk full already) is none, and the batch goes on as before (its first summary write then
refuses the batch).
"""

from __future__ import annotations

import os
from pathlib import Path

NAME = ".satmotor-reserve"
BASE = 64 * 1024  # [B] the tables' headers, a study summary, the figures' lines of text
PER_ROW = 4096  # [B] a row of summary.csv (its message: up to six lines of a child's stderr) and of
# sweep.csv and sweep.parquet; a temporary copy of summary.csv exists beside the old one while it is
# replaced, which the old one's room covers
_CHUNK = 1 << 20


def size_for(rows):
    """The bytes kept for a batch of ``rows`` scenarios and variants."""
    return BASE + PER_ROW * max(0, int(rows))


class Reserve:
    """``size`` bytes kept in ``directory`` until :meth:`release` (:attr:`size`: what was kept, 0 when the
    disk had no room for it)."""

    def __init__(self, directory, size):
        self.path = Path(directory) / NAME
        self.size = 0
        try:
            fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        except OSError:
            return
        try:
            try:
                os.posix_fallocate(fd, 0, size)
            except (AttributeError, OSError):  # no fallocate here (or not on this filesystem): written
                os.ftruncate(fd, 0)
                left = size
                while left > 0:
                    n = min(left, _CHUNK)
                    os.write(fd, os.urandom(n))  # random: a compressing filesystem keeps every block
                    left -= n
            self.size = size
        except OSError:  # no room for it: no reserve
            self.release()
        finally:
            os.close(fd)

    def release(self):
        """Give the room back (once; later calls do nothing)."""
        try:
            self.path.unlink()
        except OSError:
            pass
        self.size = 0

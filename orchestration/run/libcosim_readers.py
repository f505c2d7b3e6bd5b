"""What libcosim gives back to the engine (:mod:`orchestration.run.libcosim_engine`): the samples of
its time-series observer read into arrays, the controller's Boolean outputs from its file
observer's CSV (the time-series observer reads only Reals and Integers), and its console log with
the FMUs' messages.  The libcosimc calls libcosimpy does not wrap are made here, with ctypes, on the
library libcosimpy loaded."""

from __future__ import annotations

import ctypes
import os
import re
import sys
from ctypes import POINTER, c_char_p, c_int, c_int64, c_size_t, c_uint32, c_void_p
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

__all__ = ["Lib", "Series", "BoolFile", "CapturedLog", "file_observer", "positions", "FAILED"]

LOG_CONFIG = "LogConfig.xml"  # the file observer's configuration, in the engine's directory


class Lib:
    """The libcosimc calls the engine makes itself (sample reads into numpy arrays, the file
    observer from a configuration), on the library libcosimpy loaded."""

    def __init__(self):
        from libcosimpy._internal import libcosimc

        lib = libcosimc()
        self.real_samples = lib.cosim_observer_slave_get_real_samples
        self.int_samples = lib.cosim_observer_slave_get_integer_samples
        self.real_samples.restype = self.int_samples.restype = c_int64
        args = [c_int, c_uint32, c_int64, c_size_t, c_void_p, POINTER(c_int64), POINTER(c_int64)]
        self.real_samples.argtypes = self.int_samples.argtypes = [POINTER(None)] + args
        self.last_error = lib.cosim_last_error_message
        self.last_error.restype, self.last_error.argtypes = c_char_p, []

    def error(self):
        msg = self.last_error()
        return msg.decode("utf-8", "replace") if msg else "no message from libcosim"


class Series:
    """Reads ``[from_step, from_step + count)`` of the observed variables into float arrays."""

    def __init__(self, lib, observer):
        self._lib, self._obs = lib, observer

    def read(self, slave, refs, kind, from_step, count):
        """``(step numbers, values[len(refs), n])``: the samples libcosim holds from ``from_step``
        (at most ``count``; a decimated simulator has samples at its own steps only)."""
        real = kind == "real"
        fn = self._lib.real_samples if real else self._lib.int_samples
        steps, times = np.zeros(count, np.int64), np.zeros(count, np.int64)
        out = np.zeros((len(refs), count), np.float64 if real else np.intc)
        sp, tp = steps.ctypes.data_as(POINTER(c_int64)), times.ctypes.data_as(POINTER(c_int64))
        base, row = out.ctypes.data, out.itemsize * count
        got = count
        for i, ref in enumerate(refs):
            n = fn(self._obs, slave, ref, from_step, count, base + i * row, sp, tp)
            if n < 0:
                raise RuntimeError(f"reading samples of slave {slave} variable {ref}: {self._lib.error()}")
            got = min(got, n)
        return steps[:got].copy(), out[:, :got].astype(np.float64, copy=False)


class BoolFile:
    """The controller's Booleans from the file observer's CSV, read as it grows.  libcosim writes
    one line per controller step (``Time,StepCount,flags...``, flags 0 / 1) through a buffered
    stream, so the file lags the execution by up to a buffer's worth of lines; all of it is there
    once the execution is gone.  Kept: the step numbers and the flags not yet taken."""

    def __init__(self, path, n):
        self.path, self.n, self._pos = Path(path), n, 0
        self.steps, self.flags = np.empty(0, np.int64), np.empty((0, n))

    def update(self):
        if not self.n or not self.path.exists():
            return
        with open(self.path, "rb") as f:
            f.seek(self._pos)
            text = f.read()
        end = text.rfind(b"\n") + 1
        self._pos += end
        lines = [ln for ln in text[:end].decode().splitlines() if not ln.startswith("Time")]
        if lines:
            cells = np.array(",".join(lines).split(","), dtype=object).reshape(len(lines), -1)
            self.steps = np.concatenate([self.steps, cells[:, 1].astype(np.int64)])
            self.flags = np.vstack([self.flags, (cells[:, 2:2 + self.n] == "1").astype(float)])

    def take(self, wanted):
        """``(k, flags of wanted[:k])``: the flags of the leading step numbers of ``wanted`` (sorted)
        that are on disk; the lines before ``wanted[0]`` are dropped."""
        first = np.searchsorted(self.steps, wanted[0])
        self.steps, self.flags = self.steps[first:], self.flags[first:]
        k = int(np.searchsorted(wanted, self.steps[-1], side="right")) if len(self.steps) else 0
        return k, self.flags[np.searchsorted(self.steps, wanted[:k])]


FAILED = ("discard", "error", "fatal")
_FMI_LINE = re.compile(r"\[FMI status=(\w+), category=[^\]]*\] (.*)")


class CapturedLog:
    """libcosim's console log sent to ``path`` while the block runs.  libcosim writes its log to the
    standard output (file descriptor 1) and has no log callback, and the FMUs' messages reach the
    host only through it (an FMU's discard message at debug level).  After the block, libcosim's own
    warnings and errors are written to stderr, and :meth:`first_fmu_error` gives the first message
    an FMU logged with a discard, error or fatal status (the master's ``-- message``)."""

    def __init__(self, path):
        self.path, self.lines = Path(path), []

    def __enter__(self):
        from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

        sys.stdout.flush()
        self._libc = ctypes.CDLL(None)
        self._saved = os.dup(1)
        fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        os.dup2(fd, 1)
        os.close(fd)
        log_output_level(CosimLogLevel.DEBUG)
        return self

    def __exit__(self, *exc):
        from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

        log_output_level(CosimLogLevel.WARNING)
        sys.stdout.flush()
        self._libc.fflush(None)
        os.dup2(self._saved, 1)
        os.close(self._saved)
        self.lines = self.path.read_text(errors="replace").splitlines()
        for ln in self.lines:
            if re.search(r"\] \[(warning|error|fatal)\]", ln):
                print(ln, file=sys.stderr)
        return False

    def first_fmu_error(self):
        for ln in self.lines:
            m = _FMI_LINE.search(ln)
            if m and m.group(1) in FAILED:
                return m.group(2)
        return ""


def positions(steps, wanted):
    """Indices of ``wanted`` step numbers in the observer's ``steps`` (each must be there)."""
    pos = np.searchsorted(steps, wanted)
    if len(steps) == 0 or pos.max() >= len(steps) or not np.array_equal(steps[pos], wanted):
        raise RuntimeError(f"libcosim's observer lacks samples of steps {wanted[0]}..{wanted[-1]}")
    return pos


def _file_observer_from(cfg, directory):
    from libcosimpy._internal import libcosimc
    from libcosimpy.CosimObserver import CosimObserver

    create = libcosimc().cosim_file_observer_create_from_cfg
    create.restype, create.argtypes = POINTER(CosimObserver), [c_char_p, c_char_p]
    ptr = create(str(directory).encode(), str(cfg).encode())
    if not ptr:
        raise RuntimeError(f"libcosim file observer from {cfg}: {Lib().error()}")
    return CosimObserver(CosimObserver._CosimObserver__create_key, ptr)


def file_observer(names, instance, directory):
    """A libcosim file observer writing ``directory/observer/<instance>.csv``: the variables ``names``
    of ``instance`` at every one of its steps (``Time,StepCount,values...``)."""
    cfg = Path(directory) / LOG_CONFIG
    cfg.write_text("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
                   "<configuration timestampedFilenames=\"false\"/>\n<simulators>\n"
                   f"  <simulator name={quoteattr(instance)} decimationFactor=\"1\">\n"
                   + "".join(f"    <variable name={quoteattr(n)}/>\n" for n in names)
                   + "  </simulator>\n</simulators>\n")
    return _file_observer_from(cfg, Path(directory) / "observer")

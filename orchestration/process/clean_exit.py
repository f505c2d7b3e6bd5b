"""End a host process of ours without running native exit code: :func:`exit_now`.

Why: pythonfmu 0.6.5-0.7.0's native wrapper (the binary in every FMU we build) keeps a static
``std::shared_ptr<PyState>``.  At ``exit()`` the C++ exit handlers destroy it (its memory is freed,
the pointer is left set), then the library's ELF destructor ``onLibraryUnload()`` ->
``finalizePythonInterpreter()`` assigns ``nullptr`` to it: an atomic decrement on freed memory, and a
virtual call through it whenever the freed word happens to read 1.  valgrind reports it in every
process that instantiated one of our FMUs; in some heap layouts glibc aborts (``corrupted
double-linked list``, exit status 134) after a run that succeeded.

:func:`exit_now` ends the process the way Python would up to the point where the broken code runs,
then stops: it waits for the non-daemon threads, runs the ``atexit`` handlers (logging shutdown,
temporary-directory cleanup, the FMU glue's own exit guard), flushes ``sys.stdout``/``sys.stderr``
and calls ``os._exit``.  Skipped: the interpreter's own teardown (``__del__`` of objects still alive,
module cleanup), the C++ static destructors and ELF destructors of every loaded library.  Hence the
rule for callers: call it last, when every result file is written and closed (a ``with`` block
or ``close()``); a file object left open and unflushed loses its buffer.
"""

from __future__ import annotations

import atexit
import os
import sys
import threading


def exit_status(code):
    """The process exit status ``sys.exit(code)`` would give: None -> 0, an int as is, anything
    else printed to stderr -> 1."""
    if code is None:
        return 0
    if isinstance(code, bool) or not isinstance(code, int):
        print(code, file=sys.stderr)
        return 1
    return code & 0xFF


def exit_now(code=0):
    """End the process with ``code`` (as ``sys.exit`` would interpret it) after threads, atexit
    handlers and stdio, without the native exit handlers.  Never returns."""
    status = exit_status(code)
    try:
        if threading.current_thread() is threading.main_thread():
            shutdown = getattr(threading, "_shutdown", None)  # what Py_Finalize runs first: joins
            if shutdown is not None:                           # non-daemon threads, stops executors
                shutdown()
        atexit._run_exitfuncs()  # what Py_Finalize runs next; exceptions are printed, not raised
    finally:
        for stream in (sys.stdout, sys.stderr, sys.__stdout__, sys.__stderr__):
            try:
                if stream is not None:
                    stream.flush()
            except (OSError, ValueError):  # closed, or the reader went away (EPIPE)
                pass
        os._exit(status)

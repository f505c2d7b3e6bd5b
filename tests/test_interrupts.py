"""The stop request that SIGINT/SIGTERM/SIGHUP become inside ``interrupts.catch``."""

import os
import signal
import time

from orchestration.process.interrupts import catch


def _deliver(sig):
    os.kill(os.getpid(), sig)
    time.sleep(0.05)  # the handler runs in the main thread between bytecodes


def test_a_signal_becomes_a_stop_request_and_the_handlers_are_restored():
    before = signal.getsignal(signal.SIGTERM)
    with catch() as stop:
        assert stop.signum == 0 and stop.exit_code == 0
        _deliver(signal.SIGTERM)
        _deliver(signal.SIGINT)  # a second signal does not overwrite the first
        assert stop.signum == signal.SIGTERM and stop.exit_code == 143 and stop.event.is_set()
    assert signal.getsignal(signal.SIGTERM) is before


def test_an_inherited_ignore_is_kept():
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with catch() as stop:
            _deliver(signal.SIGINT)
            assert stop.signum == 0
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, previous)


def test_signal_names():
    from orchestration.process.interrupts import signal_name

    assert signal_name(9) == "SIGKILL" and signal_name(15) == "SIGTERM" and signal_name(99) == "signal 99"


def test_sighup_is_a_stop_request_too():
    """A closed terminal (SIGHUP) stops a run or a batch as Ctrl-C does: exit code 129 (issue 31)."""
    with catch() as stop:
        _deliver(signal.SIGHUP)
        assert stop.signum == signal.SIGHUP and stop.exit_code == 129

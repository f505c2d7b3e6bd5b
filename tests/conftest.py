"""Shared fixtures: one instance of every magnetizing-curve family; the FMUs, built once per run."""

import contextlib
import fcntl
import os
import shutil
import signal
import sys
import tempfile
from pathlib import Path

import pytest

from satmotor.machine.magnetics import ArctanCurve, ExponentialCurve, LinearCurve, PolynomialCurve
from satmotor.machine.table_curve import TableCurve

if str(Path(__file__).resolve().parents[1]) not in sys.path:  # the package bench/: its C hosts
    sys.path.append(str(Path(__file__).resolve().parents[1]))


def no_load_table():
    """A no-load test as a user would measure it: points of a saturating curve
    that is not one of our families (a Froelich-type rational curve), unevenly spaced."""
    i = (0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.5, 9.0, 11.0, 14.0, 18.0)
    psi = tuple(0.012 * x + 0.945 * x / (3.0 + x) for x in i)
    return i, psi


CURVES = {
    "arctan": ArctanCurve(),
    "exponential": ExponentialCurve(),
    "polynomial": PolynomialCurve(),
    # even exponent: the 2.2-kW machine of Qu et al. 2012, L_s(psi) = 0.34 / (1 + (0.84 psi)^7) H
    "polynomial_even": PolynomialCurve(0.34, 0.84**7 / 0.34, 8),
    "table": TableCurve(*no_load_table()),
    "linear": LinearCurve(0.1722),
}
SATURATING = [k for k in CURVES if k != "linear"]


def pytest_configure(config):
    """The interrupt tests send SIGINT to their `run` and `batch` children as a terminal's Ctrl-C would.
    A pytest started with SIGINT ignored (by a script with `&`, or under nohup) would pass that on to
    them, and they keep an ignored SIGINT ignored, by design (orchestration.process.interrupts.catch): they
    would run to their end.  So this process handles SIGINT: its children start with the default."""
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    _own_temporary_directory(config)


#: the environment variable that names a test session's own temporary directory (set by the controller)
SESSION_TMP = "SATMOTOR_TEST_TMPDIR"


def _own_temporary_directory(config):
    """Every temporary file of the session in one directory of its own: what the tests, the libraries they
    call (fmpy's extract, dask's scratch space, the compilers) and their child processes create with
    ``tempfile`` or under ``$TMPDIR`` goes there, pytest's own ``tmp_path`` directories included; the
    controller removes it at the end of a session that passed (:func:`pytest_unconfigure`), and keeps it,
    saying where, when a test failed.  The pytest-xdist workers inherit it through the environment."""
    if os.environ.get("PYTEST_XDIST_WORKER") is None:
        d = tempfile.mkdtemp(prefix="satmotor-tests-")
        os.environ[SESSION_TMP] = os.environ["TMPDIR"] = d
        config.stash[_TMP_KEY] = d
    tempfile.tempdir = None  # gettempdir() reads $TMPDIR again


_TMP_KEY = pytest.StashKey[str]()
_STATUS_KEY = pytest.StashKey[int]()


def pytest_sessionfinish(session, exitstatus):
    session.config.stash[_STATUS_KEY] = int(exitstatus)


def pytest_unconfigure(config):
    d = config.stash.get(_TMP_KEY, None)
    if d is None:
        return
    if config.stash.get(_STATUS_KEY, 1) in (0, 5):  # passed, or nothing collected
        shutil.rmtree(d, ignore_errors=True)
    else:
        print(f"\ntemporary files of this session kept in {d}")


#: the default set (``make test``) leaves these to ``make test-slow`` besides the tests marked ``slow`` in
#: their files: every test that uses the cross-compiled FMUs (zig builds for Windows and macOS, minutes on a
#: fresh machine) and every run under sanitizers or valgrind (an instrumented build, 10-50x slower steps)
SLOW_FIXTURES = frozenset({"fmu_dir_all_platforms"})
SLOW_WORDS = ("sanitiz", "valgrind")


def pytest_collection_modifyitems(config, items):
    """Marks ``slow`` what :data:`SLOW_FIXTURES` and :data:`SLOW_WORDS` (in the test's name or its
    parameters' ids) name: CI runs both sets (``.ci/run``: ``make test``, then ``make test-slow``)."""
    for item in items:
        if SLOW_FIXTURES.intersection(item.fixturenames) or any(w in item.name.lower() for w in SLOW_WORDS):
            item.add_marker(pytest.mark.slow)


@pytest.fixture(params=list(CURVES))
def curve(request):
    return CURVES[request.param]


@pytest.fixture(params=SATURATING)
def saturating_curve(request):
    return CURVES[request.param]


#: a directory of FMUs to test instead of building them in the session (``make test`` passes build/fmus,
#: which ``make check`` then checks): built there when missing or stale, never written otherwise
FMU_DIR_VARIABLE = "SATMOTOR_TEST_FMUS"


@contextlib.contextmanager
def _locked(path):
    """An exclusive lock on the file ``path`` (flock): the pytest-xdist workers of one run build a
    directory once, the first one to get here, the others wait and use it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def _once_per_run(tmp_path_factory, name, build):
    """``build(directory)`` once per test run, also with pytest-xdist: there in the directory the
    workers share (the parent of their temporary directories, which is this run's own)."""
    if os.environ.get("PYTEST_XDIST_WORKER") is None:
        d = tmp_path_factory.mktemp(name)
        build(d)
        return d
    root = tmp_path_factory.getbasetemp().parent
    d, done = root / name, root / f"{name}.built"
    with _locked(root / f"{name}.lock"):
        if not done.exists():
            build(d)
            done.touch()
    return d


def _host_only(fmus, d):
    return all(fmus.binary_folders(p) == {"linux64"} for p in fmus.paths(d, "native")) and all(
        fmus.binary_folders(p) == {"x86_64-linux"} for p in fmus.paths(d, "native-fmi3"))


@pytest.fixture(scope="session")
def fmu_dir(tmp_path_factory):
    """The six FMUs for this machine (pythonfmu, native FMI 2.0 and 3.0; no cross-compile), built once
    per test run: in $SATMOTOR_TEST_FMUS when set (rebuilt there only when missing, stale or
    cross-built), else in a temporary directory.  The tests must not write into it."""
    from orchestration.packaging import fmus

    given = os.environ.get(FMU_DIR_VARIABLE)
    if given:
        d = Path(given).resolve()
        with _locked(d.parent / f".{d.name}.lock"):
            if not (_host_only(fmus, d) and fmus.up_to_date(d)):  # e.g. an older build with cross-compiles
                fmus.build(d, quiet=True)
        return d
    return _once_per_run(tmp_path_factory, "fmus", lambda d: fmus.build(d, quiet=True))


@pytest.fixture(scope="session")
def fmu_dir_all_platforms(tmp_path_factory):
    """The distributable FMUs (``build --all-platforms``: the native ones for Linux, Windows and macOS,
    cross-compiled with zig), built once per run, only for the tests that use them; skipped without zig.
    On a fresh machine zig first compiles its MinGW and macOS C runtimes: minutes.  In
    $SATMOTOR_TEST_FMUS_ALL when set (rebuilt there only when missing or stale), as $SATMOTOR_TEST_FMUS."""
    from orchestration.packaging import fmus
    from orchestration.packaging.native import compiler as native_build

    if not native_build.zig_available():
        pytest.skip("zig is not installed (pip install ziglang, in the native and dev extras)")
    given = os.environ.get(FMU_DIR_VARIABLE + "_ALL")
    if given:
        d = Path(given).resolve()
        with _locked(d.parent / f".{d.name}.lock"):
            if not fmus.up_to_date(d, all_platforms=True):
                fmus.build(d, quiet=True, all_platforms=True)
        return d
    return _once_per_run(tmp_path_factory, "fmus_all_platforms",
                         lambda d: fmus.build(d, quiet=True, all_platforms=True))

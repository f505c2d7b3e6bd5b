"""FMI glue shared by the two slaves: registration from the satmotor interface tables, the bundle
check, initialization, stepping and the full FMU state.  No equations here.

Bundled into each FMU next to ``satmotor/``.  pythonfmu imports every FMU's modules into one shared
interpreter, caching them by name; the slaves therefore check, at instantiation, that the
``satmotor`` and glue modules they got hash to the fingerprint baked in at build time.
"""

from __future__ import annotations

import math
from pathlib import Path

from pythonfmu import Boolean, Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability, Integer, Real, String
from pythonfmu.enums import Fmi2Status

import satmotor

_TYPES = {"Real": Real, "Integer": Integer, "Boolean": Boolean, "String": String}
_CAUSALITY = {"input": Fmi2Causality.input, "output": Fmi2Causality.output,
              "parameter": Fmi2Causality.parameter}


_PINNED = []


def pin_namespace(namespace):
    """Keep one more reference to a slave module's namespace.  pythonfmu 0.7.0's fmi2Instantiate
    (findClass) re-executes the slave script in that namespace, then Py_DECREFs the borrowed dict;
    calling this at the script's top level adds the reference that DECREF takes away (without it
    the second instance of an FMU in one process crashes the host)."""
    _PINNED.append(namespace)


def fingerprint():
    """SHA-256 over the sources of the loaded ``satmotor`` package and of this module."""
    return satmotor.source_fingerprint(Path(__file__).resolve())


def _describe(var):
    return f"{var.description} [{var.unit}]" if var.unit else var.description


class UnitSlave(Fmi2Slave):
    """Base of the two slaves.  Subclasses set VARIABLES (interface tables), UNIT (a satmotor
    interface unit class taking ``{parameter: value}``) and FINGERPRINT (filled in by the build)."""

    VARIABLES = ()
    UNIT = None
    FINGERPRINT = ""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        guard_process_exit(self.resources)  # see guard_process_exit (end of file)
        got = fingerprint()
        if self.FINGERPRINT and got != self.FINGERPRINT:
            raise ImportError(
                f"{type(self).__name__}: the loaded satmotor ({satmotor.__file__}, version "
                f"{satmotor.__version__}) is not the one this FMU was built with (fingerprint {got[:12]} "
                f"!= {self.FINGERPRINT[:12]}); another FMU of a different build is loaded in this process")
        script = Path(self.resources) / f"{type(self).__module__}.py"
        if self.FINGERPRINT and script.exists() and self.FINGERPRINT not in script.read_text():
            raise ImportError(
                f"{type(self).__name__}: this process already runs {type(self).__module__} from another "
                f"build (fingerprint {self.FINGERPRINT[:12]}), not the one in {script.parent}")
        self._params = tuple(v.name for v in self.VARIABLES if v.causality == "parameter")
        self._inputs = tuple(v.name for v in self.VARIABLES if v.causality == "input")
        self._outputs = tuple(v.name for v in self.VARIABLES if v.causality == "output")
        self._unit = None
        for var in self.VARIABLES:
            setattr(self, var.name, var.start)
            kw = {"causality": _CAUSALITY[var.causality], "description": _describe(var)}
            if var.causality == "parameter":
                kw["variability"] = Fmi2Variability.fixed
            elif var.type == "Real":
                kw["variability"] = Fmi2Variability.continuous
            else:
                kw["variability"] = Fmi2Variability.discrete
            if var.causality == "output":
                kw["initial"] = Fmi2Initial.exact
            self.register_variable(_TYPES[var.type](var.name, **kw))

    def exit_initialization_mode(self):
        """Build the unit from the parameters; a bad value is logged (naming it) and refused."""
        try:
            self._unit = self.UNIT({name: getattr(self, name) for name in self._params})
        except Exception as exc:  # ParameterError, or a table file that cannot be read
            self.log(f"{type(self).__name__}: bad parameter: {exc}", Fmi2Status.error)
            raise
        self._publish()

    def do_step(self, current_time, step_size):
        """Advance the unit; a bad input or a failed step is logged and discarded, never raised."""
        try:
            self._unit.step(current_time, step_size, tuple(getattr(self, n) for n in self._inputs))
        except Exception as exc:
            self.log(f"{type(self).__name__} at t = {current_time!r} s: {exc}", Fmi2Status.discard)
            return False
        self._publish()
        return True

    def _publish(self):
        for name, value in zip(self._outputs, self._unit.outputs()):
            setattr(self, name, value)

    def _get_fmu_state(self):
        state = super()._get_fmu_state()
        state["_unit"] = None if self._unit is None else list(self._unit.get_state())
        return state

    def _set_fmu_state(self, state):
        state = dict(state)
        unit_state = state.pop("_unit", None)
        super()._set_fmu_state(state)
        if unit_state is not None:
            if self._unit is None:
                self._unit = self.UNIT({name: getattr(self, name) for name in self._params})
            self._unit.set_state(tuple(float(v) if isinstance(v, (int, float)) else math.nan
                                       for v in unit_state))


# --- process exit: pythonfmu 0.6.5-0.7.0 touches freed memory at exit; release its state in time ----------
#
# The native wrapper of these FMUs keeps a static std::shared_ptr<PyState> (PySlaveInstance.cpp).  At
# exit() the C++ exit handlers destroy it (its block is freed, the pointer left set); then the library's
# ELF destructor onLibraryUnload() -> finalizePythonInterpreter() does `pyState = nullptr` on it: an atomic
# decrement on freed memory (and a virtual call through it whenever the freed word reads 1).  Exit
# handlers run last-registered first, so the library's own finalizePythonInterpreter, registered here at
# instantiation (after the library registered its static's destructor at load), runs first: the
# pointer is null before the static is destroyed, and both later steps do nothing.

_EXIT_GUARDED = set()  # dlopen handles of the binaries whose release is registered


def guard_process_exit(resources):
    """Register, once per binary, the pythonfmu library's own ``finalizePythonInterpreter()`` as a C
    exit handler (glibc ``__cxa_atexit``) for the FMU unpacked next to ``resources``.  The library is
    already loaded (this runs inside its fmi2Instantiate); it is pinned (RTLD_NODELETE, as the first
    pythonfmu library of a process already is) so that the handler outlives a host's dlclose.  Linux
    only; a library without that symbol (not pythonfmu >= 0.6.5) is left alone; never raises."""
    try:
        import ctypes
        import glob
        import os
        import sys

        if not sys.platform.startswith("linux") or not resources:
            return
        for path in glob.glob(os.path.join(os.path.dirname(os.path.abspath(resources)),
                                           "binaries", "linux64", "*.so")):
            try:  # RTLD_NOLOAD: only a library the host has loaded, never load one
                lib = ctypes.CDLL(path, mode=os.RTLD_NOLOAD)
            except OSError:
                continue
            if lib._handle in _EXIT_GUARDED or not hasattr(lib, "finalizePythonInterpreter"):
                continue
            ctypes.CDLL(path, mode=os.RTLD_NOLOAD | os.RTLD_NODELETE)  # pin
            cxa_atexit = ctypes.CDLL("libc.so.6")["__cxa_atexit"]
            cxa_atexit.argtypes = (ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p)
            cxa_atexit.restype = ctypes.c_int
            release = ctypes.cast(lib.finalizePythonInterpreter, ctypes.c_void_p)
            if cxa_atexit(release, None, None) == 0:
                _EXIT_GUARDED.add(lib._handle)
    except Exception:  # noqa: BLE001 - a guard, never a reason to fail an instantiation
        pass

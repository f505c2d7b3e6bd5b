"""One FMI 2.0 or 3.0 co-simulation FMU instance, driven through fmpy's low-level FMU2Slave /
FMU3Slave API.

Value references are looked up by name in the model description.  Each instance keeps its own
log: FMUs call the logger with a variadic format, which ctypes cannot receive, so fmpy's native
proxy formats the message and calls one process-wide Python function; that function
(:func:`_route`) hands the message to the instance whose ``componentEnvironment`` token it
carries.  FMI 3.0's log callback has no variadic arguments: each instance passes its own.  The
per-step calls go through prebuilt ctypes arrays and argument tuples (one allocation per instance,
none per step) and private function pointers that declare no argument types
(:meth:`FMUInstance.fast`): every argument is already the ctypes object of its C type, so ctypes
passes it as it is instead of converting it on each call (about 0.3 us less per call);
:attr:`FMUInstance.calls` names the functions of the instance's FMI version.
"""

from __future__ import annotations

import itertools
import shutil
import sys
import tempfile
import weakref
from ctypes import byref, c_bool, c_double, c_int, c_size_t, c_void_p

from fmpy import extract, platform, platform_tuple, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    calloc,
    fmi2Boolean,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    fmi2Integer,
    fmi2Real,
    fmi2ValueReference,
    free,
)
from fmpy.fmi3 import FMU3Slave

STATUS = ("ok", "warning", "discard", "error", "fatal", "pending")
_FAILED = ("discard", "error", "fatal")

# The routing table of the process-wide logger: componentEnvironment token -> instance.  Weak:
# an instance that is gone takes its route with it.
_ROUTES = weakref.WeakValueDictionary()
_TOKENS = itertools.count(1)


def _route(env, instance_name, status, category, message):
    text = message.decode("utf-8", "replace") if isinstance(message, bytes) else str(message)
    level = STATUS[status] if 0 <= status < len(STATUS) else str(status)
    inst = _ROUTES.get(env or 0)
    if inst is not None:
        inst.messages.append((level, text))
    else:  # a message from an instance we do not know (another host in this process): keep it visible
        name = instance_name.decode("utf-8", "replace") if isinstance(instance_name, bytes) else instance_name
        print(f"[{name}] {level}: {text}", file=sys.stderr)


_LOGGER = fmi2CallbackLoggerTYPE(_route)  # one ctypes callback for the whole process, never freed

# the functions the stepping loop calls, and the declared type names, per FMI version
FMI2_CALLS = {"get_real": "fmi2GetReal", "set_real": "fmi2SetReal", "get_int": "fmi2GetInteger",
              "get_bool": "fmi2GetBoolean", "step": "fmi2DoStep"}
FMI3_CALLS = {"get_real": "fmi3GetFloat64", "set_real": "fmi3SetFloat64", "get_int": "fmi3GetInt32",
              "get_bool": "fmi3GetBoolean", "step": "fmi3DoStep"}
FMI3_TYPES = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "String": "String"}


def needed_to_run(member):
    """Whether an FMU archive member is needed to run the FMU here: everything but ``sources/``,
    ``documentation/`` and the binaries of other platforms (``binaries/linux64`` for FMI 2.0,
    ``binaries/x86_64-linux`` for FMI 3.0 are this platform's, as fmpy names them).  A native FMU
    carries three platforms' binaries and its C sources: skipping them makes its extraction about
    ten times faster."""
    if member.startswith(("sources/", "documentation/")):
        return False
    if member.startswith("binaries/"):
        parts = member.split("/")
        return len(parts) < 3 or parts[1] in (platform, platform_tuple)
    return True


def extract_owned(path):
    """Extract what the FMU ``path`` needs to run (:func:`needed_to_run`) into a new temporary
    directory; the caller removes it (:func:`remove_extracted`)."""
    return extract(str(path), unzipdir=tempfile.mkdtemp(prefix="satmotor-fmu-"), include=needed_to_run)


def remove_extracted(directory):
    shutil.rmtree(directory, ignore_errors=True)


def check(function, status):
    """Raise FMICallException, as fmpy does, for a status worse than fmi2Warning."""
    if status > 1:
        raise FMICallException(function=function, status=status)


class RealPort:
    """A fixed list of Real variables of one instance, read or written in one FMI call.

    :attr:`get_args` and :attr:`set_args` are the argument tuples of the fast ctypes calls
    ``FMUInstance.fast("fmi2GetReal")(*port.get_args)`` (the stepping loop's path, see
    :meth:`FMUInstance.fast`): each argument is the ctypes object of its C type (instance pointer,
    value-reference array, ``size_t`` count, value array, FMI 3.0: ``size_t`` nValues);
    :meth:`read` reads the values into :attr:`values` (initial values)."""

    def __init__(self, instance, names):
        self.names = tuple(names)
        self.n = len(self.names)
        self._vr = (fmi2ValueReference * self.n)(*instance.vr(self.names))
        self.values = (fmi2Real * self.n)()
        self._inst = instance
        n = c_size_t(self.n)
        args = (instance.handle, self._vr, n, self.values)
        self.get_args = self.set_args = args + (n,) if instance.fmi3 else args  # FMI 3: nValues
        self._get = instance.fast(instance.calls["get_real"])

    def read(self):
        r = self._get(*self.get_args)
        if r > 1:
            check(self._inst.calls["get_real"], r)
        return self.values


class DiscretePort:
    """The Integer and Boolean outputs of an instance (e.g. the controller's phase and limiter
    flags), read together after a step.

    The stepping loop calls the fast functions :attr:`get_int` and :attr:`get_bool` with
    :attr:`int_args` and :attr:`bool_args` (None when the instance has no output of that type) and
    takes the values from :attr:`int_values` and :attr:`bool_values`; :meth:`read` does the same and
    returns them in the order of :attr:`names` (Integers first, then Booleans)."""

    def __init__(self, instance, integers, booleans):
        self.names = tuple(integers) + tuple(booleans)
        ni, nb = len(integers), len(booleans)
        c = instance.handle
        int_t, bool_t = (c_int, c_bool) if instance.fmi3 else (fmi2Integer, fmi2Boolean)
        self.int_values, self.bool_values = (int_t * ni)(), (bool_t * nb)()
        vr_i = (fmi2ValueReference * ni)(*instance.vr(integers))
        vr_b = (fmi2ValueReference * nb)(*instance.vr(booleans))
        self.int_args = (c, vr_i, c_size_t(ni), self.int_values)
        self.bool_args = (c, vr_b, c_size_t(nb), self.bool_values)
        if instance.fmi3:  # nValues
            self.int_args, self.bool_args = self.int_args + (c_size_t(ni),), self.bool_args + (c_size_t(nb),)
        self.int_args, self.bool_args = (self.int_args if ni else None), (self.bool_args if nb else None)
        self.calls = instance.calls
        self.get_int = instance.fast(self.calls["get_int"])
        self.get_bool = instance.fast(self.calls["get_bool"])

    def read(self):
        """The values as a new list (Integers, then Booleans as bools or 0/1: the recorder stores them
        as float64 like every column)."""
        if self.int_args:
            r = self.get_int(*self.int_args)
            if r > 1:
                check(self.calls["get_int"], r)
        if self.bool_args:
            r = self.get_bool(*self.bool_args)
            if r > 1:
                check(self.calls["get_bool"], r)
        return self.int_values[:] + self.bool_values[:]


class UnitPool:
    """The FMU instances of one worker process, instantiated once and reset (:meth:`FMUInstance.reset`)
    for each run instead of instantiated anew (the master's ``pool``).  An instance is kept after its
    run unless it reached a fatal status; :meth:`close` frees them (before their unzip directories
    are removed)."""

    def __init__(self):
        self._units = {}

    def get(self, path, name, unzip_dir, md):
        """The instance ``name`` of the FMU ``path``: the kept one reset, else a new one."""
        u = self._units.pop(name, None)
        if u is not None and u.path == str(path) and u.unzip_dir == unzip_dir and not u.fatal:
            try:
                u.reset()
                return u
            except FMICallException:  # a reset refused: a new instance instead
                pass
        if u is not None:
            u.close()
        return FMUInstance(path, name, unzip_dir, md)

    def put(self, u):
        """After a run: keep ``u`` for the next one (closed instead after a fatal status)."""
        if u.fatal or u.slave is None:
            u.close()
        else:
            self._units[u.name] = u

    def close(self):
        for u in self._units.values():
            u.close()
        self._units.clear()


class FMUInstance:
    """An instantiated co-simulation FMU (logging on, messages kept in :attr:`messages`).

    Parameters
    ----------
    path : str or Path
        The .fmu file.
    instance_name : str
    unzip_dir : str, optional
        An already extracted copy (shared between instances of one FMU).
    """

    def __init__(self, path, instance_name, unzip_dir=None, md=None):
        self.path = str(path)
        self.name = instance_name
        self.md = read_model_description(self.path) if md is None else md  # md: read once by the caller
        self.fmi3 = self.md.fmiVersion.startswith("3")
        self.calls = FMI3_CALLS if self.fmi3 else FMI2_CALLS
        self._owned_dir = unzip_dir is None
        self.unzip_dir = extract_owned(self.path) if unzip_dir is None else unzip_dir
        self.variables = {v.name: v for v in self.md.modelVariables}
        self.messages = []
        self.initialized = False
        self.fatal = False  # after fmi2Fatal no FMI call is allowed, not even freeInstance
        self.slave = None
        self._token = next(_TOKENS)
        _ROUTES[self._token] = self
        self._callbacks = fmi2CallbackFunctions()
        self._callbacks.logger = _LOGGER
        self._callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self._callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self._callbacks.componentEnvironment = c_void_p(self._token)
        try:
            from fmpy.logging import addLoggerProxy

            addLoggerProxy(byref(self._callbacks))  # (re)points the proxy at _route
        except Exception:  # noqa: BLE001 - the proxy only formats variadic messages
            pass
        try:
            kind = FMU3Slave if self.fmi3 else FMU2Slave
            self.slave = kind(guid=self.md.guid, unzipDirectory=self.unzip_dir, instanceName=instance_name,
                              modelIdentifier=self.md.coSimulation.modelIdentifier)
            if self.fmi3:
                self.slave.instantiate(loggingOn=True, logMessage=self._log3)
            else:
                self.slave.instantiate(callbacks=self._callbacks, loggingOn=True)
            self.handle = c_void_p(self.slave.component)  # the instance pointer as a ctypes object
            if self.fmi3:  # the out-arguments of fmi3DoStep, made once
                self._step_out = tuple(byref(v) for v in (c_bool(), c_bool(), c_bool(), c_double()))
        except Exception as exc:
            self.slave = None
            self._remove_dir()
            detail = self.first_error() or "no message from the FMU (see the host's stderr)"
            raise RuntimeError(f"{self.md.modelName}: instantiation failed ({exc}): {detail}") from None

    def _log3(self, env, status, category, message):
        """FMI 3.0 log callback of this instance (not variadic: no proxy needed)."""
        text = message.decode("utf-8", "replace") if isinstance(message, bytes) else str(message)
        self.messages.append((STATUS[status] if 0 <= status < len(STATUS) else str(status), text))

    def declared_type(self, kind):
        """The type name this FMU declares for ``kind`` ('Real', 'Integer', 'Boolean', 'String')."""
        return FMI3_TYPES[kind] if self.fmi3 else kind

    def step_args(self, t, h):
        """``(doStep, args)``: the fast doStep of this instance's FMI version and its argument tuple,
        whose communication point and step size are the ctypes doubles ``t`` and ``h`` (the caller
        sets ``t.value`` before each call; the loop shares one ``t`` between the units)."""
        if self.fmi3:  # noSetFMUStatePriorToCurrentPoint, then the four out-arguments
            return self.fast(self.calls["step"]), (self.handle, t, h, c_bool(True), *self._step_out)
        return self.fast(self.calls["step"]), (self.handle, t, h, c_int(1))

    def first_error(self):
        """The first message logged with a discard, error or fatal status (else the last message),
        or ''."""
        for level, text in self.messages:
            if level in _FAILED:
                return text
        return self.messages[-1][1] if self.messages else ""

    def vr(self, names):
        """Value references of ``names``; KeyError names the variable and the FMU."""
        try:
            return [self.variables[n].valueReference for n in names]
        except KeyError as exc:
            raise KeyError(f"{self.md.modelName} has no variable {exc.args[0]!r}") from None

    def set_parameters(self, values):
        """Set start values ``{name: value}`` by the variables' declared types."""
        for name, value in values.items():
            var = self.variables[name] if name in self.variables else None
            if var is None:
                raise KeyError(f"{self.md.modelName} has no variable {name!r}")
            vr, s = [var.valueReference], self.slave
            if var.type in ("Real", "Float64"):
                (s.setFloat64 if self.fmi3 else s.setReal)(vr, [float(value)])
            elif var.type in ("Integer", "Int32"):
                (s.setInt32 if self.fmi3 else s.setInteger)(vr, [int(value)])
            elif var.type == "Boolean":
                s.setBoolean(vr, [bool(value)])
            else:
                s.setString(vr, [str(value)])

    def initialize(self, start_time):
        try:
            if self.fmi3:
                self.slave.enterInitializationMode(startTime=start_time)
            else:
                self.slave.setupExperiment(startTime=start_time)
                self.slave.enterInitializationMode()
            self.slave.exitInitializationMode()
        except FMICallException as exc:
            self.fatal = exc.status >= 4
            raise
        self.initialized = True

    def reset(self):
        """fmi2Reset / fmi3Reset: back to the state after instantiation (start values), the log emptied:
        the next run sets its parameters and initializes as a new instance would."""
        self.slave.reset()
        self.initialized = False
        self.messages.clear()

    def raw(self, function):
        """The ctypes function ``function`` (e.g. ``"fmi2DoStep"``) of this instance's library, as
        fmpy loaded it (argument types set), without fmpy's per-call wrapper: the caller checks the
        status (:func:`check`; :meth:`step_failed` for fmi2DoStep)."""
        return getattr(self.slave.dll, function)

    def fast(self, function):
        """A private ctypes function pointer to ``function`` returning the status as an int and
        declaring no argument types: the caller passes every argument as the ctypes object of its C
        type (``c_void_p``, ``c_size_t``, ``c_double``, arrays; see :class:`RealPort`), which ctypes
        passes without conversion.  fmpy's own pointer (:meth:`raw`) keeps its argument types."""
        fn = self.slave.dll[function]  # a new pointer object: fmpy's cached one is left alone
        fn.restype, fn.argtypes = c_int, None
        return fn

    def step_failed(self, status, t):
        """Raise the FMICallException of a failed fmi2DoStep at ``t``, tagged ``.unit`` (this
        instance's name) and ``.time`` (the communication point); remember a fatal status."""
        try:
            check(self.calls["step"], status)
        except FMICallException as exc:
            self.fatal = exc.status >= 4
            exc.unit, exc.time = self.name, t
            raise

    def do_step(self, t, h):
        """doStep; a failure raises as :meth:`step_failed` says."""
        fn, args = self.step_args(c_double(t), c_double(h))
        status = fn(*args)
        if status > 1:
            self.step_failed(status, t)

    def close(self):
        """Terminate (when initialized), free, and remove an extraction this instance owns; never
        raises.  After a fatal status the instance is left alone (FMI 2.0 allows no further call;
        pythonfmu 0.7.0 may crash on the free)."""
        if self.slave is not None and not self.fatal:
            try:
                if self.initialized:
                    self.slave.terminate()
            except FMICallException:
                pass
            try:
                self.slave.freeInstance()
            except Exception:  # noqa: BLE001 - freeing a failed instance must not mask the first error
                pass
        self.slave = None
        self._remove_dir()

    def _remove_dir(self):
        if self._owned_dir:
            self._owned_dir = False
            remove_extracted(self.unzip_dir)

"""One FMI 2.0 co-simulation FMU instance, driven through fmpy's low-level FMU2Slave API.

Value references are looked up by name in the model description; the FMU's log messages are
collected (logging on) so a failing call can be reported with the FMU's own words.  The per-step
calls go through prebuilt ctypes arrays (one allocation per instance, none per step).
"""

from __future__ import annotations

from ctypes import byref

from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    calloc,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    fmi2Real,
    fmi2ValueReference,
    free,
)

STATUS = ("ok", "warning", "discard", "error", "fatal", "pending")


class RealPort:
    """A fixed list of Real variables of one instance, read or written in one FMI call."""

    def __init__(self, instance, names):
        self.names = tuple(names)
        self.n = len(self.names)
        self._vr = (fmi2ValueReference * self.n)(*instance.vr(self.names))
        self.values = (fmi2Real * self.n)()
        self._inst = instance

    def write(self):
        s = self._inst.slave
        s.fmi2SetReal(s.component, self._vr, self.n, self.values)

    def read(self):
        s = self._inst.slave
        s.fmi2GetReal(s.component, self._vr, self.n, self.values)
        return self.values


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

    def __init__(self, path, instance_name, unzip_dir=None):
        self.path = str(path)
        self.name = instance_name
        self.md = read_model_description(self.path)
        self.unzip_dir = unzip_dir or extract(self.path)
        self.variables = {v.name: v for v in self.md.modelVariables}
        self.messages = []
        self._callbacks = fmi2CallbackFunctions()
        self._callbacks.logger = fmi2CallbackLoggerTYPE(self._log)
        self._callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self._callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        try:
            from fmpy.logging import addLoggerProxy

            addLoggerProxy(byref(self._callbacks))
        except Exception:  # noqa: BLE001 - the proxy only formats variadic messages
            pass
        self.slave = FMU2Slave(guid=self.md.guid, unzipDirectory=self.unzip_dir,
                               modelIdentifier=self.md.coSimulation.modelIdentifier,
                               instanceName=instance_name)
        self.initialized = False
        self.fatal = False  # after fmi2Fatal no FMI call is allowed, not even freeInstance
        try:
            self.slave.instantiate(callbacks=self._callbacks, loggingOn=True)
        except Exception as exc:
            detail = self.last_message() or "no message from the FMU (see the host's stderr)"
            raise RuntimeError(f"{self.md.modelName}: instantiation failed ({exc}): {detail}") from None

    def _log(self, env, instance, status, category, message):
        text = message.decode("utf-8", "replace") if isinstance(message, bytes) else str(message)
        self.messages.append((STATUS[status] if 0 <= status < len(STATUS) else str(status), text))

    def last_message(self):
        """The most severe (then latest) message the FMU logged, or ''."""
        if not self.messages:
            return ""
        order = {s: i for i, s in enumerate(STATUS)}
        return max(reversed(self.messages), key=lambda m: order.get(m[0], 0))[1]

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
            vr = [var.valueReference]
            if var.type == "Real":
                self.slave.setReal(vr, [float(value)])
            elif var.type == "Integer":
                self.slave.setInteger(vr, [int(value)])
            elif var.type == "Boolean":
                self.slave.setBoolean(vr, [bool(value)])
            else:
                self.slave.setString(vr, [str(value)])

    def initialize(self, start_time):
        try:
            self.slave.setupExperiment(startTime=start_time)
            self.slave.enterInitializationMode()
            self.slave.exitInitializationMode()
        except FMICallException as exc:
            self.fatal = exc.status >= 4
            raise
        self.initialized = True

    def do_step(self, t, h):
        try:
            self.slave.fmi2DoStep(self.slave.component, t, h, 1)
        except FMICallException as exc:
            self.fatal = exc.status >= 4
            raise

    def close(self):
        """Terminate (when initialized) and free; never raises.  After a fatal status the instance
        is left alone (FMI 2.0 allows no further call; pythonfmu 0.7.0 may crash on the free)."""
        if self.fatal:
            return
        try:
            if self.initialized:
                self.slave.terminate()
        except FMICallException:
            pass
        try:
            self.slave.freeInstance()
        except Exception:  # noqa: BLE001 - freeing a failed instance must not mask the first error
            pass

"""FMI glue shared by the two slaves: registration from the satmotor interface tables, the bundle
check, initialization, stepping and the full FMU state.  No equations here.

Bundled into each FMU next to ``satmotor/``.  pythonfmu imports every FMU's modules into one shared
interpreter, caching them by name; the slaves therefore check, at instantiation, that the
``satmotor`` and glue modules they got hash to the fingerprint baked in at build time.  That hash
is taken once, when this module is imported: the cached modules may come from an extraction
directory the host has deleted since (fmpy.simulate_fmu does), so nothing is read from disk later.

Statuses.  pythonfmu 0.7.0 turns any Python exception into fmi2Fatal and drops the Python instance
(a later call, even fmi2FreeInstance, may then crash the host); it ignores what set_*,
exit_initialization_mode, terminate and _set_fmu_state return (the host gets fmi2OK); only do_step
can report anything else: returning False gives fmi2Discard.  fmi2Error cannot be reached from
Python.  So a refusal here never raises: it logs a message naming the variable and the value
(status error), leaves the instance unchanged, and is reported again by the next doStep, which
returns fmi2Discard (the host may redo that step).
"""

from __future__ import annotations

import functools
import math
from pathlib import Path

from pythonfmu import Boolean, Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability, Integer, Real, String
from pythonfmu.enums import Fmi2Status

import satmotor

_INF = math.inf
INSTANTIATED, INITIALIZATION, STEPPING, TERMINATED = (
    "not initialized", "in initialization mode", "initialized", "terminated")

_TYPES = {"Real": Real, "Integer": Integer, "Boolean": Boolean, "String": String}
_CAUSALITY = {"input": Fmi2Causality.input, "output": Fmi2Causality.output,
              "parameter": Fmi2Causality.parameter}


_PINNED = []


def _source_fingerprint():
    try:
        return satmotor.source_fingerprint(Path(__file__).resolve())
    except OSError as exc:  # refused at instantiation (no build fingerprint can equal this)
        return f"unavailable ({exc})"


# SHA-256 over the loaded satmotor package and this module, taken once per process (see above)
_FINGERPRINT = _source_fingerprint()


def fingerprint():
    """SHA-256 over the sources of the loaded ``satmotor`` package and of this module, as they were
    when this module was imported."""
    return _FINGERPRINT


def pin_namespace(namespace, defined=None):
    """Call at a slave script's top level as ``pin_namespace(globals(), locals())``.

    pythonfmu 0.7.0's fmi2Instantiate (findClass) imports the slave module (cached by name across
    FMUs), re-executes this FMU's copy of the script with the module's dict as globals and a fresh
    dict as locals, Py_DECREFs the borrowed globals, and then takes the slave class from the *cached
    module*.  This keeps one more reference to the globals (without it the second instance of an
    FMU in one process crashes the host) and publishes the slave classes the script just defined
    (``defined``) into the module, so that the instance is made from this FMU's own script and its
    baked-in FINGERPRINT, not from the first one loaded under that module name."""
    _PINNED.append(namespace)
    if defined is not None and defined is not namespace:
        for name, obj in defined.items():
            if isinstance(obj, type) and issubclass(obj, UnitSlave) and obj is not UnitSlave:
                namespace[name] = obj


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
        if self.FINGERPRINT and _FINGERPRINT != self.FINGERPRINT:
            raise ImportError(
                f"{type(self).__name__}: the loaded satmotor ({satmotor.__file__}, version "
                f"{satmotor.__version__}) and glue are not the ones this FMU was built with (fingerprint "
                f"{_FINGERPRINT[:12]} != {self.FINGERPRINT[:12]}); another FMU of a different build is "
                f"loaded in this process")
        self._params = tuple(v.name for v in self.VARIABLES if v.causality == "parameter")
        self._inputs = tuple(v.name for v in self.VARIABLES if v.causality == "input")
        self._outputs = tuple(v.name for v in self.VARIABLES if v.causality == "output")
        self._unit = None
        self._phase = INSTANTIATED
        self._pending = []  # refusals not yet reported by a doStep
        self._go = False  # doStep may run: initialized, not terminated, no refusal pending
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

    # --- life cycle ------------------------------------------------------------------------------------

    def enter_initialization_mode(self):
        self._phase = INITIALIZATION

    def exit_initialization_mode(self):
        """Build the unit from the parameters; a bad value is logged (naming it) and refused."""
        try:
            self._unit = self.UNIT({name: getattr(self, name) for name in self._params})
        except Exception as exc:  # ParameterError, or a table file that cannot be read
            self.log(f"{type(self).__name__}: bad parameter: {exc}", Fmi2Status.error)
            raise
        self._publish()
        self._phase = STEPPING
        self._go = not self._pending
        # from now on fmi2Set* may change inputs only (fixed parameters, outputs: refused); the
        # setters are swapped once here, so setting inputs costs nothing more per step
        for var in self.vars.values():
            if var.causality != Fmi2Causality.input:
                var.setter = functools.partial(self._refuse_set, var.name)

    def terminate(self):
        self._phase = TERMINATED
        self._go = False

    def _refuse_set(self, name, value):
        what = "a fixed parameter" if name in self._params else "an output"
        self._refuse(f"{name}: {what} cannot be set after initialization ({name} = {value!r} refused, "
                     f"it stays {getattr(self, name)!r})")

    def _refuse(self, message):
        """Log a refused call (status error); the next doStep reports it again and discards."""
        self.log(f"{type(self).__name__}: {message}", Fmi2Status.error)
        self._pending.append(message)
        self._go = False

    # --- stepping ------------------------------------------------------------------------------------

    def do_step(self, current_time, step_size):
        """Advance the unit; a bad input or a failed step is logged and discarded, never raised."""
        if not (self._go and 0.0 < step_size < _INF and -_INF < current_time < _INF):
            return self._refuse_step(current_time, step_size)
        try:
            self._unit.step(current_time, step_size, tuple(getattr(self, n) for n in self._inputs))
        except Exception as exc:
            self.log(f"{type(self).__name__} at t = {current_time!r} s: {exc}", Fmi2Status.discard)
            return False
        self._publish()
        return True

    def _refuse_step(self, t, dt):
        """Why doStep(t, dt) cannot run, logged; False (fmi2Discard: see the module docstring)."""
        name = type(self).__name__
        if self._phase != STEPPING:
            self.log(f"{name}: doStep(currentCommunicationPoint = {t!r}, communicationStepSize = {dt!r}) "
                     f"refused: the FMU is {self._phase}; doStep is allowed only after "
                     f"exitInitializationMode and before terminate", Fmi2Status.error)
        elif self._pending:
            self.log(f"{name}: doStep at t = {t!r} s discarded: an earlier call was refused: "
                     f"{'; '.join(self._pending)}", Fmi2Status.error)
            self._pending.clear()
            self._go = True
        elif not 0.0 < dt < _INF:
            self.log(f"{name} at t = {t!r} s: communicationStepSize = {dt!r}: must be finite and > 0",
                     Fmi2Status.discard)
        else:
            self.log(f"{name}: currentCommunicationPoint = {t!r}: must be finite", Fmi2Status.discard)
        return False

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
        for name, value in state.items():  # not through the setters: restoring a state is no fmi2Set*
            setattr(self, name, value)
        if unit_state is not None:
            if self._unit is None:
                self._unit = self.UNIT({name: getattr(self, name) for name in self._params})
            self._unit.set_state(tuple(float(v) if isinstance(v, (int, float)) else math.nan
                                       for v in unit_state))

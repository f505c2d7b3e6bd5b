"""FMI glue shared by the two slaves: registration from the satmotor interface tables, the bundle
check, initialization, stepping and the full FMU state.  No equations here.

Bundled into each FMU next to ``satmotor/``.  pythonfmu imports every FMU's modules into one shared
interpreter, caching them by name; the slaves therefore check, at instantiation, that the
``satmotor`` and glue modules they got hash to the fingerprint baked in at build time.  That hash
is taken once, when this module is imported: the cached modules may come from an extraction
directory the host has deleted since (fmpy.simulate_fmu does), so nothing is read from disk later.
pythonfmu 0.7.0 does not pass the host's fmuGUID to Python; the slaves check instead that the
modelDescription.xml next to ``resources/`` carries the GUID the build wrote into
``resources/build_guid.txt``.  These two refusals raise in the constructor: pythonfmu logs the text
(fmi2Fatal) and fmi2Instantiate returns NULL.

Statuses. pythonfmu 0.7.0 turns any Python exception into fmi2Fatal and drops the Python instance (a
later call, even fmi2FreeInstance, may then crash the host); it ignores what set_*,
exit_initialization_mode, terminate and _set_fmu_state return (the host gets fmi2OK); only do_step
can report anything else: returning False gives fmi2Discard. fmi2Error cannot be reached from
Python. So no refusal after instantiation raises: bad parameters are logged by
exitInitializationMode (status error; the call returns fmi2OK) and every doStep then discards,
naming them; any later refusal logs a message naming the variable and the value (status error),
leaves the instance unchanged, and is reported again by the next doStep, which returns fmi2Discard
(the host may redo that step) -- unless a valid FMU state is set in between: the instance is then
exactly that state.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import struct
import weakref
import xml.etree.ElementTree as ET
from operator import itemgetter
from pathlib import Path

from pythonfmu import Boolean, Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability, Integer, Real, String
from pythonfmu.enums import Fmi2Status

import satmotor

_INF = math.inf
INSTANTIATED, INITIALIZATION, STEPPING, TERMINATED = (
    "not initialized", "in initialization mode", "initialized", "terminated")
REFUSED_PARAMETERS = "not initialized: exitInitializationMode refused its parameters"

_TAG, _UNIT, _REFUSED = "_tag", "_unit", "_refused"  # FMU state keys besides the variables
# A serialized state (fmi2SerializeFMUstate): a header, then the state as JSON.  The header: magic,
# format version, the model's name (NUL-padded), the length of the JSON and a SHA-256 over every header
# byte before it and the JSON (as the native glue's fmu/native/fmi/fg_state.c: any change of a byte
# is refused).  Format 1 (issue 31): before it a state was the bare JSON.
STATE_MAGIC = b"SMPYFMU\x00"
STATE_FORMAT = 1
_STATE_HEAD = struct.Struct("<8sI64sQ")  # magic, format version, model name, JSON length
_STATE_HEADER_SIZE = _STATE_HEAD.size + 32  # then the SHA-256 digest


def seal_state(model, payload):
    """The serialized form of a state: the header for ``model`` and ``payload`` (the JSON bytes)."""
    head = _STATE_HEAD.pack(STATE_MAGIC, STATE_FORMAT, model.encode("utf-8")[:63], len(payload))
    return head + hashlib.sha256(head + payload).digest() + payload


def unseal_state(model, data):
    """``(payload, None)`` of a serialized state of ``model``, or ``(None, why it is refused)``: checked
    whole (size, magic, format version, model, length, checksum) before anything of it is read."""
    n = len(data)
    if n < _STATE_HEADER_SIZE:
        return None, f"it is not valid: truncated ({n} bytes; the header alone is {_STATE_HEADER_SIZE})"
    magic, version, name, size = _STATE_HEAD.unpack_from(data)
    if magic != STATE_MAGIC:
        return None, "it is not valid: not a serialized state of a satmotor pythonfmu FMU (bad magic)"
    if version != STATE_FORMAT:
        return None, f"it is not valid: state format version {version}, this FMU reads version {STATE_FORMAT}"
    if name != model.encode("utf-8")[:63].ljust(64, b"\x00"):
        shown = name.rstrip(b"\x00").decode("utf-8", "replace")
        return None, f"it is a state of the model {shown!r}, this is {model!r}"
    if size != n - _STATE_HEADER_SIZE:
        return None, (f"it is not valid: truncated or extended: its header says {size} bytes of state, it "
                      f"has {n - _STATE_HEADER_SIZE}")
    payload = data[_STATE_HEADER_SIZE:]
    digest = data[_STATE_HEAD.size:_STATE_HEADER_SIZE]
    if hashlib.sha256(data[:_STATE_HEAD.size] + payload).digest() != digest:
        return None, "it is not valid: checksum mismatch (the state was changed or corrupted)"
    return payload, None
_PYTHON_TYPES = {"Real": (float, int), "Integer": (int,), "Boolean": (bool,), "String": (str,)}
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


def forget_search_path_entry(resources):
    """Undo the ``sys.path`` entry pythonfmu 0.7.0's fmi2Instantiate inserted for this instance.

    Its C++ constructor inserts the FMU's resources directory at ``sys.path[0]`` at every
    instantiation, before it imports the slave module and calls the slave class: 2000
    instantiations in one process left 2006 entries (each import then searched them all).  By the
    time the slave's constructor runs, the slave module, this glue and ``satmotor`` are imported
    (the package's submodules are found through ``satmotor.__path__``, not ``sys.path``), so the
    entry has done its work: the one at index 0, if it is this FMU's resources, is removed.  An
    entry anywhere else (put there by the host) is left alone; never raises.  Not called when
    pythonfmu's builder makes the slave (it inserts and removes the entry itself)."""
    import sys

    try:
        if resources and sys.path and sys.path[0] == resources:
            del sys.path[0]
    except Exception:  # noqa: BLE001 - housekeeping, never a reason to fail an instantiation
        pass


_GUIDS = {}
# in resources/: the GUID the build wrote into modelDescription.xml
# (orchestration.packaging.fmu_build.BUILD_GUID)
BUILD_GUID_FILE = "build_guid.txt"


def _guids(resources):
    """``(GUID in the modelDescription.xml next to resources, GUID in resources/build_guid.txt)``, ''
    for one that cannot be read; read once per directory."""
    if not resources:
        return "", ""
    guids = _GUIDS.get(resources)
    if guids is None:
        try:
            described = ET.parse(Path(resources).parent / "modelDescription.xml").getroot().get("guid", "")
        except (OSError, ET.ParseError):
            described = ""
        try:
            built = (Path(resources) / BUILD_GUID_FILE).read_text(encoding="utf-8").strip()
        except (OSError, UnicodeDecodeError):
            built = ""
        guids = _GUIDS[resources] = (described, built)
    return guids


def _guid(resources):
    """The GUID in the modelDescription.xml next to ``resources``, or ''."""
    return _guids(resources)[0]


def guid_problem(name, resources):
    """Why the FMU unpacked next to ``resources`` must not be instantiated: its modelDescription.xml
    carries another GUID than the one its build wrote (pythonfmu does not pass the host's fmuGUID to
    Python: this is the check left to the FMU); None when they agree or either cannot be read."""
    described, built = _guids(resources)
    if described and built and described != built:
        return (f"{name}: modelDescription.xml has guid {described}, but this FMU was built with guid "
                f"{built} ({BUILD_GUID_FILE} in its resources): the model description is not the one of "
                f"this build; instantiation refused")
    return None


def _picker(indices):
    """A function ``tuple -> tuple of its items at indices``, one C-level call: a slice when the
    indices are consecutive (one index or none included), else an itemgetter."""
    indices = list(indices)
    start = indices[0] if indices else 0
    if indices == list(range(start, start + len(indices))):
        return itemgetter(slice(start, start + len(indices)))
    return itemgetter(*indices)


_SLOTS = {}  # (sequence, i, name) -> property, made once per process (see _slot)


def _slot(sequence, i, name):
    """The attribute ``name`` of a slave as item ``i`` of its tuple ``sequence`` (``_in``: the inputs,
    ``_out``: the outputs); setting it makes a new tuple (initialization, fmi2Set of one input,
    restoring a state: never per step).  One property object per process for each (sequence, i,
    name): pythonfmu 0.7.0 executes the slave script, and so defines the slave class anew, at every
    instantiation, and keeps each class; they then share these instead of each holding its own."""
    key = (sequence, i, name)
    if key not in _SLOTS:
        _SLOTS[key] = _new_slot(sequence, i, name)
    return _SLOTS[key]


def _new_slot(sequence, i, name):

    def fget(self):
        return getattr(self, sequence)[i]

    def fset(self, value):
        old = tuple(getattr(self, sequence))
        setattr(self, sequence, old[:i] + (value,) + old[i + 1:])

    return property(fget, fset, doc=f"{name}: item {i} of {sequence}")


def _tag_text(tag):
    if not isinstance(tag, dict):
        return f"an untagged FMU (tag {tag!r:.60})"
    return f"{tag.get('model')} (build {str(tag.get('fingerprint'))[:12]}, guid {tag.get('guid')})"


def _describe(var):
    return f"{var.description} [{var.unit}]" if var.unit else var.description


class UnitSlave(Fmi2Slave):
    """Base of the two slaves.  Subclasses set VARIABLES (interface tables), UNIT (a satmotor
    interface unit class taking ``{parameter: value}``) and FINGERPRINT (filled in by the build).

    The inputs live in one tuple, ``_in`` (the order of the unit's INPUTS, as ``UNIT.step`` takes
    them), the outputs in another, ``_out`` (as ``UNIT.outputs()`` returns them); the attribute of
    each input or output is a view on its item (:func:`_slot`), so every path that reads or writes
    variables by name (pythonfmu's per-variable getters and setters, the FMU state) sees them, and a
    step moves no value into or out of attributes one by one.  Parameters are plain attributes."""

    VARIABLES = ()
    UNIT = None
    FINGERPRINT = ""

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        for sequence, causality in (("_in", "input"), ("_out", "output")):
            for i, var in enumerate(v for v in cls.VARIABLES if v.causality == causality):
                setattr(cls, var.name, _slot(sequence, i, var.name))

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        if "logger" in kwargs:  # made by the FMU binary's fmi2Instantiate (the build passes no logger)
            forget_search_path_entry(self.resources)  # see forget_search_path_entry
        guard_process_exit(self.resources)  # see guard_process_exit (end of file)
        if self.FINGERPRINT and _FINGERPRINT != self.FINGERPRINT:
            raise ImportError(
                f"{type(self).__name__}: the loaded satmotor ({satmotor.__file__}, version "
                f"{satmotor.__version__}) and glue are not the ones this FMU was built with (fingerprint "
                f"{_FINGERPRINT[:12]} != {self.FINGERPRINT[:12]}); another FMU of a different build is "
                f"loaded in this process")
        problem = guid_problem(type(self).__name__, self.resources)
        if problem:  # pythonfmu reports it as fmi2Fatal with this text; fmi2Instantiate returns NULL
            raise ValueError(problem)
        self._params = tuple(v.name for v in self.VARIABLES if v.causality == "parameter")
        self._in = tuple(v.start for v in self.VARIABLES if v.causality == "input")
        self._out = tuple(v.start for v in self.VARIABLES if v.causality == "output")
        self._unit = None
        self._phase = INSTANTIATED
        self._pending = []  # refusals not yet reported by a doStep
        self._go = False  # doStep may run: initialized, not terminated, no refusal pending
        self._kinds = {v.name: v.type for v in self.VARIABLES}
        # fmi2Get*/fmi2SetReal fast paths: tuple(vrs) -> plan (see get_real)
        self._gets = {Real: {}, Integer: {}, Boolean: {}}
        self._sets = {}
        self._identity = {"model": type(self).__name__, "fingerprint": self.FINGERPRINT or _FINGERPRINT,
                          "guid": _guid(self.resources)}
        type(self)._current = weakref.ref(self)  # for _fmu_state_from_bytes, called on the class
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
        """Build the unit from the parameters; a bad value is logged (naming it, status error) and
        refused: the instance stays uninitialized and every doStep returns fmi2Discard saying why.
        Not raised: pythonfmu would report fmi2Fatal and drop the Python instance, after which
        fmi2FreeInstance crashed the host (SIGSEGV, 2 of 4 runs of 10 instances); fmi2Error cannot
        be reached from Python (module docstring), so the call itself returns fmi2OK."""
        try:
            self._unit = self.UNIT({name: getattr(self, name) for name in self._params})
        except Exception as exc:  # ParameterError, or a table file that cannot be read
            self.log(f"{type(self).__name__}: bad parameter: {exc}", Fmi2Status.error)
            self._phase = f"{REFUSED_PARAMETERS} ({exc})"
            self._go = False
            return
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
        if message not in self._pending:  # a refused deserialization, then the same state set: once
            self._pending.append(message)
        self._go = False

    # --- stepping ------------------------------------------------------------------------------------

    def do_step(self, current_time, step_size):
        """Advance the unit; a bad input or a failed step is logged and discarded, never raised."""
        if not (self._go and 0.0 < step_size < _INF and -_INF < current_time < _INF):
            return self._refuse_step(current_time, step_size)
        unit = self._unit
        try:
            unit.step(current_time, step_size, self._in)
            self._out = unit.outputs()
        except Exception as exc:
            self.log(f"{type(self).__name__} at t = {current_time!r} s: {exc}", Fmi2Status.discard)
            return False
        warnings = getattr(unit, "warnings", None)  # the plant's plausibility warnings, once each
        while warnings:
            self.log(warnings.pop(0), Fmi2Status.warning)
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
        self._out = self._unit.outputs()

    # --- fmi2GetReal / fmi2SetReal (and fmi2GetInteger / fmi2GetBoolean) ------------------------------
    # pythonfmu's get_real/set_real call a Python getter or setter per variable.  Here a list of value
    # references seen before is served by a plan made once for it: a list of outputs of one type is
    # picked from ``_out`` in one C-level call (a slice or an itemgetter) and returned as they are (the
    # unit's outputs are float, int and bool as declared; pythonfmu converts them in C); a list of Real
    # inputs replaces ``_in`` (all of them in the unit's order: the values, as a tuple; else one pick
    # from the old inputs followed by the new values).  Any other list (parameters, inputs read back,
    # outputs set, a value reference of another type or unknown, a length mismatch) takes pythonfmu's
    # per-variable path, with its setters (swapped by exit_initialization_mode), its errors and its
    # order of effects.

    _MAX_PLANS = 64

    def _vars_of(self, key, kind, causality):
        """The variables of ``key`` when all are of ``kind`` and ``causality``, else None."""
        found = []
        for vr in key:
            var = self.vars.get(vr)
            if not isinstance(var, kind) or var.causality != causality:
                return None
            found.append(var)
        return found

    def _slots(self, causality):
        """``{name: index in _in or _out}`` of the variables of ``causality``."""
        return {v.name: i for i, v in enumerate(v for v in self.VARIABLES if v.causality == causality)}

    def _get_plan(self, key, kind):
        found = self._vars_of(key, kind, Fmi2Causality.output)
        if found is None:
            return False
        slots = self._slots("output")
        return _picker(slots[v.name] for v in found)

    def _set_plan(self, key):
        found = self._vars_of(key, Real, Fmi2Causality.input)
        if found is None:
            return False
        slots = self._slots("input")
        n = len(slots)
        if [slots[v.name] for v in found] == list(range(n)):
            return True  # every input, in the unit's order
        source = list(range(n))  # item i of the new _in: in old _in + values (the last one set wins)
        for j, var in enumerate(found):
            source[slots[var.name]] = n + j
        return _picker(source)

    def _fast_get(kind, fallback):  # noqa: N805 - builds the methods below, at class creation
        def get(self, vrs):
            key = tuple(vrs)
            plans = self._gets[kind]
            pick = plans.get(key)
            if pick is None:
                if len(plans) >= self._MAX_PLANS:
                    plans.clear()
                pick = plans[key] = self._get_plan(key, kind)
            if pick is False:
                return fallback(self, vrs)
            return list(pick(self._out))

        get.__name__ = fallback.__name__
        get.__doc__ = f"{fallback.__name__}: outputs picked from _out by a plan, else pythonfmu's path."
        return get

    get_real = _fast_get(Real, Fmi2Slave.get_real)
    get_integer = _fast_get(Integer, Fmi2Slave.get_integer)  # the controller's phase
    get_boolean = _fast_get(Boolean, Fmi2Slave.get_boolean)  # the controller's limiter flags
    del _fast_get

    def set_real(self, vrs, values):
        key = tuple(vrs)
        plan = self._sets.get(key)
        if plan is None:
            if len(self._sets) >= self._MAX_PLANS:
                self._sets.clear()
            plan = self._sets[key] = self._set_plan(key)
        if plan is False or len(values) != len(key):
            return super().set_real(vrs, values)
        self._in = tuple(values) if plan is True else plan(self._in + tuple(values))
        return None

    # --- FMU state -----------------------------------------------------------------------------------
    # A state is a dict: every variable by name, _UNIT (the unit's flat state, None before
    # initialization) and _TAG (this FMU's identity and the unit state's length).  A state of another
    # FMU (all pythonfmu FMUs of a process share one interpreter, so the host can hand one over), of
    # another build, or a malformed one is refused with the instance unchanged.

    def _get_fmu_state(self):
        state = {name: getattr(self, name) for name in self._kinds}
        unit = None if self._unit is None else list(self._unit.get_state())
        state[_TAG] = dict(self._identity, size=None if unit is None else len(unit))
        state[_UNIT] = unit
        return state

    def _set_fmu_state(self, state):
        try:
            problem = self._state_problem(state) or self._restore(state)
        except Exception as exc:  # never into pythonfmu (fmi2Fatal); _restore changes nothing before
            problem = f"{type(exc).__name__}: {exc}"  # its last, infallible lines
        if problem:
            self._refuse(f"setFMUState refused, the instance is unchanged: {problem}")
        else:  # the instance is now exactly the state the host set: earlier refusals no longer matter
            self._pending.clear()
            self._go = self._phase == STEPPING

    def _state_problem(self, state):
        """Why ``state`` is not a state of this FMU, or None."""
        if not isinstance(state, dict):
            return f"not an FMU state of {type(self).__name__} but a {type(state).__name__}"
        if _REFUSED in state:
            return str(state[_REFUSED])
        tag = state.get(_TAG)
        if not isinstance(tag, dict) or any(tag.get(k) != v for k, v in self._identity.items()):
            return f"it is a state of {_tag_text(tag)}, this is {_tag_text(self._identity)}"
        names = set(state) - {_TAG, _UNIT}
        if names != set(self._kinds):
            return (f"variables missing: {sorted(set(self._kinds) - names)}, "
                    f"unknown: {sorted(names - set(self._kinds))}")
        for name, kind in self._kinds.items():
            if type(state[name]) not in _PYTHON_TYPES[kind]:
                return f"{name} = {state[name]!r} is not a {kind}"
        unit = state.get(_UNIT)
        if unit is None:
            if tag.get("size") is not None:
                return f"it has no unit state, but its tag says {tag['size']!r} entries"
            return None
        if not isinstance(unit, list) or len(unit) != tag.get("size"):
            return (f"the unit state has {len(unit) if isinstance(unit, list) else repr(unit)} entries, "
                    f"its tag says {tag.get('size')!r}")
        for i, v in enumerate(unit):
            if type(v) not in (float, int) or not math.isfinite(v):
                return f"unit state entry {i} = {v!r} is not a finite number"
        return None

    def _restore(self, state):
        """Adopt a state that passed _state_problem; returns why not, changing nothing, or None."""
        values = {name: state[name] for name in self._kinds}
        unit_state, unit = state.get(_UNIT), None
        if unit_state is None:
            if self._phase in (STEPPING, TERMINATED):
                return "it was taken before initialization, and this instance is initialized"
        else:
            unit = self._unit
            params = {name: values[name] for name in self._params}
            if unit is None or any(getattr(self, name) != value for name, value in params.items()):
                try:  # a state of another instance of this FMU, with other parameters
                    unit = self.UNIT(params)
                except Exception as exc:
                    return f"its parameters are refused: {exc}"
            want = len(unit.get_state())
            if len(unit_state) != want:
                return (f"its unit state has {len(unit_state)} entries, {type(self).__name__} with its "
                        f"parameters has {want}")
            old = unit.get_state()
            try:
                unit.set_state(tuple(float(v) for v in unit_state))
            except Exception as exc:
                unit.set_state(old)
                return f"its unit state is refused: {exc}"
        for name, value in values.items():  # not through the setters: restoring a state is no fmi2Set*
            setattr(self, name, value)
        self._unit = unit
        if unit is not None:
            self._publish()
        return None

    @staticmethod
    def _fmu_state_to_bytes(state):
        """The state sealed (:func:`seal_state`) under its model's name; never raises (fmi2Fatal)."""
        tag = state.get(_TAG) if isinstance(state, dict) else None
        model = str(tag.get("model", "")) if isinstance(tag, dict) else ""
        try:
            payload = json.dumps(state).encode("utf-8")
        except Exception as exc:  # deserialized, this state is refused
            payload = json.dumps({_REFUSED: f"the FMU state could not be serialized: {exc}"}).encode("utf-8")
        return seal_state(model, payload)

    @classmethod
    def _fmu_state_from_bytes(cls, data):
        """Called by pythonfmu on the instance's class: never raises (fmi2Fatal).  A blob that is not
        a state of this FMU (another model, format version or build, corrupted: the checksum) becomes
        a refusal, logged at once through the instance (pin_namespace gives each instance a class of
        its own) and reported again by the next doStep, which is discarded (pythonfmu returns fmi2OK
        from deSerializeFMUstate); setFMUState of it is refused too."""
        ref = cls.__dict__.get("_current")
        inst = ref() if ref is not None else None
        try:
            data = bytes(data)
            payload, problem = unseal_state(cls.__name__, data)
            if problem is None:
                state = json.loads(payload.decode("utf-8"))
                problem = inst._state_problem(state) if inst is not None else None
        except Exception as exc:  # not UTF-8, not JSON, nested too deep, ...
            problem = f"it is not valid ({type(exc).__name__}: {exc})"
        if problem:
            state = {_REFUSED: f"the serialized FMU state ({len(data)} bytes) is refused: {problem}"}
            if inst is not None:
                inst._refuse(f"deSerializeFMUstate: {state[_REFUSED]}")
        return state


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

"""FMI harness for tests/test_fmu.py: one fmpy low-level instance with its own log, and the
child-process checks (run as ``python fmu_helpers.py MODE ...``; no satmotor import here, so a
child starts with nothing cached but what its FMUs load)."""

from __future__ import annotations

import gc
import hashlib
import json
import re
import struct
import sys
import zipfile
from typing import NamedTuple

from fmpy import calloc, extract, free, read_model_description
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)


class Fmu(NamedTuple):
    path: str
    unzip: str
    md: object


def open_fmu(path, unzip=None):
    return Fmu(str(path), extract(str(path), unzipdir=unzip), read_model_description(str(path)))


class Slave:
    """An instance of ``fmu`` (fmpy FMU2Slave, loggingOn) with name-based access and a log of
    ``(status, message)`` (``log``: a list to append to, kept if instantiation fails); initialized
    with ``params`` unless ``initialize`` is False."""

    def __init__(self, fmu, name="inst", params=None, initialize=True, log=None):
        self.vars = {v.name: v for v in fmu.md.modelVariables}
        self.log = [] if log is None else log
        self.dead = False  # after fmi2Fatal: no further call (pythonfmu 0.7.0 crashes on a later free)
        self._cb = fmi2CallbackFunctions()
        self._cb.logger = fmi2CallbackLoggerTYPE(self._logger)
        self._cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self._cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self.fmu = FMU2Slave(guid=fmu.md.guid, unzipDirectory=fmu.unzip, instanceName=name,
                             modelIdentifier=fmu.md.coSimulation.modelIdentifier)
        self.fmu.instantiate(callbacks=self._cb, loggingOn=True)
        if initialize:
            self.initialize(params)

    def _logger(self, env, instance, status, category, message):
        self.log.append((status, (message or b"").decode("utf-8", "replace")))

    def messages(self, min_status=0):
        return "\n".join(m for s, m in self.log if s >= min_status)

    def set(self, values):
        for name, value in values.items():
            v = self.vars[name]
            setter = {"Real": self.fmu.setReal, "Integer": self.fmu.setInteger,
                      "String": self.fmu.setString, "Boolean": self.fmu.setBoolean}[v.type]
            setter([v.valueReference], [value])

    def initialize(self, params=None, t0=0.0):
        self.set(params or {})
        self.fmu.setupExperiment(startTime=t0)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def get(self, names):
        """Values of ``names`` (Reals in one call; Integer/Boolean outputs by their own type, as floats)."""
        if all(self.vars[n].type == "Real" for n in names):
            return self.fmu.getReal([self.vars[n].valueReference for n in names])
        return [float(self.value(n)) for n in names]

    def value(self, name):
        """One variable's value, read by its declared type."""
        v = self.vars[name]
        getter = {"Real": self.fmu.getReal, "Integer": self.fmu.getInteger,
                  "String": self.fmu.getString, "Boolean": self.fmu.getBoolean}[v.type]
        value = getter([v.valueReference])[0]
        return value.decode() if isinstance(value, bytes) else value

    def step(self, t, dt, inputs=None):
        self.set(inputs or {})
        self.fmu.doStep(t, dt)

    def free(self):
        self.fmu.freeInstance()


def tamper_fingerprint(src, dst):
    """Copy of the plant FMU whose slave script carries another 64-hex FINGERPRINT."""
    with zipfile.ZipFile(src) as z:
        files = {n: z.read(n) for n in z.namelist()}
    script = files["resources/satmotor_plant_fmu.py"].decode()
    fp = re.search(r'FINGERPRINT = "([0-9a-f]{64})"', script).group(1)
    files["resources/satmotor_plant_fmu.py"] = script.replace(fp, fp[::-1]).encode()
    with zipfile.ZipFile(dst, "w") as z:
        for n, data in files.items():
            z.writestr(n, data)


def _child_repeat(paths):
    """Three instances of each FMU in this process, one step each."""
    for path in paths:
        fmu = open_fmu(path)
        keep = []
        for i in range(3):
            s = Slave(fmu, f"i{i}")
            s.fmu.doStep(0.0, 1e-4)
            keep.append(s)
            gc.collect()
        for s in keep:  # an FMI host frees its instances (exiting with live ones is not covered)
            s.free()
    print(json.dumps({"ok": True}))


def _child_tamper(tampered, controller, genuine_first=None):
    """Instantiate the tampered plant (after the genuine one if given), then run the controller."""
    out = {"instantiated": False, "error": "", "log": ""}
    if genuine_first:
        genuine = Slave(open_fmu(genuine_first), "genuine")
        genuine.fmu.doStep(0.0, 1e-4)
    log = []
    try:
        Slave(open_fmu(tampered), "tampered", initialize=False, log=log)
        out["instantiated"] = True
    except Exception as exc:  # fmpy: "Failed to instantiate model"
        out["error"] = repr(exc)
    out["log"] = "\n".join(m for _, m in log)
    c = Slave(open_fmu(controller), "controller")
    c.step(0.0, 1e-4, {"psi_ref": 0.9})
    out["alive"] = c.get(["v_s_alpha"])[0] > 0.0
    c.free()
    if genuine_first:
        genuine.free()
    print(json.dumps(out))


SIM_STEPS = 20  # of 1e-4 s, from the start values below (plant, controller) and the other defaults
SIM_START = ({"v_s_alpha": 100.0}, {"psi_ref": 0.9})


def _child_simulate(paths, runs=3):
    """fmpy.simulate_fmu ``runs`` times per FMU in this process, the FMUs taking turns (each run
    extracts the FMU into a new temporary directory and deletes it afterwards).  Per run: the
    exception if any, and the outputs at the last communication point."""
    from fmpy import simulate_fmu

    out = {path: [] for path in paths}
    for _ in range(runs):
        for path in paths:
            try:
                res = simulate_fmu(path, start_time=0.0, stop_time=SIM_STEPS * 1e-4, output_interval=1e-4,
                                   start_values=SIM_START["Controller" in path])
                out[path].append({"error": "", "last": {n: float(res[n][-1]) for n in res.dtype.names}})
            except Exception as exc:  # fmpy: "Failed to instantiate model" and the like
                out[path].append({"error": repr(exc), "last": None})
    print(json.dumps(out))


STATE_STEPS = 5  # plant steps of 1e-4 s at STATE_INPUTS before the states are taken
STATE_INPUTS = {"v_s_alpha": 100.0, "v_s_beta": 0.0, "T_load": 0.0}


# a pythonfmu FMU's serialized state, written out here from its documented format (satmotor_fmu_glue:
# magic, format version, model name, JSON length, SHA-256 of all of it before the digest and the JSON)
STATE_HEAD = struct.Struct("<8sI64sQ")
STATE_HEADER_SIZE = STATE_HEAD.size + 32


def seal(model, payload, version=1, magic=b"SMPYFMU\x00"):
    """``payload`` (JSON bytes) as the serialized state of ``model`` (format ``version``)."""
    head = STATE_HEAD.pack(magic, version, model.encode(), len(payload))
    return head + hashlib.sha256(head + payload).digest() + payload


def unseal(blob):
    """``(model, version, payload)`` of a serialized state (the checksum not checked)."""
    _, version, name, _ = STATE_HEAD.unpack_from(blob)
    return name.rstrip(b"\x00").decode(), version, blob[STATE_HEADER_SIZE:]


def _forged(blob, change):
    """``blob`` (a serialized state) with ``change(state)`` applied to its JSON, sealed again."""
    model, _, payload = unseal(blob)
    state = json.loads(payload)
    change(state)
    return seal(model, json.dumps(state).encode())


def _status(f, *args):
    try:
        return 0, f(*args)
    except Exception as exc:  # fmpy's FMICallException carries the status
        return getattr(exc, "status", repr(exc)), None


def _child_state(plant_path, controller_path):
    """Foreign and malformed FMU states handed to a plant (and one to a controller) that has run
    STATE_STEPS steps.  Per attempt: the statuses of deSerializeFMUstate / setFMUState, the messages
    (status >= error) they and the next doStep logged, whether the outputs stayed, the status of that
    doStep and of the same step redone, and the outputs after it.  Each attempt advances one step."""
    plant = Slave(open_fmu(plant_path), "plant")
    ctrl = Slave(open_fmu(controller_path), "ctrl")
    h, ctrl_in = 1e-4, {"psi_ref": 0.9}
    for k in range(STATE_STEPS):
        plant.step(k * h, h, STATE_INPUTS)
        ctrl.step(k * h, h, ctrl_in)
    own = plant.fmu.getFMUState()
    own_blob = bytes(plant.fmu.serializeFMUState(own))
    foreign = ctrl.fmu.getFMUState()
    foreign_blob = bytes(ctrl.fmu.serializeFMUState(foreign))
    steps = {"plant": STATE_STEPS, "ctrl": STATE_STEPS}
    out = {}

    def attempt(label, s, inputs, blob=None, state=None):
        key = "plant" if s is plant else "ctrl"
        outs = [n for n, v in s.vars.items() if v.causality == "output"]
        n, before, r = len(s.log), s.get(outs), {}
        if blob is not None:
            r["deserialize"], state = _status(s.fmu.deSerializeFMUstate, blob)
        if state is not None:
            r["set"], _ = _status(s.fmu.setFMUState, state)
        r["unchanged"] = s.get(outs) == before
        k = steps[key]
        s.set(inputs)
        r["step"], _ = _status(s.fmu.doStep, k * h, h)
        r["redo"], _ = _status(s.fmu.doStep, k * h, h) if r["step"] != 0 else (None, None)
        steps[key] += 1
        r["log"] = "\n".join(m for status, m in s.log[n:] if status >= 3)
        r["k"], r["outputs"] = steps[key], dict(zip(outs, s.get(outs)))
        if blob is not None and state is not None:
            s.fmu.freeFMUState(state)
        out[label] = r

    def plant_blob(label, blob):
        attempt(label, plant, STATE_INPUTS, blob=blob)

    def forged(label, change):
        plant_blob(label, _forged(own_blob, change))

    attempt("controller state", plant, STATE_INPUTS, state=foreign)
    plant_blob("controller blob", foreign_blob)
    plant_blob("truncated", own_blob[: len(own_blob) // 2])
    plant_blob("garbled", bytes(range(256)))
    plant_blob("empty", b"")
    plant_blob("not an object", seal("SaturatedInductionMotor", b"[1.0, 2.0]"))
    forged("non-numeric entry", lambda st: st["_unit"].__setitem__(0, "x"))
    forged("null entry", lambda st: st["_unit"].__setitem__(1, None))
    forged("entry missing", lambda st: st["_unit"].pop())
    forged("entry missing, tag adjusted",
           lambda st: (st["_unit"].pop(), st["_tag"].update(size=st["_tag"]["size"] - 1)))
    forged("other build", lambda st: st["_tag"].update(fingerprint=st["_tag"]["fingerprint"][::-1]))
    forged("other guid", lambda st: st["_tag"].update(guid="{0}"))
    forged("untagged", lambda st: st.pop("_tag"))
    attempt("plant state", ctrl, ctrl_in, state=own)
    # the genuine state, set and deserialized, still goes back to step STATE_STEPS
    steps["plant"] = STATE_STEPS
    attempt("own state", plant, STATE_INPUTS, state=own)
    steps["plant"] = STATE_STEPS
    attempt("own blob", plant, STATE_INPUTS, blob=own_blob)
    plant.fmu.freeFMUState(own)
    ctrl.fmu.freeFMUState(foreign)
    plant.free()
    ctrl.free()
    print(json.dumps(out))


if __name__ == "__main__":
    if sys.argv[1] == "repeat":
        _child_repeat(sys.argv[2:])
    elif sys.argv[1] == "simulate":
        _child_simulate(sys.argv[2:])
    elif sys.argv[1] == "state":
        _child_state(*sys.argv[2:])
    else:
        _child_tamper(*sys.argv[2:])

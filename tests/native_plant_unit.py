"""Test helper: the plant unit of the native core (``fmu/native/core/sm_plant_unit.c``) through ctypes,
on the library of :mod:`native_core`: :class:`CPlantUnit` has the methods of
``satmotor.interface.PlantUnit`` (``step``, ``outputs``, ``get_state``, ``set_state``, ``warnings``),
errors raised as ``CUnitError`` with the core's status and message."""

from __future__ import annotations

import ctypes

import native_core
from native_core import DCLinkParams, MotorParams, PlantParams, params

from satmotor.interface import PLANT_INPUTS, PLANT_OUTPUTS

N_IN, N_OUT = len(PLANT_INPUTS), len(PLANT_OUTPUTS)
MSG_LEN = 256
MAX_WARNINGS = 4
STATE_MAX = 11 + 2 + 2 + 6 + 17  # SM_PLANT_STATE_MAX


class CUnitError(Exception):
    def __init__(self, status, message):
        super().__init__(f"status {status}: {message}")
        self.status, self.message = status, message


def declare(lib):
    """The unit's signatures on the core library ``lib``, read from its header (native_core.declare:
    none typed here); returns lib."""
    return native_core.declare(lib)


class CPlantUnit:
    """``PlantUnit(values)`` on the C core (``values``: flat parameters by name, as PlantUnit's)."""

    def __init__(self, lib, values):
        self.lib = declare(lib)
        self.buf = (ctypes.c_double * ((lib.sm_plant_unit_size() + 7) // 8))()  # 8-byte aligned, zeroed
        off = (ctypes.c_size_t * 3)()
        lib.sm_plant_unit_offsets(off)
        self._off = tuple(off)
        self._msg = ctypes.create_string_buffer(MSG_LEN)
        self.warnings = []
        structs = (params(lib, s, values) for s in (MotorParams, PlantParams, DCLinkParams))
        st = lib.sm_plant_unit_init(self.buf, *structs, self._msg, MSG_LEN)
        if st != 0:
            raise CUnitError(st, self._msg.value.decode())

    def _take_warnings(self):
        base = ctypes.addressof(self.buf)
        n = ctypes.c_int.from_address(base + self._off[1])
        for k in range(n.value):
            self.warnings.append(ctypes.string_at(base + self._off[2] + k * MSG_LEN).decode())
        n.value = 0

    def step(self, t, dt, inputs):
        arr = (ctypes.c_double * N_IN)(*inputs)
        st = self.lib.sm_plant_unit_step(self.buf, t, dt, arr, self._msg, MSG_LEN)
        self._take_warnings()
        if st != 0:
            raise CUnitError(st, self._msg.value.decode())

    def outputs(self):
        return tuple((ctypes.c_double * N_OUT).from_address(ctypes.addressof(self.buf) + self._off[0]))

    def derivatives(self, t, x, inputs):
        n = len(x)
        dx = (ctypes.c_double * n)()
        st = self.lib.sm_plant_unit_derivatives(self.buf, t, (ctypes.c_double * n)(*x),
                                                (ctypes.c_double * N_IN)(*inputs), dx)
        if st != 0:
            raise CUnitError(st, "no derivatives")
        return tuple(dx)

    def get_state(self):
        s = (ctypes.c_double * STATE_MAX)()
        n = self.lib.sm_plant_unit_get_state(self.buf, s, STATE_MAX)
        assert n == self.lib.sm_plant_unit_state_size(self.buf)
        return tuple(s[:n])

    def set_state(self, state):
        st = self.lib.sm_plant_unit_set_state(self.buf, (ctypes.c_double * len(state))(*state), len(state))
        if st != 0:
            raise CUnitError(st, "set_state refused")

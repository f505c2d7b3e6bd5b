"""Test helper: the native core (``fmu/native/core/*.c`` and its generated ``sm_params.h`` / ``.c``)
compiled with gcc into one shared library, loaded with ctypes, argument types declared.  One build per
flag set per pytest session.  Extra compiler flags (appended) from the environment variable
``SM_CORE_EXTRA_CFLAGS``.  The parameter structs (:data:`MotorParams`, :data:`PlantParams`,
:data:`ControllerParams`) are ctypes structures whose fields are read from the generator's table
(:func:`orchestration.build.native.tables.struct_members`), as the C structs are generated from it."""

from __future__ import annotations

import ctypes
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

from orchestration.build.native import tables as native_tables

CORE = Path(__file__).resolve().parents[1] / "fmu" / "native" / "core"
FLAGS = ["-std=c99", "-O2", "-fPIC", "-shared", "-Wall", "-Wextra", "-Werror", "-pedantic", "-Wconversion",
         "-Wshadow"]
SANITIZE = ["-fsanitize=address,undefined", "-fno-sanitize-recover=undefined", "-fno-omit-frame-pointer",
            "-g"]
SM_TABLE_MAX = 512

_cache: dict = {}

D, I, P, S = ctypes.c_double, ctypes.c_int, ctypes.POINTER(ctypes.c_double), ctypes.c_size_t
C = ctypes.c_char_p


class Outputs(ctypes.Structure):
    _fields_ = [(n, ctypes.c_double) for n in ("i_s_alpha", "i_s_beta", "i_r_alpha", "i_r_beta", "i_mu_alpha",
                                                "i_mu_beta", "i_mu", "psi_m", "m", "T_e", "P_fe", "T_s",
                                                "T_r")]


_CTYPES = {"Real": ctypes.c_double, "Integer": ctypes.c_int, "Boolean": ctypes.c_int}


def _params_struct(c_struct):
    fields = [(n, ctypes.c_char * native_tables.STRING_MAX if t == "String" else _CTYPES[t])
              for n, t in native_tables.struct_members(c_struct)]
    return type(f"sm_{c_struct}_params", (ctypes.Structure,), {"_fields_": fields})


MotorParams, PlantParams, ControllerParams, DCLinkParams = (
    _params_struct(s) for s in ("motor", "plant", "controller", "dclink"))


def params(lib, struct, values=None):
    """A ``struct`` (one of the parameter structs) with the C defaults (``sm_<s>_params_default``),
    then the members named in ``values`` set (the other names ignored; str: encoded)."""
    p = struct()
    getattr(lib, struct.__name__ + "_default")(ctypes.byref(p))
    members = {n for n, _ in struct._fields_}
    for name, value in (values or {}).items():
        if name in members:
            setattr(p, name, value.encode() if isinstance(value, str) else value)
    return p


def build(extra_flags=(), out_dir=None):
    """Compile every ``fmu/native/core/*.c`` with the generated ``sm_params.c`` into one shared
    library; return its path."""
    gcc = shutil.which("gcc")
    if gcc is None:
        raise RuntimeError("gcc not found")
    out_dir = Path(out_dir or tempfile.mkdtemp(prefix="sm_native_core_"))
    lib = out_dir / ("libsmcore_san.so" if extra_flags else "libsmcore.so")
    gen = out_dir / ("generated_san" if extra_flags else "generated")
    gen.mkdir(exist_ok=True)
    generated = native_tables.core_files(gen)
    sources = sorted(str(p) for p in CORE.glob("*.c")) + [str(p) for p in generated if p.suffix == ".c"]
    env_flags = os.environ.get("SM_CORE_EXTRA_CFLAGS", "").split()  # e.g. "-O3 -march=native"
    cmd = [gcc, *FLAGS, *env_flags, *extra_flags, f"-I{gen}", f"-I{CORE}", "-o", str(lib), *sources, "-lm"]
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise RuntimeError(f"native core build failed:\n{' '.join(cmd)}\n{res.stderr}")
    return lib


def declare(lib):
    """Set the ctypes signatures of the public functions; returns lib."""
    sig = {
        "sm_curve_init": (I, [ctypes.c_void_p, C, D, D, D, D, I, C, ctypes.c_char_p, S]),
        "sm_curve_init_table": (I, [ctypes.c_void_p, P, P, I, ctypes.c_char_p, S]),
        "sm_curve_psi": (D, [ctypes.c_void_p, D]),
        "sm_curve_m": (D, [ctypes.c_void_p, D]),
        "sm_curve_dm_dI": (D, [ctypes.c_void_p, D]),
        "sm_curve_L_dyn": (D, [ctypes.c_void_p, D]),
        "sm_curve_evaluate": (None, [ctypes.c_void_p, D, P, P, P, P]),
        "sm_curve_current": (I, [ctypes.c_void_p, D, P]),
        "sm_curve_solve": (I, [ctypes.c_void_p, D, D, P, P]),
        "sm_curve_solve_from": (I, [ctypes.c_void_p, D, D, D, P, P]),
        "sm_inductance_matrix": (None, [D, D, D, D, D, P, P, P]),
        "sm_hypot": (D, [D, D]),
        "sm_atan": (D, [D]),
        "sm_atan2": (D, [D, D]),
        "sm_curve_size": (S, []),
        "sm_motor_size": (S, []),
        "sm_repr_double": (ctypes.c_char_p, [D, ctypes.c_char_p, S]),
        "sm_motor_init": (I, [ctypes.c_void_p, ctypes.POINTER(MotorParams), ctypes.POINTER(PlantParams),
                              ctypes.c_char_p, S]),
        "sm_plant_derivatives": (I, [ctypes.c_void_p, P, D, D, D, P]),
        "sm_plant_outputs_of": (I, [ctypes.c_void_p, P, ctypes.POINTER(Outputs)]),
        "sm_plant_outputs_v": (I, [ctypes.c_void_p, P, D, D, ctypes.POINTER(Outputs)]),
        "sm_plant_step": (I, [ctypes.c_void_p, P, D, D, D, D, I]),
        "sm_plant_step_memo": (I, [ctypes.c_void_p, P, P, D, D, D, D, I]),
        "sm_plant_outputs_memo": (I, [ctypes.c_void_p, P, P, D, D, ctypes.POINTER(Outputs)]),
        "sm_solve_memo_clear": (None, [P]),
        "sm_plant_initial_state": (I, [ctypes.c_void_p, D, D, D, D, P]),
        "sm_plant_check_step": (I, [ctypes.c_void_p, D, D, D, D, ctypes.POINTER(I), ctypes.c_char_p, S]),
        "sm_plant_nonfinite_message": (None, [D, D, P, ctypes.c_char_p, S]),
        "sm_dclink_init": (I, [ctypes.c_void_p, ctypes.POINTER(DCLinkParams), ctypes.c_char_p, S]),
        "sm_dclink_size": (S, []),
        "sm_dclink_source_voltage": (D, [ctypes.c_void_p, D]),
        "sm_dclink_applied": (None, [D, D, D, P, P]),
        "sm_dclink_derivatives": (I, [ctypes.c_void_p, ctypes.c_void_p, D, P, D, D, D, I, P]),
        "sm_dclink_switch": (I, [ctypes.c_void_p, D, I]),
        "sm_dclink_step": (I, [ctypes.c_void_p, ctypes.c_void_p, D, P, D, D, D, D, I, ctypes.POINTER(I),
                               ctypes.POINTER(I), P]),
        "sm_dclink_over_voltage_message": (None, [D, D, D, ctypes.c_char_p, S]),
        "sm_inverter_size": (S, []),
        "sm_inverter_init": (I, [ctypes.c_void_p, ctypes.POINTER(PlantParams), D, ctypes.c_char_p, S]),
        "sm_inverter_duties": (None, [D, D, D, P]),
        "sm_inverter_intervals_bound": (D, [ctypes.c_void_p, D]),
        "sm_inverter_step": (I, [ctypes.c_void_p, ctypes.c_void_p, P, D, D, D, D, D, P, P, S,
                                 ctypes.POINTER(S)]),
        "sm_inverter_step_memo": (I, [ctypes.c_void_p, ctypes.c_void_p, P, P, D, D, D, D, D, P, P, S,
                                       ctypes.POINTER(S)]),
        "sm_inverter_step_link": (I, [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, P, P, D, D, D, D, D,
                                       P, ctypes.POINTER(I), ctypes.POINTER(I), P, P, S, ctypes.POINTER(S)]),
        "sm_deadtime_compensate": (None, [P, P, D, D, D]),
    }
    for struct in (MotorParams, PlantParams, ControllerParams, DCLinkParams):
        sig[struct.__name__ + "_default"] = (None, [ctypes.POINTER(struct)])
        sig[struct.__name__ + "_size"] = (S, [])
    for name, (res, args) in sig.items():
        f = getattr(lib, name)
        f.restype, f.argtypes = res, args
    return lib


def load(sanitize=False):
    """The ctypes library, built once per session (per flag set)."""
    key = bool(sanitize)
    if key not in _cache:
        path = build(SANITIZE if sanitize else ())
        _cache[key] = path if sanitize else declare(ctypes.CDLL(str(path)))
    return _cache[key]


def new_curve(lib):
    """A zeroed, 8-byte aligned buffer of sizeof(sm_curve) (the structs hold no pointers)."""
    return (ctypes.c_double * ((lib.sm_curve_size() + 7) // 8))()


def new_inverter(lib):
    """A zeroed, 8-byte aligned buffer of sizeof(sm_inverter)."""
    return (ctypes.c_double * ((lib.sm_inverter_size() + 7) // 8))()


def new_motor(lib):
    """A zeroed, 8-byte aligned buffer of sizeof(sm_motor)."""
    return (ctypes.c_double * ((lib.sm_motor_size() + 7) // 8))()

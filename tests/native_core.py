"""Test helper: the native core (``fmu/native/core/*.c`` and its generated ``sm_params.h`` / ``.c``)
compiled with gcc into one shared library, loaded with ctypes, argument types declared.  One build per
flag set, kept in ``build/native_core/`` (:data:`CACHE`: rebuilt when a source, the generated tables
or a flag changes; no temporary folder is left behind).  Extra compiler flags (appended) from the
environment variable ``SM_CORE_EXTRA_CFLAGS``.  The parameter structs (:data:`MotorParams`,
:data:`PlantParams`, :data:`ControllerParams`) are ctypes structures whose fields are read from the
generator's table (:func:`orchestration.packaging.native.tables.struct_members`), as the C structs are
generated from it."""

from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import subprocess
from pathlib import Path

import c_binding

from orchestration.packaging.native import atan_tables
from orchestration.packaging.native import tables as native_tables

ROOT = Path(__file__).resolve().parents[1]
CORE = ROOT / "fmu" / "native" / "core"
CACHE = ROOT / "build" / "native_core"  # one folder per flag set: the library and what it was built from
FLAGS = ["-std=c99", "-O2", "-fPIC", "-shared", "-Wall", "-Wextra", "-Werror", "-pedantic", "-Wconversion",
         "-Wshadow"]
SANITIZE = ["-fsanitize=address,undefined", "-fno-sanitize-recover=undefined", "-fno-omit-frame-pointer",
            "-g"]

_cache: dict = {}

_CTYPES = {"Real": ctypes.c_double, "Integer": ctypes.c_int, "Boolean": ctypes.c_int}


def _params_struct(c_struct):
    fields = [(n, ctypes.c_char * native_tables.STRING_MAX if t == "String" else _CTYPES[t])
              for n, t in native_tables.struct_members(c_struct)]
    return type(f"sm_{c_struct}_params", (ctypes.Structure,), {"_fields_": fields})


MotorParams, PlantParams, ControllerParams, DCLinkParams = (
    _params_struct(s) for s in ("motor", "plant", "controller", "dclink"))

# the core's headers read (tests/c_binding.py): every struct a ctypes class of the C name (the parameter
# structs the classes above, checked against the header), every function's signature
BINDING = c_binding.read([CORE], {"sm_params.h": native_tables.core_header()},
                         known={c.__name__: c for c in (MotorParams, PlantParams, ControllerParams,
                                                        DCLinkParams)})
STRUCTS = BINDING.structs
Outputs = STRUCTS["sm_plant_outputs"]
SM_TABLE_MAX = BINDING.constants["SM_TABLE_MAX"]  # sm_curves.h


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
    library; return its path: in ``out_dir`` (built anew), or by default in :data:`CACHE`, built only
    when what it is built from changed (the sources, the generated tables, the compiler and the flags;
    safe with pytest-xdist: each build is written under a name of its own, then renamed)."""
    gcc = shutil.which("gcc")
    if gcc is None:
        raise RuntimeError("gcc not found")
    env_flags = os.environ.get("SM_CORE_EXTRA_CFLAGS", "").split()  # e.g. "-O3 -march=native"
    flags = [*FLAGS, *env_flags, *extra_flags]
    name = "libsmcore_san.so" if extra_flags else "libsmcore.so"
    generated = {"sm_params.h": native_tables.core_header(), "sm_params.c": native_tables.core_source(),
                 "sm_atan_tables.h": atan_tables.atan_header()}
    if out_dir is not None:
        return _compile(gcc, flags, Path(out_dir), Path(out_dir) / name, generated)
    key = hashlib.sha256("\0".join([gcc, *flags]).encode())
    for p in sorted(CORE.glob("*.[ch]")):
        key.update(p.name.encode() + b"\0" + p.read_bytes())
    for text in generated.values():
        key.update(text.encode())
    folder = CACHE / hashlib.sha256("\0".join(flags).encode()).hexdigest()[:12]
    lib, stamp = folder / name, folder / "key"
    if lib.exists() and stamp.exists() and stamp.read_text() == key.hexdigest():
        return lib
    folder.mkdir(parents=True, exist_ok=True)
    own = folder / f"build-{os.getpid()}"
    try:
        _compile(gcc, flags, own, own / name, generated)
        os.replace(own / name, lib)
    finally:
        shutil.rmtree(own, ignore_errors=True)
    tmp = folder / f"key-{os.getpid()}"
    tmp.write_text(key.hexdigest())
    os.replace(tmp, stamp)
    return lib


def _compile(gcc, flags, work, lib, generated):
    gen = work / "generated"
    gen.mkdir(parents=True, exist_ok=True)
    for n, text in generated.items():
        (gen / n).write_text(text)
    sources = sorted(str(p) for p in CORE.glob("*.c")) + [str(gen / "sm_params.c")]
    cmd = [gcc, *flags, f"-I{gen}", f"-I{CORE}", "-o", str(lib), *sources, "-lm"]
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise RuntimeError(f"native core build failed:\n{' '.join(cmd)}\n{res.stderr}")
    return lib


def declare(lib):
    """Set the ctypes signatures of every function the core's headers declare (:data:`BINDING`, read
    from the headers: none is typed here); returns lib."""
    return BINDING.declare(lib)


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

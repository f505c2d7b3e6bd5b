"""The C hosts: how a C program that loads our FMUs is built, and the C floor master run on them.

``build_c_host(source, exe)`` compiles a host (C99, warnings as errors, the FMI headers shipped with
fmpy, ``-ldl``) with the host's ``cc`` (``$CC``): the one recipe that ``bench/floor_master.c`` (the C
floor) and the tests' own hosts (``tests/native_c_host.c``) are built by.  ``build_floor``, ``unit``,
``floor_args`` and ``run_floor`` run the floor on the shipped native FMI 2.0 plant and controller with
constant set-points, nothing recorded: the floor of ``bench_floor``, ``bench_engines``,
``bench_c_engine`` and ``bench_montecarlo`` and of ``tests/test_bench.py``.  Independent of the
compiled engine of ``orchestration.run.c_engine``: the floor steps the FMUs itself.
"""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

from fmpy import extract, read_model_description

from orchestration.packaging.native.compiler import fmi_headers_dir
from orchestration.scenario.system import MEASUREMENTS

ROOT = Path(__file__).resolve().parents[1]
FLOOR_C = ROOT / "bench" / "floor_master.c"
H = 1e-4
SETPOINTS = {"omega_ref": 100.0, "psi_ref": 0.95, "T_load": 10.0}  # [rad/s], [Wb], [N m]


def build_c_host(source, exe, flags=("-O2",)):
    """Compile the C host ``source`` into ``exe`` (C99, -Wall -Wextra -Werror, FMI headers, -ldl)."""
    cc = os.environ.get("CC", "cc")
    subprocess.run([cc, "-std=c99", *flags, "-Wall", "-Wextra", "-Werror", "-I", str(fmi_headers_dir()),
                    str(source), "-o", str(exe), "-ldl"], check=True)
    return Path(exe)


def build_floor(tmp):
    """The floor master built into directory ``tmp``."""
    return build_c_host(FLOOR_C, Path(tmp) / "floor_master")


def unit(path, tmp):
    """(model description, binary, {name: value reference}) of the FMU ``path`` extracted under ``tmp``."""
    md = read_model_description(str(path))
    d = Path(tmp) / md.coSimulation.modelIdentifier
    d.mkdir(parents=True, exist_ok=True)
    d = Path(extract(str(path), unzipdir=str(d)))
    lib = d / "binaries" / "linux64" / f"{md.coSimulation.modelIdentifier}.so"
    return md, lib, {v.name: v.valueReference for v in md.modelVariables}


def floor_args(exe, plant, ctrl, steps, mode):
    """The floor master's command line: ``steps`` steps of ``H`` of units ``plant`` and ``ctrl``."""
    (pmd, plib, pvr), (cmd_, clib, cvr) = plant, ctrl
    spec = [f"P2C:{pvr[n]}:{cvr[n]}" for n in MEASUREMENTS]
    spec += [f"C2P:{cvr[n]}:{pvr[n]}" for n in ("v_s_alpha", "v_s_beta")]
    spec += [f"C:{cvr[n]}={v!r}" for n, v in SETPOINTS.items()]
    spec += [f"P:{pvr['T_load']}={SETPOINTS['T_load']!r}"]
    spec += [f"OUT:{v.valueReference}" for v in pmd.modelVariables if v.causality == "output"]
    return [str(exe), str(plib), pmd.guid, str(clib), cmd_.guid, str(steps), repr(H), mode, *spec]


def run_floor(args):
    """The floor master's printout and its loop's (CPU, wall) time [s] (instantiation excluded)."""
    got = json.loads(subprocess.run(args, check=True, capture_output=True, text=True).stdout)
    return got, got["cpu_ns_per_step"] * got["steps"] * 1e-9, got["ns_per_step"] * got["steps"] * 1e-9

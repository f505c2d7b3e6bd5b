"""The pythonfmu FMUs in a C host process (tests/native_c_host.c: dlopen, fmi2* calls, no Python of
its own), as a C/C++ tool (Simulink, Dymola, OMSimulator, libcosim) loads them, with the recipe such
a host needs on Linux; and without it: no libpython preloaded (dlopen fails), a wrong PYTHONHOME
(Python ends the host process), no numpy on the embedded Python's path (fmi2Instantiate returns
NULL, naming the module).

What pythonfmu 0.7.0's binary needs (``readelf -d``): DT_NEEDED is libstdc++, libgcc_s and libc
only; its Py* symbols (stable ABI) are left undefined, to be found in a libpython already loaded
into the process.  A Python host has one; a C host has none, so the recipe is:

* ``LD_PRELOAD=<LIBDIR>/<INSTSONAME>`` (sysconfig of the Python to use, here libpython3.11.so.1.0)
  - LD_LIBRARY_PATH alone does not help: nothing asks for libpython by name;
* ``PYTHONHOME=<sys.base_prefix>`` - the embedded interpreter's standard library (without it, the
  prefix that libpython was built with: right only where that Python is installed as built);
* ``PYTHONPATH=<a site-packages with numpy>`` - the only third-party package the FMUs import
  (pythonfmu and satmotor are bundled in their resources/).

Each FMU runs in the same C host as the native FMI 2.0 FMU of the same model, with the same
parameters and inputs; the outputs agree to 1e-12 (relative)."""

from __future__ import annotations

import re
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import numpy
import pytest
from fmpy import read_model_description

from orchestration.packaging import fmus

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[1]
STEPS, H = 200, 1e-4
PLANT = "SaturatedInductionMotor"
# name: (Real inputs and parameters set before initialization, Real outputs printed after STEPS steps)
CASES = {
    "SaturatedInductionMotor": (
        {"v_s_alpha": 150.0, "v_s_beta": -40.0, "T_load": 5.0, "B_2": 0.001},
        ["i_s_alpha", "i_s_beta", "psi_r_alpha", "psi_r_beta", "omega_m", "theta_m", "T_e", "i_mu"]),
    "BacksteppingController": (
        {"i_s_alpha": 5.0, "i_s_beta": 1.0, "psi_r_alpha": 0.9, "psi_r_beta": 0.1, "omega_m": 10.0,
         "omega_ref": 50.0, "psi_ref": 0.95},
        ["v_s_alpha", "v_s_beta", "v_sd", "v_sq", "e1", "e2", "z1", "z2", "W", "T_load_est"]),
}


@pytest.fixture(scope="module")
def host(tmp_path_factory):
    from bench.floor_host import build_c_host

    exe = tmp_path_factory.mktemp("host") / "host"
    return build_c_host(ROOT / "tests" / "native_c_host.c", exe, flags=())


def libpython():
    """The shared libpython of the running Python (``LIBDIR/INSTSONAME``), or skip."""
    if not sysconfig.get_config_var("Py_ENABLE_SHARED"):
        pytest.skip("this Python has no shared libpython (built without --enable-shared)")
    lib = Path(sysconfig.get_config_var("LIBDIR")) / sysconfig.get_config_var("INSTSONAME")
    if not lib.is_file():
        pytest.skip(f"{lib} does not exist")
    return lib


def recipe():
    """The environment of a C/C++ host process for a pythonfmu FMU (see the module docstring)."""
    return {"LD_PRELOAD": str(libpython()), "PYTHONHOME": sys.base_prefix,
            "PYTHONPATH": str(Path(numpy.__file__).resolve().parents[1])}


def run_in_host(host, fmu, tmp_path, env):
    """``CompletedProcess`` of the C host stepping ``fmu`` STEPS times with CASES' values."""
    md = read_model_description(str(fmu))
    unzipped = tmp_path / f"{fmu.parent.name}_{fmu.stem}"
    if not unzipped.exists():
        with zipfile.ZipFile(fmu) as z:
            z.extractall(unzipped)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    values, outputs = CASES[md.modelName]
    lib = unzipped / "binaries" / "linux64" / f"{md.coSimulation.modelIdentifier}.so"
    args = [str(host), str(lib), md.guid, (unzipped / "resources").as_uri(), str(STEPS), repr(H),
            *(f"{vr[n]}={v!r}" for n, v in values.items()), "--", *(str(vr[n]) for n in outputs)]
    return subprocess.run(args, capture_output=True, text=True, env=env, timeout=120)


@pytest.mark.parametrize("name", list(CASES))
def test_the_pythonfmu_fmu_in_a_c_host_with_the_recipe_gives_the_native_fmus_numbers(name, host, fmu_dir,
                                                                                        tmp_path):
    pythonfmu = fmus.paths(fmu_dir, "python")[list(CASES).index(name)]
    native = fmus.paths(fmu_dir, "native")[list(CASES).index(name)]
    got = run_in_host(host, pythonfmu, tmp_path, recipe())
    assert got.returncode == 0, got.stderr
    ref = run_in_host(host, native, tmp_path, {})  # the native FMU needs nothing
    assert_same_numbers(got, ref, CASES[name][1])


def assert_same_numbers(got, ref, names):
    """The host's printed outputs of a pythonfmu run ``got`` agree with the native run ``ref`` to
    1e-12 relative (of max(|ref|, 1))."""
    assert ref.returncode == 0, ref.stderr
    a, b = numpy.array(got.stdout.split(), float), numpy.array(ref.stdout.split(), float)
    assert len(a) == len(b) == len(names)
    assert numpy.all(numpy.isfinite(b)) and numpy.any(b != 0.0)  # the run moved
    dev = numpy.abs(a - b) / numpy.maximum(numpy.abs(b), 1.0)
    assert dev.max() <= 1e-12, dict(zip(names, dev))


def test_without_libpython_preloaded_the_host_cannot_even_load_the_binary(host, fmu_dir, tmp_path):
    """LD_LIBRARY_PATH to libpython's directory, PYTHONHOME and PYTHONPATH set, but no preload: the
    binary does not ask for libpython, so dlopen fails on the first Python symbol."""
    env = {**recipe(), "LD_LIBRARY_PATH": str(libpython().parent)}
    del env["LD_PRELOAD"]
    r = run_in_host(host, fmus.paths(fmu_dir, "python")[0], tmp_path, env)
    assert r.returncode == 2 and r.stdout == ""
    assert re.search(r"^dlopen: .*: undefined symbol: _?Py\w+$", r.stderr, re.M), r.stderr


def test_with_a_wrong_pythonhome_python_takes_the_host_process_down(host, fmu_dir, tmp_path):
    """libpython preloaded, but PYTHONHOME without a standard library: Python's initialization, inside
    fmi2Instantiate, ends the host process (a fatal error, not a NULL instance the host could handle)."""
    env = {**recipe(), "PYTHONHOME": str(tmp_path / "no-python-here")}
    r = run_in_host(host, fmus.paths(fmu_dir, "python")[0], tmp_path, env)
    assert r.returncode != 0 and r.stdout == ""
    assert "Fatal Python error" in r.stderr and "No module named 'encodings'" in r.stderr, r.stderr
    assert "instantiate failed" not in r.stderr  # the host never got control back


def system_libpython_without_numpy():
    """The system's (Debian/Ubuntu) libpython of this Python version, when that Python has no numpy;
    else skip (the failure below needs an interpreter whose own paths lack numpy)."""
    version = f"{sys.version_info.major}.{sys.version_info.minor}"
    exe, lib = Path(f"/usr/bin/python{version}"), Path(f"/usr/lib/x86_64-linux-gnu/libpython{version}.so.1.0")
    if not (exe.is_file() and lib.is_file()):
        pytest.skip(f"no system Python {version} with a shared libpython")
    if subprocess.run([str(exe), "-c", "import numpy"], capture_output=True, env={}).returncode == 0:
        pytest.skip(f"the system Python {version} has numpy")
    return lib


def test_without_numpy_on_the_embedded_pythons_path_instantiation_fails_naming_it(host, fmu_dir, tmp_path):
    """The system's libpython preloaded (its own standard library, no numpy): fmi2Instantiate returns
    NULL with pythonfmu's fmi2Fatal message naming the missing module; PYTHONPATH to a site-packages
    with numpy is what it lacked."""
    lib = system_libpython_without_numpy()
    plant = fmus.paths(fmu_dir, "python")[0]
    assert plant.stem == PLANT
    r = run_in_host(host, plant, tmp_path, {"LD_PRELOAD": str(lib)})
    assert r.returncode == 3 and r.stdout == "", r.stderr  # the host's "instantiate failed"
    assert "Fatal py exception" in r.stderr and "No module named 'numpy'" in r.stderr, r.stderr
    ok = run_in_host(host, plant, tmp_path, {"LD_PRELOAD": str(lib), "PYTHONPATH": recipe()["PYTHONPATH"]})
    ref = run_in_host(host, fmus.paths(fmu_dir, "native")[0], tmp_path, {})
    assert ok.returncode == 0, ok.stderr
    assert_same_numbers(ok, ref, CASES[PLANT][1])

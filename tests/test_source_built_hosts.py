"""Hosts that can only be built from source (docs/hosts.md, "Hosts built from source"): OMSimulator's
command line, the Modelica Reference-FMUs' C ``fmusim`` and the FMU Compliance Checker.  None is on
PyPI (OMSimulator's PyPI package downloads its binaries from OpenModelica's own server when it is
built) or in Debian, so CI does not have them: each test skips, naming the recipe, unless the
executable is found, by its environment variable (``OMSIMULATOR``, ``FMUSIM``, ``FMUCHECK``) or on
PATH (``OMSimulator``, ``fmusim``, ``fmuCheck.linux64``).

What is compared, and with what:
* fmusim runs each native co-simulation FMU alone with the reference inputs (``reference/``, made from
  the plain-Python units, not from the FMUs) and must give the reference outputs within 1e-12 of each
  column's largest value, the bound of tests/test_reference_results.py (seen: 9.1e-15 plant, 4e-16
  controller, the digits fmusim prints).
* The FMU Compliance Checker passes every FMI 2.0 native FMU with its default settings (0 errors), and
  with the reference inputs gives the reference outputs within 1e-10 (plant) and 1e-8 (controller):
  bounds set after seeing 4.9e-12 and 1.5e-9, which come from the checker, not the FMUs: it sums its
  time in floating point and interpolates the input table at that time.
* OMSimulator's command line loads the package ``export-ssp`` writes and its plant outputs agree with
  the master's ``--algorithm jacobi`` run within 1e-11 (seen: 1.3e-13 over 0.3 s; not bit for bit,
  as OMSimulator passes each step as the difference of two times summed in floating point).
"""

from __future__ import annotations

import dataclasses
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from orchestration.cli import commands as cli
from orchestration.packaging import fmus
from orchestration.run.master import run
from orchestration.scenario.load import load_scenario

ROOT = Path(__file__).resolve().parents[1]
RECIPE = "build it from source as docs/hosts.md says"
CS_FMUS = [(v, m) for v in ("native", "native-fmi3")
           for m in ("SaturatedInductionMotor", "BacksteppingController")]
PLANT_OUTPUTS = ["i_s_alpha", "i_s_beta", "psi_r_alpha", "psi_r_beta", "omega_m", "T_e"]


def executable(variable, name):
    path = os.environ.get(variable) or shutil.which(name)
    if not path or not os.access(path, os.X_OK):
        pytest.skip(f"{name} not found (set {variable} or put it on PATH): {RECIPE}")
    return path


def relative_difference(got, want):
    """Largest |got - want| of the common columns but time, relative to each column's largest |want|;
    rows at a repeated time (before and after an event) keep the last."""
    got = got.drop_duplicates("time", keep="last").reset_index(drop=True)
    assert len(got) >= len(want) and np.allclose(got["time"][:len(want)], want["time"], rtol=0, atol=1e-12)
    cols = [c for c in want.columns if c in got.columns and c != "time"]
    assert cols
    return max(float(np.max(np.abs(got[c][:len(want)].to_numpy() - want[c].to_numpy()))
                     / max(float(np.max(np.abs(want[c]))), 1e-300)) for c in cols)


def reference(name):
    d = ROOT / "reference" / name
    return d / f"{name}_in.csv", pd.read_csv(d / f"{name}_ref.csv")


@pytest.mark.parametrize("variant, name", CS_FMUS)
def test_fmusim_gives_the_reference_results(variant, name, fmu_dir, tmp_path):
    exe = executable("FMUSIM", "fmusim")
    inputs, want = reference(name)
    out = tmp_path / "out.csv"
    args = ["--interface-type", "cs", "--stop-time", "0.3", "--output-interval", "1e-4", "--input-file",
            str(inputs), "--output-file", str(out), "--log-level", "warning"]
    fmu = fmu_dir / variant / f"{name}.fmu"
    done = subprocess.run([exe, *args, str(fmu)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert relative_difference(pd.read_csv(out), want) <= 1e-12


def checker(fmu, tmp_path, *options):
    exe = executable("FMUCHECK", "fmuCheck.linux64")
    out, log = tmp_path / "out.csv", tmp_path / "log.txt"
    done = subprocess.run([exe, *options, "-o", str(out), "-e", str(log), str(fmu)], capture_output=True,
                          text=True, timeout=300)
    text = log.read_text()
    assert done.returncode == 0 and "\t0 Error(s)" in text, text[-2000:]
    return out


@pytest.mark.parametrize("variant, name", [("native", "SaturatedInductionMotor"),
                                           ("native", "BacksteppingController"),
                                           ("native-me", "SaturatedInductionMotorME")])
def test_the_compliance_checker_passes_with_its_default_settings(variant, name, fmu_dir, tmp_path):
    checker(fmu_dir / variant / f"{name}.fmu", tmp_path)


@pytest.mark.parametrize("name, bound", [("SaturatedInductionMotor", 1e-10),
                                         ("BacksteppingController", 1e-8)])
def test_the_compliance_checker_gives_the_reference_results(name, bound, fmu_dir, tmp_path):
    inputs, want = reference(name)
    out = checker(fmu_dir / "native" / f"{name}.fmu", tmp_path, "-k", "cs", "-h", "1e-4", "-n", "0",
                  "-s", "0.3", "-l", "3", "-i", str(inputs))
    got = pd.read_csv(out)
    # its time is summed in floating point: the rows are matched by index, their times within 1e-13 s
    assert np.max(np.abs(got["time"][:len(want)].to_numpy() - want["time"].to_numpy())) < 1e-13
    got["time"] = np.r_[want["time"].to_numpy(), got["time"][len(want):].to_numpy()]
    assert relative_difference(got, want) <= bound


def read_mat(path):
    """{name: values} of an OpenModelica result file (MAT v4, ``binTrans``) as OMSimulator writes it."""
    from scipy.io import loadmat

    m = loadmat(path, chars_as_strings=False)
    names = ["".join(row).rstrip("\x00 ").strip() for row in m["name"].T]
    data = {1: m["data_1"].T, 2: m["data_2"].T}
    out = {}
    for name, (which, col, *_) in zip(names, m["dataInfo"].T):
        out[name] = data[2 if which == 0 else int(which)][:, abs(int(col)) - 1] * (1 if col > 0 else -1)
    return out


def test_omsimulator_runs_the_exported_package_like_the_master(fmu_dir, tmp_path):
    exe = executable("OMSIMULATOR", "OMSimulator")
    path = ROOT / "scenarios" / "ramp_rated_load.yaml"
    package = tmp_path / "p.ssp"
    assert cli.main(["export-ssp", str(path), str(package), "--fmus", str(fmu_dir)]) == 0
    stop = 0.3
    # its command line's stop time is 1 s unless given (it replaces the package's DefaultExperiment)
    done = subprocess.run([exe, f"--stopTime={stop}", "--resultFile=r.mat", str(package)], cwd=tmp_path,
                          capture_output=True, text=True, timeout=600)
    log = done.stdout + done.stderr
    assert done.returncode == 0, log[-3000:]
    # "whole multiple": its last step, clipped to 1.49e-13 s with no stop time declared, is not refused
    for refused in ("internal error", "ParameterBinding", "xml schema", "whole multiple"):
        assert refused not in log, log[-3000:]
    res = read_mat(tmp_path / "r.mat")
    t = res["time"]
    after = np.r_[t[1:] != t[:-1], True]  # each communication point's row after the transfer
    prefix = next(k for k in res if k.endswith(".plant.i_s_alpha"))[:-len("plant.i_s_alpha")]
    got = np.column_stack([res[f"{prefix}plant.{v}"][after] for v in PLANT_OUTPUTS])
    sc = dataclasses.replace(load_scenario(path), stop_time=stop)
    plant, ctrl = fmus.paths(fmu_dir, "native")
    master = run(sc, str(plant), str(ctrl), algorithm="jacobi")
    assert master.ok, master.message
    every = round(sc.record.interval / sc.step)
    want = master.frame[[f"plant.{v}" for v in PLANT_OUTPUTS]].to_numpy()
    got = got[::every][:len(want)]  # OMSimulator's last, clipped step adds a row at the stop time
    assert len(got) == len(want)
    err = np.max(np.abs(got - want) / np.max(np.abs(want), axis=0))
    assert err <= 1e-11, f"max relative difference {err:.3g}"

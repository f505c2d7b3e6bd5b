"""fmu-manipulation-toolbox's ``fmucontainer`` (the ``check`` extra) as a real host: it turns the package
``export-ssp`` writes into one FMI 2.0 co-simulation FMU holding the plant, the controller and the
ScenarioSignals FMU, and fmpy runs that container.  Its plant outputs equal the master's ``jacobi``
run bit for bit (the container's default "parallel" schedule reads every output after all units
have stepped).  Seen with fmu-manipulation-toolbox 2.0: the container does not apply the SSD's
parameter values (``Auto-wiring: 0 parameters``; a scenario with the plant's R_r 1.5x runs with the
default R_r), so it is tested on a scenario at default parameters, and docs/hosts.md says so.
"""

from __future__ import annotations

import dataclasses
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from orchestration.cli import commands as cli
from orchestration.packaging import fmus
from orchestration.run.master import run
from orchestration.scenario.load import load_scenario

ROOT = Path(__file__).resolve().parents[1]
OUTPUTS = ["i_s_alpha", "i_s_beta", "psi_r_alpha", "psi_r_beta", "psi_s_alpha", "psi_s_beta", "omega_m"]


def test_the_container_of_the_package_runs_in_fmpy_like_the_master(fmu_dir, tmp_path):
    tool = Path(sys.executable).with_name("fmucontainer")
    if not tool.exists() and shutil.which("fmucontainer") is None:
        pytest.skip("fmucontainer not installed: pip install -e '.[check]'")
    from fmpy import read_model_description, simulate_fmu

    path = ROOT / "scenarios" / "ramp_rated_load.yaml"
    package = tmp_path / "p.ssp"
    assert cli.main(["export-ssp", str(path), str(package), "--fmus", str(fmu_dir)]) == 0
    sc = dataclasses.replace(load_scenario(path), stop_time=0.3)
    made = subprocess.run([str(tool if tool.exists() else "fmucontainer"), "-container", f"p.ssp:{sc.step!r}",
                           "-fmu-directory", str(tmp_path)], capture_output=True, text=True, timeout=300)
    assert made.returncode == 0, made.stdout + made.stderr
    # every input connected: no "ERROR | Input '...' is not connected" (the controller's v_dc, before)
    assert "ERROR" not in made.stdout + made.stderr, made.stdout + made.stderr
    container = tmp_path / "p.fmu"
    names = {v.name for v in read_model_description(str(container)).modelVariables}
    assert {f"saturatedinductionmotor.{n}" for n in OUTPUTS} <= names
    res = simulate_fmu(str(container), stop_time=sc.stop_time, step_size=sc.step, output_interval=sc.step,
                       output=[f"saturatedinductionmotor.{n}" for n in OUTPUTS])
    got = np.array([res[f"saturatedinductionmotor.{n}"] for n in OUTPUTS]).T
    plant, ctrl = fmus.paths(fmu_dir, "native")
    master = run(sc, str(plant), str(ctrl), algorithm="jacobi")
    assert master.ok, master.message
    want = master.frame[[f"plant.{n}" for n in OUTPUTS]].to_numpy()
    assert got.shape == want.shape and np.abs(want).max() > 1.0
    assert np.array_equal(got, want)

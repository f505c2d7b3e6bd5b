"""fmpy's ``simulate_ssp`` and the package ``export-ssp`` writes: why it cannot run it, and that the
export says so.

fmpy 0.3's ``simulate_ssp`` (fmpy/ssp/simulation.py) starts every connector at 0.0, sets each FMU's
inputs from the connectors before its step and passes the outputs along the connections only after all
units stepped: at t = 0 the controller gets psi_ref = 0.0 whatever the ScenarioSignals FMU outputs (its
outputs after initialization are the set-points at t = 0, ``initial="calculated"``), and refuses it
(> 0 required).  It applies none of the SSD's parameter bindings either.  The working route with fmpy is
fmu-manipulation-toolbox's container (tests/test_container.py); libcosim and Ecos run the package as it
is (tests/test_libcosim.py, tests/test_ecos.py)."""

from __future__ import annotations

import zipfile
from pathlib import Path

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
from fmpy.ssp.simulation import simulate_ssp

from orchestration.cli import commands as cli
from orchestration.packaging import ssd
from orchestration.scenario.load import load_scenario

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = ROOT / "scenarios" / "ramp_rated_load.yaml"


@pytest.fixture(scope="module")
def package(fmu_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("ssp") / "r.ssp"
    assert cli.main(["export-ssp", str(DEFAULT), str(out), "--fmus", str(fmu_dir)]) == 0
    return out


def test_the_export_says_that_fmpys_simulate_ssp_cannot_run_it_and_what_can(fmu_dir, tmp_path, capsys):
    out = tmp_path / "p.ssp"
    assert cli.main(["export-ssp", str(DEFAULT), str(out), "--fmus", str(fmu_dir)]) == 0
    captured = capsys.readouterr()
    assert captured.out.strip() == str(out)
    assert "fmpy's simulate_ssp cannot run this package" in captured.err
    assert "psi_ref = 0.0" in captured.err and "fmucontainer -container p.ssp:0.0001" in captured.err


def test_fmpys_simulate_ssp_stops_at_t0_on_the_zero_it_sets(package, capfd):
    with pytest.raises(FMICallException, match="fmi2DoStep failed with status 2"):
        simulate_ssp(str(package), stop_time=0.01, step_size=1e-4)
    # fmpy's default logger prints to stdout; once orchestration.run.fmu_instance has installed its own
    # (fmpy's logger proxy is one per process) an unknown instance's message goes to stderr
    got = capfd.readouterr()
    log = got.out + got.err
    assert "BacksteppingController at t = 0 s: psi_ref = 0.0: must be a finite number > 0" in log, log


def test_the_signals_fmu_gives_the_set_points_from_initialization(package, tmp_path):
    """Not the package's fault: read after initialization, before any step, as an importer that reads
    the initial outputs does, the ScenarioSignals FMU gives the scenario's set-points at t = 0."""
    with zipfile.ZipFile(package) as z:
        z.extractall(tmp_path)
    path = tmp_path / ssd.RESOURCES[ssd.SIGNALS_UNIT]
    md = read_model_description(str(path))
    assert {v.name: v.initial for v in md.modelVariables if v.causality == "output"} == {
        "omega_ref": "calculated", "psi_ref": "calculated", "T_load": "calculated"}
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path)),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="signals")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    sc = load_scenario(DEFAULT)
    got = fmu.getReal([vr[n] for n in ("omega_ref", "psi_ref", "T_load")])
    assert got == [sc.profiles[n].value(0.0) for n in ("omega_ref", "psi_ref", "T_load")]
    assert got[1] > 0.5  # the flux set-point the controller needs from its first sample
    fmu.terminate()
    fmu.freeInstance()

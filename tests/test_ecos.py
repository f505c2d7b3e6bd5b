"""Ecos (the ``ecospy`` wheel from PyPI, a C++ co-simulation engine of NTNU's Ecos project) as a real
third-party host of the project's FMUs: it runs the package ``export-ssp`` writes (native FMI 2.0
plant and controller, the ScenarioSignals FMU) and the native FMI 3.0 pair, and its plant outputs are
compared with the project's own master running the same scenario under the ``jacobi`` algorithm
(Ecos's fixed-step algorithm reads every output after all units have stepped, as a Jacobi master).

Ecos's shared library needs Debian's ``libtbb12`` (scripts/system_packages.sh installs it); without
it, or without the wheel (the ``ecos`` extra), these tests skip with the reason.
"""

from __future__ import annotations

import dataclasses
import math
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np
import pytest

from orchestration.cli import commands as cli
from orchestration.packaging import fmus, ssd
from orchestration.run.master import run
from orchestration.scenario.load import load_scenario

ROOT = Path(__file__).resolve().parents[1]
NS = {"ssd": ssd.SSD_NS, "ssc": ssd.SSC_NS, "ssv": ssd.SSV_NS}
OUTPUTS = ["i_s_alpha", "i_s_beta", "psi_r_alpha", "psi_r_beta", "omega_m", "T_e"]


def ecospy():
    try:
        import ecospy as module
    except (ImportError, OSError) as e:  # OSError: its library loads at import, libtbb.so.12 missing
        pytest.skip(f"ecospy cannot be loaded ({e}): pip install -e '.[ecos]' and Debian's libtbb12 "
                    "(scripts/system_packages.sh)")
    module.EcosLib.set_log_level("warn")
    return module


def master_frame(scenario, stop, fmu_dir, variant):
    sc = dataclasses.replace(scenario, stop_time=stop)
    plant, ctrl = fmus.paths(fmu_dir, variant)
    result = run(sc, str(plant), str(ctrl), algorithm="jacobi")
    assert result.ok, result.message
    every = round(sc.record.interval / sc.step)
    return result.frame[[f"plant.{v}" for v in OUTPUTS]].to_numpy(), every


def step_and_read(sim, n):
    """Plant outputs at t = 0 and after each of ``n`` base steps."""
    read = lambda: [sim.get_real(f"plant::{v}") for v in OUTPUTS]  # noqa: E731
    got = [read()]
    for _ in range(n):
        sim.step()
        got.append(read())
    return np.array(got)


def assert_agrees(got, want, every, tol):
    got = got[::every]
    assert got.shape == want.shape
    scale = np.max(np.abs(want), axis=0)
    err = np.max(np.abs(got - want) / np.where(scale > 0, scale, 1.0))
    assert err <= tol, f"max relative difference {err:.3g} > {tol:g}"
    return err


@pytest.mark.parametrize("name, stop", [("ramp_rated_load", 0.3), ("speed_reversal", 0.3)])
def test_ecos_runs_the_exported_package_like_the_master(name, stop, fmu_dir, tmp_path):
    """The .ssp as it is: parameters from its bindings, connections from its SSD; ramp_rated_load
    covers pre-magnetization, the switch to the law and the start of the ramp.  Single-rate packages
    only (h = Ts): with a controller at a multiple of h Ecos steps each unit at its step-size hint
    but moves values between units at its own instants, not libcosim's (docs/hosts.md)."""
    eco = ecospy()
    path = ROOT / "scenarios" / f"{name}.yaml"
    package = tmp_path / "p.ssp"
    assert cli.main(["export-ssp", str(path), str(package), "--fmus", str(fmu_dir)]) == 0
    sc = load_scenario(path)
    want, every = master_frame(sc, stop, fmu_dir, "native")
    with eco.EcosSimulation(ssp_path=str(package), step_size=sc.step) as sim:
        sim.init()
        got = step_and_read(sim, round(stop / sc.step))
    # Ecos accumulates its time in floating point; the FMUs of this package do not depend on the
    # step's start time except the signals' profiles, evaluated at Ecos's time
    assert_agrees(got, want, every, 0.0)  # bit for bit


def package_parts(package, workdir):
    """(signals FMU path, {component: {name: value}}, [(source, sink)]) of an exported package."""
    with zipfile.ZipFile(package) as z:
        z.extractall(workdir)
    root = ET.parse(workdir / "SystemStructure.ssd").getroot()
    params = {}
    for c in root.findall("ssd:System/ssd:Elements/ssd:Component", NS):
        values = params.setdefault(c.get("name"), {})
        for p in c.findall(".//ssv:Parameter", NS):
            el = p[0]
            tag, v = el.tag.split("}")[1], el.get("value")
            values[p.get("name")] = {"Real": float, "Integer": int, "Boolean": lambda s: s == "true",
                                     "String": str}[tag](v)
    links = [(f"{c.get('startElement')}::{c.get('startConnector')}",
              f"{c.get('endElement')}::{c.get('endConnector')}")
             for c in root.findall("ssd:System/ssd:Connections/ssd:Connection", NS)]
    return workdir / ssd.RESOURCES["signals"], params, links


def test_ecos_runs_the_fmi3_pair_like_the_master(fmu_dir, tmp_path):
    """The native FMI 3.0 plant and controller assembled in Ecos's own structure API, with the
    package's ScenarioSignals FMU, its parameters and its connections."""
    eco = ecospy()
    package = tmp_path / "p.ssp"
    path = ROOT / "scenarios" / "ramp_rated_load.yaml"
    assert cli.main(["export-ssp", str(path), str(package), "--fmus", str(fmu_dir)]) == 0
    signals, params, links = package_parts(package, tmp_path / "x")
    plant, ctrl = fmus.paths(fmu_dir, "native-fmi3")
    sc = load_scenario(path)
    stop = 0.3
    want, every = master_frame(sc, stop, fmu_dir, "native-fmi3")
    with eco.EcosSimulationStructure() as structure:
        for name, uri in (("plant", plant), ("controller", ctrl), ("signals", signals)):
            structure.add_model(name, str(uri))
        for source, sink in links:
            structure.make_real_connection(source, sink)
        structure.add_parameter_set("scenario", {f"{unit}::{k}": v for unit, values in params.items()
                                                 for k, v in values.items()})
        with eco.EcosSimulation(structure=structure, step_size=sc.step) as sim:
            sim.init(parameter_set="scenario")
            got = step_and_read(sim, round(stop / sc.step))
    assert_agrees(got, want, every, 0.0)  # bit for bit
    assert math.isfinite(got[-1, OUTPUTS.index("omega_m")]) and got[-1, OUTPUTS.index("omega_m")] > 1.0

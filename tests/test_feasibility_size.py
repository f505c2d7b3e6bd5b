"""The recording size the feasibility check predicts (before any FMU runs) is the size the run
then writes: counted here from the CSV file of real runs, with measured signals and with a
``record.outputs`` selection."""

from __future__ import annotations

import csv

import pytest
import yaml

from orchestration.cli import commands as cli
from orchestration.scenario.feasibility import recorded_size
from orchestration.scenario.load import load_scenario


def written_size(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return len(rows) - 1, len(rows[0])


@pytest.mark.parametrize("edit", ["noise", "selection"])
def test_predicted_size_is_the_written_size(fmu_dir, tmp_path, edit):
    with open("scenarios/noisy_measurements.yaml") as f:
        data = yaml.safe_load(f)
    data["stop_time"] = 0.05
    data.pop("acceptance", None)
    if edit == "selection":
        data["record"] = {**data.get("record", {}), "outputs": ["plant.T_e", "controller.v_sd"]}
    scenario = tmp_path / f"size_{edit}.yaml"
    scenario.write_text(yaml.safe_dump(data))
    code, summary = cli.run_file(scenario, tmp_path / "out", fmu_dir, build=False, plot=False)
    assert summary["status"] == "ok", summary
    csv_file = next((tmp_path / "out" / summary["scenario"]).glob("*.csv"))
    assert recorded_size(load_scenario(scenario)) == written_size(csv_file)

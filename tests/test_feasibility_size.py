"""The recording size the feasibility check predicts (before any FMU runs) is the size the run
then writes: counted here from the CSV file of real runs, with measured signals and with a
``record.outputs`` selection."""

from __future__ import annotations

import csv

import pytest
import yaml

from orchestration.cli import commands as cli
from orchestration.scenario.feasibility import MAX_RECORDED_VALUES, kept_size, recorded_size
from orchestration.scenario.load import ScenarioError, load_scenario


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


def test_a_decimated_run_keeps_the_predicted_rows(fmu_dir, tmp_path):
    with open("scenarios/noisy_measurements.yaml") as f:
        data = yaml.safe_load(f)
    data["stop_time"] = 0.0503  # 504 rows: one of 7 kept from the first is 72
    data.pop("acceptance", None)
    data["record"] = {**data.get("record", {}), "level": "decimated", "every": 7}
    scenario = tmp_path / "size_decimated.yaml"
    scenario.write_text(yaml.safe_dump(data))
    code, summary = cli.run_file(scenario, tmp_path / "out", fmu_dir, build=False, plot=False)
    assert summary["status"] == "ok", summary
    csv_file = next((tmp_path / "out" / summary["scenario"]).glob("*.csv"))
    rows, cols = written_size(csv_file)
    assert kept_size(load_scenario(scenario)) == (rows, cols) and rows == 72


LONG = ("name: long\nstop_time: 600.0\nprofiles:\n  psi_ref: {type: constant, value: 0.9}\n"
        "  omega_ref: {type: step, time: 0.1, value: 50.0}\nrecord: {interval: 1.0e-4%s}\n")


@pytest.mark.parametrize("level, refused", [
    ("", True),  # full: 6e6 rows of every column kept
    (", level: decimated, every: 2", True),  # 3e6 rows kept
    (", level: decimated, every: 1000", False),  # 6001 rows kept
    (", level: metrics", False),  # nothing kept: the metrics fold the rows as the run goes
])
def test_the_recorded_values_limit_counts_what_the_level_keeps(tmp_path, level, refused):
    f = tmp_path / "long.yaml"
    f.write_text(LONG % level)
    if refused:
        with pytest.raises(ScenarioError, match=r"stop_time = 600.0: would record .* the limit is 1e\+08"):
            load_scenario(f)
    else:
        sc = load_scenario(f)
        rows, cols = recorded_size(sc)
        assert rows * cols > MAX_RECORDED_VALUES  # what the run computes is beyond the limit

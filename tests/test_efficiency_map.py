"""``efficiency-map`` (orchestration/tools/efficiency_map.py): the grid arguments and their refusals, and a
tiny map whose efficiencies are those of separate ``run``s of the same points, computed here from their
time series, with a point beyond the current limit reported as not reachable."""

from __future__ import annotations

import math

import pandas as pd
import pytest
import yaml

from orchestration.cli.commands import main
from orchestration.tools.efficiency_map import ArgumentError, parse_grid, parse_modes


def test_grid_values_both_ends_included():
    assert parse_grid("0:150:4", "--speed") == [0.0, 50.0, 100.0, 150.0]
    assert parse_grid("-20:20:3", "--torque") == [-20.0, 0.0, 20.0]
    assert parse_grid("7.5:99:1", "--torque") == [7.5]


@pytest.mark.parametrize("text", ["0:150", "0:150:3:4", "a:150:3", "0:b:3", "0:150:x", "0:150:2.5",
                                  "0:150:0", "0:150:-1", "nan:1:2", ""])
def test_grid_refusals_name_argument_and_value(text):
    with pytest.raises(ArgumentError) as err:
        parse_grid(text, "--speed")
    assert str(err.value).startswith(f"--speed {text!r}")


def test_flux_modes():
    assert parse_modes("nominal,loss_minimizing,nominal") == ["nominal", "loss_minimizing"]
    with pytest.raises(ArgumentError, match="--flux-mode 'nominal,fastest'.*'fastest'"):
        parse_modes("nominal,fastest")


@pytest.mark.parametrize("args, said", [
    (["--speed", "0:100", "--torque", "0:10:2"], "--speed '0:100'"),
    (["--speed", "0:100:2", "--torque", "-10:10:0"], "--torque '-10:10:0'"),
    (["--speed", "0:100:2", "--torque", "0:10:2", "--flux-mode", "minimal"], "--flux-mode 'minimal'"),
])
def test_cli_refuses_bad_arguments_exit_2(tmp_path, capsys, args, said):
    code = main(["efficiency-map", "scenarios/rated_point.yaml", *args, "--out", str(tmp_path / "m")])
    assert code == 2
    assert said in capsys.readouterr().err
    assert not (tmp_path / "m").exists()  # refused before anything is written


def _window_efficiency(frame, t_from):
    """P_mech / P_in over the rows at time >= t_from, from the recorded plant outputs."""
    w = frame[frame["time"] >= t_from - 1e-12]
    return w["plant.P_mech"].mean() / w["plant.P_in"].mean()


def test_tiny_map_against_separate_runs(tmp_path, fmu_dir, capsys):
    speeds, torques, stop_time, window = (50.0, 150.0), (10.0, 90.0), 0.4, 0.04
    out = tmp_path / "map"
    code = main(["efficiency-map", "scenarios/rated_point.yaml", "--speed", "50:150:2", "--torque", "10:90:2",
                 "--out", str(out), "--time", str(stop_time), "--window", str(window), "--fmus", str(fmu_dir),
                 "--jobs", "2"])
    assert code == 0, capsys.readouterr().err
    table = pd.read_csv(out / "efficiency_map.csv")
    parquet = pd.read_parquet(out / "efficiency_map.parquet")
    assert list(parquet.columns) == list(table.columns)
    pd.testing.assert_series_equal(parquet["efficiency"], table["efficiency"])
    assert (out / "efficiency_map.png").stat().st_size > 0
    assert sorted(zip(table["speed"], table["torque"])) == sorted((s, t) for s in speeds for t in torques)
    base = yaml.safe_load(open("scenarios/rated_point.yaml"))
    for speed in speeds:
        far = table[(table["speed"] == speed) & (table["torque"] == 90.0)].iloc[0]
        assert not far["reachable"]  # 90 N m needs more than I_max = 30 A
        assert "current limit" in far["why"] and math.isnan(far["efficiency"])
        row = table[(table["speed"] == speed) & (table["torque"] == 10.0)].iloc[0]
        assert row["reachable"] and row["status"] == "ok"
        point = {**base, "name": f"point_{int(speed)}", "stop_time": stop_time,
                 "profiles": {"psi_ref": base["profiles"]["psi_ref"],
                              "omega_ref": {"type": "constant", "value": speed},
                              "T_load": {"type": "ramp", "start": 0.2 * stop_time, "end": 0.4 * stop_time,
                                         "from": 0.0, "to": 10.0}}}
        point.pop("acceptance")  # rated_point's bounds are for its own ramp
        f = tmp_path / f"point_{int(speed)}.yaml"
        f.write_text(yaml.safe_dump(point))
        assert main(["run", str(f), "--out", str(tmp_path / "runs"), "--fmus", str(fmu_dir), "--no-build",
                     "--no-plot", "--engine", "c"]) == 0
        series = pd.read_parquet(tmp_path / "runs" / point["name"] / "timeseries.parquet")
        expected = _window_efficiency(series, stop_time - window)  # every step, the map every 4th row
        assert 0.5 < expected < 1.0
        assert row["efficiency"] == pytest.approx(expected, rel=1e-3)


def test_interrupted_map_writes_what_it_has(tmp_path, fmu_dir):
    """A stop (SIGTERM) before any point ran: the table is still written, every row saying so, exit 143."""
    import signal

    from orchestration.cli.batch import run_batch
    from orchestration.process.interrupts import StopRequest
    from orchestration.tools.efficiency_map import run_map

    stop = StopRequest()
    stop.request(signal.SIGTERM)
    code = run_map(run_batch, "scenarios/rated_point.yaml", tmp_path, [50.0, 100.0], [5.0],
                   ["nominal", "loss_minimizing"], fmu_dir, stop=stop, stop_time=0.2, plot=False)
    assert code == 128 + signal.SIGTERM
    table = pd.read_csv(tmp_path / "efficiency_map.csv")
    assert len(table) == 4 and not table["reachable"].any()
    assert set(table["status"]) == {"interrupted"}
    assert table["why"].str.contains("interrupted").all()


def test_invalid_scenario_refused_before_running(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump({"name": "bad", "stop_time": 1.0, "step": 1e-4, "motor": {"R_r": -1.0},
                                   "profiles": {"psi_ref": {"type": "constant", "value": 0.95}}}))
    code = main(["efficiency-map", str(bad), "--speed", "50:100:2", "--torque", "0:10:2",
                 "--out", str(tmp_path / "m")])
    assert code == 2
    err = capsys.readouterr().err
    assert "R_r" in err and "-1" in err
    assert not (tmp_path / "m" / "runs").exists()

"""The demos behind `make demo` write what they promise (smoke tests with real content checks)."""

import json
import sys
from pathlib import Path

import pandas as pd
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "demos"))

import closed_loop  # noqa: E402
import dol_start  # noqa: E402


def test_closed_loop_demo_writes_csv_json_png(tmp_path):
    closed_loop.main(["--out", str(tmp_path)])
    df = pd.read_csv(tmp_path / "closed_loop.csv")
    assert {"t [s]", "omega_m [rad/s]", "psi_ref [Wb]", "W [1]"} <= set(df.columns)
    assert df["t [s]"].iloc[-1] == pytest.approx(1.5)
    m = json.loads((tmp_path / "closed_loop.json").read_text())
    # the CSV and the metrics agree on the final speed error
    final = df["omega_m [rad/s]"].iloc[-1]
    assert abs(final - 100.0) / 100.0 <= m["ss_speed"] + 1e-15
    assert (tmp_path / "closed_loop.png").stat().st_size > 10_000


def test_dol_demo_writes_csv_png(tmp_path):
    dol_start.main(["--out", str(tmp_path), "--t-end", "0.05"])
    df = pd.read_csv(tmp_path / "dol_start.csv")
    assert len(df) == 501 and "T_e [N m]" in df.columns
    assert (tmp_path / "dol_start.png").stat().st_size > 10_000


def test_dol_demo_runs_a_motor_of_the_library(tmp_path):
    dol_start.main(["--out", str(tmp_path), "--t-end", "1.0", "--motor", "qu2012_2kw2"])
    df = pd.read_csv(tmp_path / "dol_start_qu2012_2kw2.csv")
    # the 2.2-kW machine runs up and carries its rated 14.6 N m from 0.6 s: the torque balances the load
    assert df["T_load [N m]"].iloc[-1] == 14.6
    assert df["T_e [N m]"].iloc[-1] == pytest.approx(14.6, rel=0.02)
    assert 140.0 < df["omega_m [rad/s]"].iloc[-1] < 157.1  # below synchronous speed (50 Hz, n_p = 2)

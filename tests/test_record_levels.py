"""Record levels: the metrics computed as the run goes (satmotor.metrics.RunningMetrics, fed chunk by
chunk by the recorder's observer) against the whole-record computation, on hand-made series and on
real runs at every level (full, decimated, metrics), and the rows each level leaves on disk."""

import json
import math

import numpy as np
import pandas as pd
import pytest

from orchestration.results.recorder import MetricsOnly, Recorder
from satmotor.metrics import RunningMetrics, closed_loop_metrics

ALMOST = ("iae_speed", "iae_flux")  # summed chunk by chunk: equal to within rounding


def _series(n=3001, seed=0, w_final=50.0):
    """Series of a run: law switching on at sample 400, a speed settling to ``w_final``, noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 1e-4
    w = w_final * (1 - np.exp(-t / 0.05)) + rng.normal(0, 0.3, n)
    ref = np.full(n, w_final)
    run = np.arange(n) >= 400
    return dict(t=t, omega_m=w, omega_ref=ref, psi_r_alpha=0.9 + rng.normal(0, 1e-3, n),
                psi_r_beta=rng.normal(0, 1e-3, n), psi_ref=np.full(n, 0.9), z1=rng.normal(0, 1, n),
                e1=rng.normal(0, 1e-3, n), i_s_alpha=rng.normal(0, 5, n), i_s_beta=rng.normal(0, 5, n),
                v_s_alpha=rng.normal(0, 200, n), v_s_beta=rng.normal(0, 200, n),
                W=1e6 + rng.normal(0, 1e4, n), run=run,
                voltage_limited=(rng.random(n) < 0.1).astype(float),
                current_limited=(rng.random(n) < 0.05).astype(float))


def _running(s, cuts, window=None):
    m = RunningMetrics(s["t"][-1], s["omega_ref"][-1], window)
    for a, b in zip([0, *cuts], [*cuts, len(s["t"])]):
        m.update(**{k: v[a:b] for k, v in s.items()})
    return m


def _same(got, want):
    assert list(got) == list(want)
    for k, v in want.items():
        if math.isnan(v):
            assert math.isnan(got[k]), k
        elif k in ALMOST:
            assert got[k] == pytest.approx(v, rel=1e-12, abs=0), k
        else:
            assert got[k] == v, k  # the same float operations: bit for bit


@pytest.mark.parametrize("cuts", [[], [1], [399, 400, 401], [1000, 2000], list(range(7, 3001, 97))])
@pytest.mark.parametrize("window", [None, (0.2, 0.25), (0.29, 0.3)])
def test_running_metrics_equal_the_whole_record_ones_whatever_the_chunks(cuts, window):
    s = _series()
    want = closed_loop_metrics(**{k: v for k, v in s.items() if k != "run"}, run=s["run"], ss_window=window)
    _same(_running(s, cuts, window).result(), want)


@pytest.mark.parametrize("w_final", [0.0, -30.0])
def test_running_metrics_for_a_zero_or_negative_final_speed(w_final):
    s = _series(w_final=w_final, seed=2)
    want = closed_loop_metrics(**{k: v for k, v in s.items() if k != "run"}, run=s["run"])
    _same(_running(s, [500, 1500]).result(), want)


def test_running_metrics_without_the_law_running():
    s = _series()
    s["run"] = np.zeros_like(s["run"])
    want = closed_loop_metrics(**{k: v for k, v in s.items() if k != "run"}, run=s["run"])
    _same(_running(s, [1000]).result(), want)


def test_a_record_that_stops_early_gives_no_running_metrics():
    s = _series()
    m = RunningMetrics(s["t"][-1] + 1e-4, s["omega_ref"][-1])  # the run was meant to go one step further
    m.update(**s)
    assert m.result() is None
    assert RunningMetrics(1.0, 0.0).result() == {}


def test_the_recorder_keeps_one_row_of_every_n_across_chunks_and_shows_the_observer_all():
    seen = []
    rec = Recorder(["time", "x"], chunk_rows=7, observer=lambda a: seen.append(a.copy()), every=3)
    for k in range(50):
        rec.append((k * 0.1, float(k)))
    rec.close()
    got = rec.arrays()
    assert got["x"].tolist() == [float(k) for k in range(0, 50, 3)]
    assert rec.n_rows == 17 and rec.n_seen == 50
    assert np.concatenate(seen)[:, 1].tolist() == [float(k) for k in range(50)]
    only = MetricsOnly(["time", "x"], chunk_rows=7, observer=lambda a: None)
    for k in range(20):
        only.append((k * 0.1, float(k)))
    only.close()
    assert only.n_rows == 0 and only.n_seen == 20 and len(only.arrays()["x"]) == 0


# ----- real runs at each level -----------------------------------------------------------------

SCENARIO = """name: {name}
stop_time: 0.4
profiles:
  psi_ref: {{type: constant, value: 0.95}}
  omega_ref: {{type: ramp, start: 0.12, end: 0.3, from: 0.0, to: 50.0}}
  T_load: {{type: step, time: 0.32, value: 10.0}}
record: {record}
"""


@pytest.fixture(scope="module")
def levels(tmp_path_factory, fmu_dir):
    from orchestration.cli.commands import run_file

    d = tmp_path_factory.mktemp("levels")
    out = d / "out"
    records = {"full": "{level: full}", "decimated": "{level: decimated, every: 7}", "metrics": "metrics",
               "chunked": "{level: metrics}"}
    summaries = {}
    for name, record in records.items():
        f = d / f"{name}.yaml"
        f.write_text(SCENARIO.format(name=name, record=record))
        if name == "chunked":  # several chunks of 1000 rows: the metrics summed across them
            from functools import partial

            from orchestration.results import writer

            with pytest.MonkeyPatch.context() as mp:
                mp.setattr(writer, "MetricsOnly", partial(MetricsOnly, chunk_rows=1000))
                code, summaries[name] = run_file(f, out, fmu_dir, build=False, variant="native")
        else:
            code, summaries[name] = run_file(f, out, fmu_dir, build=False, variant="native")
        assert code == 0, summaries[name]
    return out, summaries


def test_every_level_gives_the_same_metrics(levels):
    out, s = levels
    full = s["full"]["metrics"]
    assert full and s["full"]["rows"] == 4001
    for name in ("decimated", "metrics", "chunked"):
        _same(s[name]["metrics"], full)
        assert s[name]["holds_setpoints"] == s["full"]["holds_setpoints"]
        assert s[name]["setpoints"] == s["full"]["setpoints"]
        assert s[name]["rows"] == 4001
        assert json.loads((out / name / "metrics.json").read_text())["record"] == (
            "metrics" if name == "chunked" else name)


def test_each_level_leaves_what_it_says_on_disk(levels):
    out, s = levels
    full = pd.read_parquet(out / "full" / "timeseries.parquet")
    dec = pd.read_parquet(out / "decimated" / "timeseries.parquet")
    assert len(full) == 4001 and s["full"]["rows_written"] == 4001
    assert len(dec) == 572 == s["decimated"]["rows_written"]  # rows 0, 7, ..., 3997
    assert dec.reset_index(drop=True).equals(full.iloc[::7].reset_index(drop=True))
    assert len(pd.read_csv(out / "decimated" / "timeseries.csv")) == 572
    assert (out / "full" / "figure.png").exists() and (out / "decimated" / "figure.png").exists()
    assert sorted(p.name for p in (out / "metrics").iterdir()) == ["metrics.json"]
    assert s["metrics"]["rows_written"] == 0


def test_record_levels_are_checked(tmp_path):
    from orchestration.scenario.validate import validate_scenario_file

    for record, field, words in (("{level: all}", "record.level", "must be one of"),
                                 ("{level: full, every: 3}", "record.every", "decimated only"),
                                 ("{level: decimated, every: 0}", "record.every", ">= 1")):
        f = tmp_path / "r.yaml"
        f.write_text(SCENARIO.format(name="r", record=record))
        problems = validate_scenario_file(f)
        assert [p.field for p in problems] == [field] and words in problems[0].message, problems

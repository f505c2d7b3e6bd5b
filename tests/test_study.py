"""Sensitivity studies (orchestration/study): the designs and the indices through the code path batch
uses, checked on functions whose indices are known in closed form (Ishigami's for Sobol', a linear
function's elementary effects for Morris), and on a drive whose answer is physically clear (a parameter
the run cannot depend on gets a total index of exactly zero); the study's summary and its report,
opened in a real headless browser."""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from orchestration.scenario.sweep import parse_sweep
from orchestration.study.analyses import indices
from orchestration.study.summary import wilson

ROOT = Path(__file__).resolve().parents[1]
CHROMIUM = Path("/usr/bin/chromium")
TABLES = {"motor": {"x1": 0.0, "x2": 0.0, "x3": 0.0}}  # three free "parameters" for the analytic checks


def _design(raw, tables=TABLES):
    sweep, problems = parse_sweep(raw, {"name": "f", "motor": {}}, "f.yaml", tables)
    assert problems == [], problems
    return sweep, np.array([[x for _, x in v.values] for v in sweep.variants])


def _frame(sweep, **metrics):
    return pd.DataFrame({"variant": [v.name for v in sweep.variants], "index": range(len(sweep.variants)),
                         "status": "ok", **metrics})


def test_sobol_indices_of_the_ishigami_function_match_their_closed_form():
    """f = sin x1 + a sin^2 x2 + b x3^4 sin x1 on [-pi, pi]^3 (Ishigami and Homma 1990), a = 7, b = 0.1:
    V = a^2/8 + b pi^4/5 + b^2 pi^8/18 + 1/2, V1 = (1 + b pi^4/5)^2 / 2, V2 = a^2/8,
    V13 = b^2 pi^8 (1/18 - 1/50), V3 = 0."""
    a, b, pi = 7.0, 0.1, math.pi
    V = a * a / 8 + b * pi**4 / 5 + b * b * pi**8 / 18 + 0.5
    V1, V2, V13 = (1 + b * pi**4 / 5) ** 2 / 2, a * a / 8, b * b * pi**8 * (1 / 18 - 1 / 50)
    S1 = [V1 / V, V2 / V, 0.0]
    ST = [(V1 + V13) / V, V2 / V, V13 / V]
    assert [round(s, 4) for s in S1 + ST] == [0.3139, 0.4424, 0.0, 0.5576, 0.4424, 0.2437]
    sweep, X = _design({"analysis": "sobol", "samples": 1024, "seed": 3,
                        "parameters": {f"motor.x{i}": {"uniform": [-pi, pi]} for i in (1, 2, 3)}})
    assert sweep.kind == "sobol" and len(sweep.variants) == 1024 * (3 + 2)
    assert X.min() >= -pi and X.max() <= pi
    Y = np.sin(X[:, 0]) + a * np.sin(X[:, 1]) ** 2 + b * X[:, 2] ** 4 * np.sin(X[:, 0])
    got = indices(sweep, _frame(sweep, ishigami=Y, constant=0.0 * Y)).set_index(["metric", "parameter"])
    for i in range(3):
        row = got.loc[("ishigami", f"motor.x{i + 1}")]
        assert abs(row["S1"] - S1[i]) < 0.03 and abs(row["ST"] - ST[i]) < 0.03, row
        assert abs(row["S1"] - S1[i]) < row["S1_conf"] and abs(row["ST"] - ST[i]) < row["ST_conf"], row
    assert got.loc[("constant", "motor.x1"), "note"] == "the same in every variant: no variance to share"
    assert math.isnan(got.loc[("constant", "motor.x1"), "ST"])


def test_morris_elementary_effects_of_a_linear_function_are_its_slopes_times_the_ranges():
    tables = {"motor": {"x1": 0.0, "x2": 0.0}}
    sweep, X = _design({"analysis": "morris", "samples": 10, "levels": 4, "seed": 1,
                        "parameters": {"motor.x1": {"uniform": [0.0, 2.0]},
                                       "motor.x2": {"uniform": [5.0, 6.0]}}},
                       tables)
    assert sweep.kind == "morris" and len(sweep.variants) == 10 * (2 + 1)
    got = indices(sweep, _frame(sweep, lin=3.0 * X[:, 0] - 0.5 * X[:, 1])).set_index("parameter")
    # an elementary effect is the change over the parameter's whole range: 3 x 2 and -0.5 x 1, no spread
    assert got.loc["motor.x1", ["mu", "mu_star"]].tolist() == pytest.approx([6.0, 6.0])
    assert got.loc["motor.x2", ["mu", "mu_star"]].tolist() == pytest.approx([-0.5, 0.5])
    assert got["sigma"].abs().max() < 1e-9


def test_a_design_repeats_with_its_seed_and_a_failed_variant_gives_no_index():
    raw = {"analysis": "sobol", "samples": 8, "seed": 5, "parameters": {"motor.x1": {"normal": [1.0, 0.1]},
                                                                         "motor.x2": {"tolerance": 0.5}}}
    s1, X1 = _design(raw, {"motor": {"x1": 0.0, "x2": 2.0}})
    s2, X2 = _design(raw, {"motor": {"x1": 0.0, "x2": 2.0}})
    assert np.array_equal(X1, X2) and X1[:, 1].min() >= 1.0 and X1[:, 1].max() <= 3.0
    Y = X1[:, 0] * 1.0
    Y[3] = math.nan
    got = indices(s1, _frame(s1, y=Y))
    assert got["note"].tolist() == [f"1 of {len(Y)} variants have no finite value: no index"] * 2


@pytest.mark.parametrize("sweep, field, words", [
    ({"analysis": "sobol", "samples": 6, "seed": 1}, "sweep.samples", "a power of two"),
    ({"analysis": "sobol", "seed": 1}, "sweep.samples", "N base samples"),
    ({"analysis": "morris", "samples": 4, "seed": 1, "levels": 3}, "sweep.levels", "an even integer"),
    ({"analysis": "sobol", "samples": 4, "seed": 1, "levels": 4}, "sweep.levels", "needs analysis: morris"),
    ({"analysis": "fast", "samples": 4, "seed": 1}, "sweep.analysis", "must be one of sobol, morris"),
    ({"analysis": "sobol", "samples": 4}, "sweep.seed", "needs a seed"),
    ({"analysis": "sobol", "samples": 4096, "seed": 1}, "sweep.samples", "gives 12288 variants"),
])
def test_a_bad_study_is_refused_naming_the_field(sweep, field, words):
    raw = {**sweep, "parameters": {"motor.x1": {"uniform": [0.0, 1.0]}}}
    _, problems = parse_sweep(raw, {"name": "f"}, "f.yaml", TABLES)
    assert [p.field for p in problems] == [field] and words in problems[0].message, problems


def test_a_study_without_salib_is_refused_naming_the_pip_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "SALib", None)  # not importable, as if not installed
    raw = {"analysis": "sobol", "samples": 4, "seed": 1, "parameters": {"motor.x1": {"uniform": [0.0, 1.0]}}}
    (p,) = parse_sweep(raw, {"name": "f"}, "f.yaml", TABLES)[1]
    assert p.field == "sweep.analysis" and p.message.endswith('pip install "satmotor[study]"'), p


def test_morris_refuses_a_normal_distribution():
    raw = {"analysis": "morris", "samples": 4, "seed": 1, "parameters": {"motor.x1": {"normal": [1.0, 0.1]}}}
    (p,) = parse_sweep(raw, {"name": "f"}, "f.yaml", TABLES)[1]
    assert p.field == "sweep.parameters.motor.x1.normal" and "maps to infinity" in p.message


def test_the_wilson_interval_of_known_fractions():
    assert wilson(0, 20) == (0.0, pytest.approx(3.8414588 / (20 + 3.8414588)))  # z^2 / (n + z^2)
    low, high = wilson(10, 20)
    assert (round(low, 4), round(high, 4)) == (0.2993, 0.7007) and wilson(20, 20)[1] == 1.0
    assert all(math.isnan(x) for x in wilson(0, 0))


def test_the_library_studies_are_valid_and_small():
    from orchestration.scenario.validate import check_scenario_file
    from orchestration.scenario.variants import load_sweep

    for name, kind, count in (("sobol_motor", "sobol", 48), ("morris_motor", "morris", 20)):
        base, sweep, variants = load_sweep(ROOT / "scenarios" / f"{name}.yaml")
        assert sweep.kind == kind and len(variants) == count and base.stop_time <= 1.0
        assert check_scenario_file(ROOT / "scenarios" / f"{name}.yaml") == ([], [])


# --- a drive study, end to end: batch, its files, the report in a browser ---------------------------------

DRIVE = """name: null_param
stop_time: 0.3
mismatch: true
profiles:
  psi_ref: {type: constant, value: 0.95}
  omega_ref: {type: ramp, start: 0.12, end: 0.22, from: 0.0, to: 50.0}
acceptance:
  ss_speed: 1.0e-9        # no variant meets it: every one is outside
  ss_window: [0.28, 0.3]
sweep:
  analysis: sobol
  samples: 4
  seed: 11
  parameters:
    plant.J: {tolerance: 0.3}
    plant.T_amb: {uniform: [253.15, 313.15]}   # the thermal model is off (the default): no effect
"""


def _chromium(args, user_dir):
    flags = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
             "--disable-component-update", "--disable-sync", "--no-first-run", f"--user-data-dir={user_dir}"]
    return subprocess.run([str(CHROMIUM), *flags, *map(str, args)], capture_output=True, text=True,
                          timeout=120)


def test_a_drive_study_gives_a_parameter_it_cannot_depend_on_a_zero_total_index(tmp_path, fmu_dir):
    f = tmp_path / "null_param.yaml"
    f.write_text(DRIVE)
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, "-m", "orchestration", "batch", f, "--out", out, "--fmus", fmu_dir,
                        "--variant", "native", "--jobs", "2"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 3, r.stderr  # every variant misses the 1e-9 bound
    d = out / "null_param"
    s = pd.read_csv(d / "sensitivity.csv").set_index(["metric", "parameter"])
    varied = [m for m, p in s.index if p == "plant.T_amb" and s.loc[(m, p), "note"] != s.loc[(m, p), "note"]]
    assert {"iae_speed", "iae_flux", "ss_speed"} <= set(varied)  # metrics that vary with J
    for m in varied:
        # T_amb: every variant equals its J-twin bit for bit, so the estimator's sums are exactly zero
        assert s.loc[(m, "plant.T_amb"), "ST"] == 0.0 and s.loc[(m, "plant.T_amb"), "ST_conf"] == 0.0, m
        assert s.loc[(m, "plant.T_amb"), "S1"] == 0.0, m
    assert s.loc[("peak_current", "plant.T_amb"), "note"] == "the same in every variant: no variance to share"
    assert s.loc[("iae_speed", "plant.J"), "ST"] > 0.5  # the speed's tracking error: the inertia's
    assert len(pd.read_csv(d / "sweep.csv")) == 4 * (2 + 2)
    summary = pd.read_csv(d / "study_summary.csv").set_index("metric")
    row = summary.loc["ss_speed"]
    assert row["bound"] == 1e-9 and row["outside"] == 16 and row["outside_fraction"] == 1.0
    assert row["outside_low"] == pytest.approx(wilson(16, 16)[0]) and row["outside_high"] == 1.0
    said = row["outside_variants"]
    assert "null_param-00 (plant.J = " in said and ", plant.T_amb = " in said
    assert summary.loc["(failed)", "outside"] == 0
    assert "sweep null_param: ss_speed <= 1e-09: 16 of 16 variants outside (100.0%" in r.stderr
    assert (d / "sensitivity.png").stat().st_size > 5_000
    page = (d / "report.html").read_text()
    assert "<script" not in page and "http" not in page.replace("http-equiv", "")  # self-contained
    assert page.count("data:image/png;base64,") == 2 and "analysis: sobol" in page  # figures, the scenario
    if not CHROMIUM.exists():
        pytest.skip(f"{CHROMIUM} is absent (Debian package chromium: scripts/system_packages.sh): the "
                    "report is not opened in a browser")
    dom = _chromium(["--dump-dom", (d / "report.html").as_uri()], tmp_path / "profile")
    assert dom.returncode == 0, dom.stderr
    for ident in ("sweep-figure", "sensitivity-figure"):
        assert f'<figure id="{ident}"><img alt=' in dom.stdout, ident
    for ident in ("summary", "sensitivity", "variants", "versions"):
        assert f'id="{ident}"' in dom.stdout, ident
    assert dom.stdout.count("<tr>") > 16 + 8 + 19
    shot = tmp_path / "report.png"
    r = _chromium(["--screenshot=" + str(shot), "--window-size=1280,2400", (d / "report.html").as_uri()],
                  tmp_path / "profile2")
    assert r.returncode == 0 and shot.stat().st_size > 50_000, r.stderr
    keep = os.environ.get("SATMOTOR_KEEP_REPORT")  # where to leave the screenshot and the page, if asked
    if keep:
        shutil.copy(shot, keep)

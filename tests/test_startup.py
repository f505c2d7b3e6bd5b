"""The start-up of one ``run``: what a run does not use is not imported, and the CLI starts numpy with
one OpenBLAS thread unless the environment says otherwise (``bench/bench_startup.py`` measures it)."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

CHILD = """
import json, sys
from orchestration.cli.commands import main
code = main(sys.argv[1:])
print(json.dumps({"code": code, "modules": sorted(sys.modules), "blas": __import__("os").environ.get(
    "OPENBLAS_NUM_THREADS")}))
"""

#: imported by a run --no-plot of the native FMUs at record: metrics, they would be paid for nothing
UNUSED = ("matplotlib", "pandas", "pyarrow", "scipy", "SALib", "lxml", "urllib.request", "http.client",
          "xml.sax", "ssl", "socket", "orchestration.packaging.native.source_fmu")


def _child(args, env_extra=None):
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    env.update(env_extra or {})
    r = subprocess.run([sys.executable, "-c", CHILD, *map(str, args)], cwd=ROOT, capture_output=True,
                       text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("engine", ["c", "fmpy"])
def test_a_run_at_level_metrics_imports_nothing_it_does_not_use(tmp_path, fmu_dir, engine):
    f = tmp_path / "short.yaml"
    f.write_text("name: short\nstop_time: 0.05\nrecord: metrics\nprofiles:\n"
                 "  psi_ref: {type: constant, value: 0.9}\n"
                 "  omega_ref: {type: step, time: 0.01, value: 20.0}\n")
    # a cache of its own: the first run parses the model descriptions (lxml) and compiles the engine into
    # it; the run after it, as every later run of a user's, reads them from the cache
    cache = {"SATMOTOR_ENGINE_CACHE": str(tmp_path / "cache")}
    args = ["run", f, "--out", tmp_path / "out", "--fmus", fmu_dir, "--no-build", "--no-plot", "--engine",
            engine, "--variant", "native"]
    _child(args, cache)
    got = _child(args, cache)
    assert got["code"] in (0, 3)  # 3: the acceptance of so short a run may be missed
    assert (tmp_path / "out" / "short" / "metrics.json").is_file()
    loaded = set(got["modules"])
    assert [m for m in UNUSED if m in loaded] == []
    assert got["blas"] == "1"  # set before numpy was imported


def test_a_users_openblas_setting_is_kept(fmu_dir):
    got = _child(["validate", ROOT / "scenarios" / "ramp_rated_load.yaml", "--fmus", fmu_dir],
                 {"OPENBLAS_NUM_THREADS": "2"})
    assert got["code"] == 0 and got["blas"] == "2"

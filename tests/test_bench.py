"""The benchmark runner (``python -m bench``) and the C floor host it shares with the tests.

The runner finds every ``bench/bench_NAME.py`` (the list here is read from the directory, not from the
runner), ``--list`` names each, an unknown name is refused with exit status 2 and the known names, and
each benchmark module imports and has ``main(argv)``.  ``write_section`` replaces a benchmark's block in
place and keeps the rest.  The C floor master (``bench/floor_master.c`` built by
``bench.floor_host``), stepping the native FMUs, ends in the same plant outputs as the fmpy master.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
NAMES = sorted(p.stem.removeprefix("bench_") for p in (ROOT / "bench").glob("bench_*.py"))


def bench(*args):
    return subprocess.run([sys.executable, "-m", "bench", *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=120)


def test_the_runner_lists_every_benchmark_module():
    r = bench("--list")
    assert r.returncode == 0, r.stderr
    listed = [line.split()[0] for line in r.stdout.splitlines() if line.strip()]
    assert listed == NAMES
    assert len(NAMES) >= 17 and {"floor", "engines", "loss_min"} <= set(NAMES)
    assert all(len(line.split(None, 1)) == 2 for line in r.stdout.splitlines()), "one without a summary"


def test_an_unknown_benchmark_or_none_is_refused_with_status_2():
    r = bench("floor", "no_such_bench", "--rounds", "1")
    assert r.returncode == 2
    assert "unknown benchmark 'no_such_bench'" in r.stderr and "floor" in r.stderr
    assert "== bench" not in r.stdout  # nothing ran, not even the known one
    r = bench()
    assert r.returncode == 2 and "usage" in r.stderr


def test_every_benchmark_module_imports_and_has_main():
    code = ("import importlib, inspect, sys\n"
            "for n in sys.argv[1:]:\n"
            "    m = importlib.import_module('bench.bench_' + n)\n"
            "    assert list(inspect.signature(m.main).parameters) == ['argv'], n\n"
            "print('ok', len(sys.argv) - 1)\n")
    r = subprocess.run([sys.executable, "-c", code, *NAMES], cwd=ROOT, capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.split() == ["ok", str(len(NAMES))]


def test_write_section_replaces_its_block_and_keeps_the_rest(tmp_path, monkeypatch):
    from bench import common

    path = tmp_path / "RESULTS.md"
    block = {k: f"<!-- {k}:start -->\n{v}\n<!-- {k}:end -->\n" for k, v in
             (("a", "old a"), ("b", "b"), ("new a", "## new a"), ("c", "## c"))}
    path.write_text("# head\n\n" + block["a"] + "\n" + block["b"])
    monkeypatch.setattr(common, "RESULTS", path)
    common.write_section("a", "## new a\n")
    common.write_section("c", "## c")
    new_a = block["new a"].replace("new a:", "a:")
    assert path.read_text() == "# head\n\n" + new_a + "\n" + block["b"] + "\n" + block["c"]


def test_the_c_floor_host_ends_where_the_fmpy_master_does(fmu_dir, tmp_path):
    from bench.floor_host import H, build_floor, floor_args, run_floor, unit
    from orchestration.packaging import fmus
    from orchestration.run.master import run
    from orchestration.scenario.load import load_scenario

    steps = 200
    plant_path, ctrl_path = fmus.paths(fmu_dir, "native")
    plant, ctrl = unit(plant_path, tmp_path / "p"), unit(ctrl_path, tmp_path / "c")
    got, cpu, wall = run_floor(floor_args(build_floor(tmp_path), plant, ctrl, steps, "floor"))
    assert got["steps"] == steps and cpu > 0 and wall > 0
    from bench.bench_floor import SCENARIO

    yaml = tmp_path / "floor.yaml"
    yaml.write_text(SCENARIO.format(stop=steps * H))
    r = run(load_scenario(yaml), plant_path, ctrl_path)
    assert r.ok, r.message
    names = [v.name for v in plant[0].modelVariables if v.causality == "output"]
    last = r.frame[[f"plant.{n}" for n in names]].to_numpy()[-1]
    assert [float(x) for x in got["outputs"]] == [float(x) for x in last]

"""batch on a real dask.distributed cluster (2 worker processes on 127.0.0.1, started here): the
variants go in chunks (the grouping a local batch uses), and a worker killed mid-study has its
chunk run again on another worker, the table whole and equal to a local batch's."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]
METRICS = ["iae_speed", "iae_flux", "ss_speed", "ss_flux", "peak_current", "peak_voltage"]


def _study(tmp_path, samples):
    f = tmp_path / "mc.yaml"
    f.write_text("name: mc\nstop_time: 0.4\nmismatch: true\nplant: {R_r: 1.6}\n"
                 "profiles:\n  psi_ref: {type: constant, value: 0.95}\n"
                 "  omega_ref: {type: ramp, start: 0.12, end: 0.3, from: 0.0, to: 50.0}\n"
                 f"sweep:\n  samples: {samples}\n  seed: 7\n"
                 "  parameters:\n    plant.R_r: {tolerance: 0.15}\n")
    return f


def _batch(*args):
    argv = [sys.executable, "-m", "orchestration", "batch", *map(str, args), "--variant", "native",
            "--no-plot"]
    return subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)


@pytest.mark.slow
def test_a_killed_dask_worker_has_its_variants_run_again_and_the_table_is_whole(tmp_path, fmu_dir):
    from distributed import Client, LocalCluster

    samples = 24
    f = _study(tmp_path, samples)
    local = _batch(f, "--jobs", "2", "--out", tmp_path / "local", "--fmus", fmu_dir)
    _, err = local.communicate(timeout=900)
    assert local.returncode == 0, err[-2000:]
    out = tmp_path / "dask"
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster, Client(cluster) as client:
        p = _batch(f, "--scheduler", cluster.scheduler_address, "--out", out, "--fmus", fmu_dir)
        try:
            victim, t0 = None, time.monotonic()
            while victim is None and time.monotonic() - t0 < 300:
                assert p.poll() is None, p.communicate()
                busy = [w for w, keys in client.processing().items() if keys]
                started = list((out / "mc").glob("mc-*/metrics.json")) if (out / "mc").is_dir() else []
                if busy and started:  # a chunk's child runs on that worker: kill the worker mid-chunk
                    victim = client.run(os.getpid, workers=[busy[0]])[busy[0]]
                time.sleep(0.05)
            assert victim is not None, "no chunk ever started"
            os.kill(victim, signal.SIGKILL)
            stdout, stderr = p.communicate(timeout=900)
            assert busy[0] not in client.scheduler_info()["workers"]  # it died (its nanny started another)
        finally:
            if p.poll() is None:
                p.kill()
    assert p.returncode == 0, stderr[-3000:]
    t = pd.read_csv(out / "mc" / "sweep.csv")
    ref = pd.read_csv(tmp_path / "local" / "mc" / "sweep.csv").set_index("variant")
    assert len(ref) == samples and sorted(t["variant"]) == sorted(ref.index)  # each exactly once
    assert (t["status"] == "ok").all(), t[t["status"] != "ok"][["variant", "status", "message"]]
    s = pd.read_csv(out / "summary.csv")
    assert len(s) == samples and s["scenario"].is_unique and (s["status"] == "ok").all()
    got = t.set_index("variant").loc[ref.index]
    assert (got["plant.R_r"] == ref["plant.R_r"]).all()
    pd.testing.assert_frame_equal(got[METRICS], ref[METRICS], check_exact=True)

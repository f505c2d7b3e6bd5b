"""Running one probe in a child process of its own and reading what it printed: shared by the
co-simulation checks (:mod:`orchestration.check.checker`) and the model-exchange ones
(:mod:`orchestration.check.model_exchange`), so neither imports the other's module."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

from orchestration.process.interrupts import signal_name

TIMEOUT = 300.0  # [s] per probe


def run_probe_lines(mode, path, *extra, module="orchestration.check.probes"):
    """``(returncode, [JSON objects printed, in order], stderr tail)`` of one child probe."""
    cmd = [sys.executable, "-m", module, mode, str(path), *map(str, extra)]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=TIMEOUT)
    except subprocess.TimeoutExpired as exc:
        out = exc.stdout.decode("utf-8", "replace") if isinstance(exc.stdout, bytes) else exc.stdout or ""
        return None, _json_lines(out), f"timed out after {TIMEOUT:g} s"
    return proc.returncode, _json_lines(proc.stdout), proc.stderr.strip()[-300:]


def _json_lines(text):
    objects = []
    for line in text.splitlines():
        try:
            obj = json.loads(line)
        except ValueError:
            continue
        if isinstance(obj, dict):
            objects.append(obj)
    return objects


def died(code, tail):
    """The FAIL detail for a probe that did not exit with 0."""
    if code is None:
        return tail
    if code < 0 or code > 128:
        num = -code if code < 0 else code - 128
        how = f"killed by {signal_name(num)}" + (f" (exit status {code})" if code > 0 else "")
    else:
        how = f"exit status {code}"
    return f"the child process {how}" + (f": {tail}" if tail else "")


def reference_dir(md_root, references):
    name = md_root.get("modelName", "")
    for base in references:
        d = Path(base) / name
        if base is not None and (d / f"{name}_ref.csv").is_file():
            return d
    return None


def report(unit, probe):
    """The child's side: print the JSON result of ``probe()`` on ``unit`` (an extracted FMU with
    ``errors()`` and ``unzip``); an FMI call that fails is a ``{"ok": false}`` result with the FMU's
    log, the exit code stays 0; the extracted copy is removed whatever happens."""
    try:
        try:
            out = probe()
        except Exception as exc:  # noqa: BLE001 - an FMI call failed: the probe reports it
            out = {"ok": False, "detail": f"{exc}" + (f" (log: {unit.errors()})" if unit.errors() else "")}
    finally:
        shutil.rmtree(unit.unzip, ignore_errors=True)
    print(json.dumps(out))
    sys.stdout.flush()

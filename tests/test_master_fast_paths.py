"""The master's fast paths: what an FMU extraction keeps, the profile evaluator, the recorder's chunk
list that the stepping loop appends to, and the private ctypes pointers."""

import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import platform, platform_tuple

from orchestration.run.fmu_instance import (
    FMUInstance,
    RealPort,
    extract_owned,
    needed_to_run,
    remove_extracted,
)
from orchestration.run.recorder import Recorder
from orchestration.run.step_plans import evaluator


def test_extraction_keeps_this_platform_the_description_and_the_resources_only(tmp_path):
    members = ["modelDescription.xml", "resources/a.py", "resources/sub/b.csv", "sources/x.c",
               "documentation/index.html", f"binaries/{platform}/M.so", f"binaries/{platform_tuple}/M.so",
               "binaries/win64/M.dll", "binaries/darwin64/M.dylib", "binaries/aarch64-darwin/M.dylib"]
    fmu = tmp_path / "M.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        for m in members:
            z.writestr(m, m)
    d = extract_owned(fmu)
    try:
        kept = sorted(str(p.relative_to(d)) for p in Path(d).rglob("*") if p.is_file())
    finally:
        remove_extracted(d)
    expected = sorted(["modelDescription.xml", "resources/a.py", "resources/sub/b.csv",
                       f"binaries/{platform}/M.so", f"binaries/{platform_tuple}/M.so"])
    assert kept == expected
    assert not needed_to_run("sources/fmi2Functions.h")


@pytest.mark.parametrize("n", range(7))
def test_the_profile_evaluator_gives_each_function_at_t_in_order(n):
    funcs = [lambda t, i=i: t * (i + 1) + 0.1 * i for i in range(n)]
    evaluate = evaluator(funcs)
    for t in (0.0, 0.25, 1.7):
        assert evaluate(t) == tuple(t * (i + 1) + 0.1 * i for i in range(n))


def test_rows_appended_to_the_chunk_list_across_flushes_are_all_recorded():
    rec = Recorder(["time", "a", "flag"], chunk_rows=4)
    rows = rec.rows  # the stepping loop keeps this list for the whole run
    left = rec.chunk_rows
    for k in range(11):
        rows.append((k * 0.5, 2.0 * k, k % 2 == 0))
        left -= 1
        if not left:
            rec.flush()
            left = rec.chunk_rows
    assert rec.rows is rows
    rec.close()
    a = rec.arrays()
    assert rec.n_rows == 11
    np.testing.assert_array_equal(a["time"], [0.5 * k for k in range(11)])
    np.testing.assert_array_equal(a["a"], [2.0 * k for k in range(11)])
    np.testing.assert_array_equal(a["flag"], [1.0 if k % 2 == 0 else 0.0 for k in range(11)])


def test_the_fast_pointer_is_private_and_reads_what_fmpy_reads(fmu_dir):
    from orchestration.build import fmus

    plant, _ = fmus.paths(fmu_dir, "native")
    inst = FMUInstance(plant, "plant")
    try:
        inst.initialize(0.0)
        fast = inst.fast("fmi2GetReal")
        assert fast is not inst.raw("fmi2GetReal") and fast.argtypes is None
        assert inst.raw("fmi2GetReal").argtypes is not None  # fmpy's own pointer keeps its types
        names = [v.name for v in inst.md.modelVariables if v.causality == "output"]
        port = RealPort(inst, names)
        got = list(port.read())
        assert got == inst.slave.getReal(inst.vr(names))
    finally:
        inst.close()

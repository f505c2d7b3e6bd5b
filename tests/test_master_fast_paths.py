"""The master's fast paths: what an FMU extraction keeps, the profile evaluator, the recorder's chunk
list that the stepping loop appends to, and the private ctypes pointers."""

import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import platform, platform_tuple

from orchestration.results.recorder import Recorder
from orchestration.run.fmu_instance import (
    FMUInstance,
    RealPort,
    extract_owned,
    needed_to_run,
    remove_extracted,
)
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
    from orchestration.packaging import fmus

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


def test_raw_rows_decode_to_the_values_of_tuple_rows_in_column_order():
    """Rows given as bytes (doubles, int32, boolean bytes, in a permuted order) come back as the floats
    the same rows give as tuples, across flushes; a boolean byte other than 0 is 1.0."""
    import struct

    cols = ["time", "a", "b", "i", "flag", "p"]
    order = [0, 2, 1, 3, 4, 5]  # column "a" is the raw row's third value, "b" its second
    raw_rec, ref = Recorder(cols, chunk_rows=3), Recorder(cols, chunk_rows=3)
    raw = raw_rec.raw_rows((("<f8", 3), ("<i4", 1), ("?", 1), ("<f8", 1)), order)
    for k in range(8):
        t, a, b, i, flag, p = k * 1e-4, (-1.0) ** k / 3.0, 1e300 * k, k - 4, (0, 1, 2)[k % 3], 0.1 * k
        raw += struct.pack("<3di", t, b, a, i) + bytes([flag]) + struct.pack("<d", p)
        ref.rows.append((t, a, b, i, bool(flag), p))
        if k % 3 == 2:
            raw_rec.flush()
            ref.flush()
    for r in (raw_rec, ref):
        r.close()
    got, want = raw_rec.arrays(), ref.arrays()
    assert raw_rec.n_rows == ref.n_rows == 8 and not raw
    for c in cols:
        assert got[c].tobytes() == want[c].tobytes(), c
    with pytest.raises(ValueError, match="layout of 2 values for 6 columns"):
        Recorder(cols).raw_rows((("<f8", 2),))
    with pytest.raises(ValueError, match="not a permutation"):
        Recorder(cols).raw_rows((("<f8", 6),), [0, 0, 1, 2, 3, 4])


def _scenario(tmp_path, every=1, interval=1e-4):
    from orchestration.scenario.load import load_scenario

    f = tmp_path / "s.yaml"
    f.write_text(f"""name: s
stop_time: 0.05
step: 1.0e-4
controller_every: {every}
profiles:
  psi_ref: {{type: constant, value: 0.95}}
  omega_ref: {{type: ramp, start: 0.0, end: 0.05, to: 20.0}}
  T_load: {{type: step, time: 0.02, value: 5.0}}
record: {{interval: {interval}}}
""")
    return load_scenario(f)


@pytest.mark.parametrize("variant", ["native", "native-fmi3"])
def test_ports_wired_through_memory_record_what_picked_ports_record(fmu_dir, tmp_path, monkeypatch, variant):
    """The Gauss-Seidel loop with the ports wired through memory (chained_port) against the same loop
    with the inputs picked in Python (chained_port switched off): the same record to the last bit, with
    the controller every step or every other step and every row or every fifth recorded."""
    from orchestration.packaging import fmus
    from orchestration.run import master

    plant, ctrl = fmus.paths(fmu_dir, variant)
    real = master.chained_port
    for every, interval in ((1, 1e-4), (2, 5e-4)):
        sc = _scenario(tmp_path, every, interval)
        frames, made = {}, []
        for mode in ("chained", "picked"):
            def spy(*a, made=made):
                made.append(real(*a))
                return made[-1]

            monkeypatch.setattr(master, "chained_port", spy if mode == "chained" else (lambda *a: None))
            r = master.run(sc, plant, ctrl)
            assert r.ok, r.message
            frames[mode] = r.frame
        assert len(made) == 2 and all(c is not None for c in made)  # the chained loop did run
        a, b = frames["chained"], frames["picked"]
        assert list(a.columns) == list(b.columns) and a.shape == b.shape
        assert a.to_numpy().tobytes() == b.to_numpy().tobytes()


def test_chained_port_declines_what_it_cannot_wire(fmu_dir):
    """An output feeding two inputs, or an input fed by the unit itself, goes the picked way (None)."""
    from orchestration.packaging import fmus
    from orchestration.run.master import _outputs
    from orchestration.run.step_plans import chained_port
    from orchestration.scenario.system import CONTROLLER, DEFAULT_CONNECTIONS, PLANT, Connection

    plant_path, ctrl_path = fmus.paths(fmu_dir, "native")
    p, c = FMUInstance(plant_path, PLANT), FMUInstance(ctrl_path, CONTROLLER)
    try:
        outputs = {PLANT: _outputs(p), CONTROLLER: _outputs(c)}
        profiles = {"psi_ref": lambda t: 0.9, "omega_ref": lambda t: 1.0, "T_load": lambda t: 0.0}
        prof = [profiles[k] for k in sorted(profiles)]
        args = (outputs, profiles, prof)
        assert chained_port(p, PLANT, outputs[PLANT], c, CONTROLLER, DEFAULT_CONNECTIONS, *args) is not None
        twice = [x if x.target != "controller.psi_r_alpha" else Connection("plant.i_s_alpha", x.target)
                 for x in DEFAULT_CONNECTIONS]
        assert chained_port(p, PLANT, outputs[PLANT], c, CONTROLLER, twice, *args) is None
        own = [x if x.target != "plant.T_load" else Connection("plant.T_e", x.target)
               for x in DEFAULT_CONNECTIONS]
        assert chained_port(c, CONTROLLER, outputs[CONTROLLER], p, PLANT, own, *args) is None
    finally:
        p.close()
        c.close()


def test_the_collector_is_off_in_the_loop_and_as_it_was_after(fmu_dir, tmp_path, monkeypatch):
    import gc

    from orchestration.packaging import fmus
    from orchestration.run import master

    plant, ctrl = fmus.paths(fmu_dir, "native")
    sc = _scenario(tmp_path)
    seen, real = [], master.evaluator

    def spying(funcs):  # the profiles evaluated once per step, in the loop: is the collector on there?
        evaluate = real(funcs)
        return lambda t: seen.append(gc.isenabled()) or evaluate(t)

    monkeypatch.setattr(master, "evaluator", spying)
    for enabled in (True, False):
        (gc.enable if enabled else gc.disable)()
        try:
            assert master.run(sc, plant, ctrl).ok
            assert gc.isenabled() is enabled
        finally:
            gc.enable()
    assert seen and not any(seen)

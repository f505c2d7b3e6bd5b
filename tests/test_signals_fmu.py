"""The ScenarioSignals native FMU (fmu/signals/native_model.c, orchestration/packaging/signals_fmu.py).

Its outputs, stepped with fmpy's FMU2Slave on the scenario's grid, are compared with the Python
profiles' ``value(t_k)``, ``t_k = k h`` (the master's time), for every scenario of scenarios/ and
for hand-made profiles of every kind; malformed or oversize profiles files are refused with an FMI
error naming the file, the line and the text; a C host runs the FMU under valgrind.
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path
from types import MappingProxyType

import pytest
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu

from orchestration.packaging import signals_fmu
from orchestration.scenario.load import Scenario, load_scenario
from orchestration.scenario.profiles import Constant, Sum, parse_profile

sys.path.insert(0, str(Path(__file__).parent))
from fmu_helpers import Slave, open_fmu  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = sorted((ROOT / "scenarios").glob("*.yaml"))
SIGNALS = signals_fmu.SIGNALS


def scenario_of(profiles, step=1e-4, stop_time=0.1, path="hand-made.yaml"):
    """A Scenario with profiles given in their YAML form {name: spec}."""
    parsed = {"omega_ref": Constant(0.0), "T_load": Constant(0.0), "psi_ref": Constant(0.9)}
    for name, spec in profiles.items():
        p, problems = parse_profile(spec, f"profiles.{name}", path)
        assert not problems, problems
        parsed[name] = p
    return Scenario("hand_made", "", Path(path), stop_time, step, profiles=MappingProxyType(parsed))


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    """One ScenarioSignals FMU (of the default scenario); other profiles go through profiles_file."""
    out = tmp_path_factory.mktemp("signals")
    path = signals_fmu.build(load_scenario(ROOT / "scenarios" / "ramp_rated_load.yaml"), out)
    return open_fmu(path, str(out / "unzipped"))


def outputs_along(fmu, profiles_file, h, n, accumulate=False):
    """[(omega_ref, psi_ref, T_load) at t_k] for k = 0..n, stepping from k h (or an accumulated t)."""
    s = Slave(fmu, params={"profiles_file": str(profiles_file)} if profiles_file else None)
    rows = [s.get(list(SIGNALS))]
    t = 0.0
    for k in range(n):
        s.fmu.doStep(t, h)
        t = t + h if accumulate else (k + 1) * h
        rows.append(s.get(list(SIGNALS)))
    s.free()
    return rows


def largest_difference(sc, rows):
    """Largest |FMU - Python| / max(|Python|, 1e-300) over the rows (t_k = k h)."""
    worst = 0.0
    for k, row in enumerate(rows):
        t = k * sc.step
        for name, got in zip(SIGNALS, row):
            want = sc.profiles[name].value(t)
            if got != want:
                worst = max(worst, abs(got - want) / max(abs(want), 1e-300))
    return worst


def check_against_python(fmu, sc, tmp_path, accumulate=False):
    f = tmp_path / f"{sc.name}.txt"
    f.write_text(signals_fmu.profiles_text(sc))
    n = round(sc.stop_time / sc.step)
    worst = largest_difference(sc, outputs_along(fmu, f, sc.step, n, accumulate))
    print(f"ScenarioSignals vs profile.value(t_k): {sc.name}: largest relative difference {worst:.3g}")
    assert worst <= 1e-12, f"{sc.name}: largest relative difference {worst:.3g}"
    return worst


@pytest.mark.slow
@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.stem)
def test_every_scenario_equals_the_python_profiles_at_the_master_time(fmu, path, tmp_path):
    check_against_python(fmu, load_scenario(path), tmp_path)


def test_the_profiles_inside_the_fmu_are_used_by_default(fmu):
    """No profiles_file set: resources/profiles.txt, the default scenario's profiles."""
    sc = load_scenario(ROOT / "scenarios" / "ramp_rated_load.yaml")
    n = round(0.3 / sc.step)
    assert largest_difference(sc, outputs_along(fmu, None, sc.step, n)) == 0.0


HAND_MADE = {
    "constant": {"omega_ref": {"type": "constant", "value": -12.5}},
    # jumps exactly on grid times whose k h is not the decimal time (3000 * 1e-4 != 0.3), and between them
    "steps": {"omega_ref": [{"type": "step", "time": 0.03, "value": 50.0, "initial": -3.0},
                            {"type": "step", "time": 0.0301, "value": 7.0},
                            {"type": "step", "time": 0.07005, "value": 1.0}],
              "T_load": {"type": "step", "time": 0.0, "value": 4.0, "initial": 1.0}},
    "ramps": {"omega_ref": {"type": "ramp", "start": 0.02, "end": 0.07, "to": 100.0},
              "psi_ref": {"type": "ramp", "start": 0.0, "end": 0.033, "to": 0.5, "from": 1.1},
              "T_load": [{"type": "ramp", "start": 0.01, "end": 0.0123, "to": -7.0, "from": 3.0},
                         {"type": "ramp", "start": 0.05, "end": 0.09, "to": 2.0}]},
    "table": {"T_load": {"type": "table", "points": [[0.0, 1.0], [0.0123, 5.0], [0.05, 5.0], [0.07, -2.0],
                                                      [0.0800001, 3.0]]},
              "omega_ref": {"type": "table", "points": [[0.04, 10.0]]}},
    "sines": {"T_load": {"type": "sine", "amplitude": 3.0, "frequency": 37.0, "phase": 0.7, "offset": 1.5,
                         "start": 0.0421},
              "omega_ref": [{"type": "sine", "amplitude": 2.0, "frequency": 0.0, "phase": 1.0},
                            {"type": "sine", "amplitude": 1.0, "frequency": 1234.5}],
              "psi_ref": {"type": "sine", "amplitude": 0.1, "frequency": 50.0, "offset": 0.9}},
    "sum_of_every_kind": {"T_load": [
        {"type": "constant", "value": 0.25}, {"type": "step", "time": 0.05, "value": 2.0},
        {"type": "ramp", "start": 0.01, "end": 0.04, "to": 3.0, "from": -1.0},
        {"type": "table", "points": [[0.0, 0.0], [0.02, 1.0], [0.06, -1.0]]},
        {"type": "sine", "amplitude": 0.5, "frequency": 60.0, "phase": -0.3, "start": 0.015},
        {"type": "csv", "file": "load.csv", "value_column": 2}]},
}


@pytest.mark.parametrize("case", sorted(HAND_MADE))
@pytest.mark.parametrize("accumulate", [False, True], ids=["t=kh", "t+=h"])
def test_hand_made_profiles_of_every_kind(fmu, case, accumulate, tmp_path):
    """Also with an importer that accumulates its time (t + h + h ...): the grid snapping gives the
    values at k h all the same, jumps on grid times included."""
    (tmp_path / "load.csv").write_text("time;x;T [N m]\n0;9;0\n0.013;9;2.5\n0.0131;9;-1\n0.06;9;4\n")
    sc = scenario_of(HAND_MADE[case], path=str(tmp_path / "hand.yaml"))
    check_against_python(fmu, sc, tmp_path, accumulate)


def test_off_grid_steps_evaluate_at_the_communication_point(fmu, tmp_path):
    """An importer stepping 3e-5 s (not on the 1e-4 grid) gets value(t + h) of the point it reaches."""
    (tmp_path / "load.csv").write_text("0,0,1\n1,0,2\n")
    ramp = {"omega_ref": {"type": "ramp", "start": 0.0, "end": 1.0, "to": 1.0}}
    sc = scenario_of(HAND_MADE["sum_of_every_kind"] | ramp, path=str(tmp_path / "h.yaml"))
    f = tmp_path / "p.txt"
    f.write_text(signals_fmu.profiles_text(sc))
    s = Slave(fmu, params={"profiles_file": str(f)})
    t, h = 0.0, 3e-5
    checked = 0
    for _ in range(100):
        s.fmu.doStep(t, h)
        t += h
        if abs(t / 1e-4 - round(t / 1e-4)) > 1e-3:  # off the grid
            names = ["omega_ref", "T_load"]
            assert s.get(names) == [sc.profiles[n].value(t) for n in names]
            checked += 1
    s.free()
    assert checked >= 80


def test_the_fmu_validates_and_simulates_with_fmpy(tmp_path):
    from fmpy import simulate_fmu

    sc = load_scenario(ROOT / "scenarios" / "sinusoidal_load.yaml")
    path = signals_fmu.build(sc, tmp_path)
    assert validate_fmu(str(path)) == []
    r = simulate_fmu(str(path), stop_time=0.05, output_interval=sc.step, step_size=sc.step)
    for row in r:
        assert row["T_load"] == sc.profiles["T_load"].value(round(row["time"] / sc.step) * sc.step)


def test_fmi3_fmu_gives_the_same_values(tmp_path):
    from fmpy import extract, read_model_description
    from fmpy.fmi3 import FMU3Slave

    sc = load_scenario(ROOT / "scenarios" / "speed_reversal.yaml")
    path = signals_fmu.build(sc, tmp_path, fmi_version="3.0")
    assert validate_fmu(str(path)) == []
    md = read_model_description(str(path))
    s = FMU3Slave(guid=md.guid, unzipDirectory=extract(str(path)), modelIdentifier="ScenarioSignals")
    s.instantiate()
    s.enterInitializationMode(startTime=0.0)
    s.exitInitializationMode()
    for k in range(round(sc.stop_time / sc.step)):
        s.doStep(k * sc.step, sc.step)
        assert s.getFloat64([0, 1, 2]) == [sc.profiles[n].value((k + 1) * sc.step) for n in SIGNALS]
        assert s.getFloat64([signals_fmu.VR_TIME]) == [k * sc.step + sc.step]  # the point reached
    s.terminate()
    s.freeInstance()


def test_model_description_units_and_variables(tmp_path):
    from fmpy import read_model_description

    sc = load_scenario(ROOT / "scenarios" / "ramp_rated_load.yaml")
    md = read_model_description(str(signals_fmu.build(sc, tmp_path)))
    got = {v.name: (v.causality, v.type, v.unit) for v in md.modelVariables}
    assert got == {"omega_ref": ("output", "Real", "rad/s"), "psi_ref": ("output", "Real", "Wb"),
                   "T_load": ("output", "Real", "N m"), "profiles_file": ("parameter", "String", None)}
    assert (md.defaultExperiment.stopTime, md.defaultExperiment.stepSize) == (str(sc.stop_time), str(sc.step))


# --- refusals -------------------------------------------------------------------------------------

GOOD = "satmotor-signals 1\ngrid 0.0001\nsignal omega_ref\nconstant 1\nsignal psi_ref\nconstant 0.9\n" \
       "signal T_load\nconstant 0\nend\n"
BIG = "\n".join(f"{i * 1e-3!r} 1.0" for i in range(signals_fmu.MAX_POINTS + 1))
MALFORMED = {  # file text -> (line, text the message must quote)
    "not a number": (GOOD.replace("constant 1\n", "constant 1.0x\n"), 4, "1.0x"),
    "nan": (GOOD.replace("constant 1\n", "constant nan\n"), 4, "nan"),
    "hex": (GOOD.replace("constant 1\n", "constant 0x1p3\n"), 4, "0x1p3"),
    "overflow": (GOOD.replace("constant 1\n", "constant 1e999\n"), 4, "1e999"),
    "too few numbers": (GOOD.replace("constant 0\n", "step 0.1 2\n"), 8, "step TIME INITIAL VALUE"),
    "extra field": (GOOD.replace("constant 0\n", "constant 0 5\n"), 8, "5"),
    "unknown keyword": (GOOD.replace("constant 0\n", "square 0 1\n"), 8, "square"),
    "unknown signal": (GOOD.replace("signal T_load", "signal T_lod"), 7, "T_lod"),
    "missing signal": (GOOD.replace("signal T_load\nconstant 0\n", ""), 7, "T_load"),
    "duplicate signal": (GOOD.replace("signal T_load", "signal psi_ref"), 7, "psi_ref"),
    "no end": (GOOD.replace("end\n", ""), 8, "end"),
    "after end": (GOOD + "constant 3\n", 10, "constant"),
    "bad header": ("satmotor-signal 1\n" + GOOD.split("\n", 1)[1], 1, "satmotor-signal"),
    "version 2": (GOOD.replace("satmotor-signals 1", "satmotor-signals 2"), 1, "'2'"),
    "negative grid": (GOOD.replace("grid 0.0001", "grid -1"), 2, "'-1'"),
    "ramp end before start": (GOOD.replace("constant 0\n", "ramp 0.5 0.5 0 1 2\n"), 8, "0.5"),
    "negative frequency": (GOOD.replace("constant 0\n", "sine 1 -50 0 0 0\n"), 8, "-50"),
    "table times decrease": (GOOD.replace("constant 0\n", "table 3\n0 1\n0.2 1\n0.1 1\n"), 11, "0.10000"),
    "table cut short": (GOOD.replace("constant 0\nend\n", "table 3\n0 1\n"), 10, "inside a table"),
    "table N not an integer": (GOOD.replace("constant 0\n", "table 2.5\n0 1\n"), 8, "2.5"),
    "table too big": (GOOD.replace("constant 0\n", f"table {signals_fmu.MAX_POINTS + 1}\n{BIG}\n"), 8,
                      "8193 points does not fit"),
    "too many terms": (GOOD.replace("constant 0\n", "constant 0\n" * (signals_fmu.MAX_TERMS + 1)),
                       8 + signals_fmu.MAX_TERMS, "32"),
    "empty signal": (GOOD.replace("signal psi_ref\nconstant 0.9\n", "signal psi_ref\n"), 6, "T_load"),
    "line too long": (GOOD.replace("constant 0\n", "constant " + "1" * 600 + "\n"), 8, "'512'"),
    "NUL byte": (GOOD.replace("constant 0\n", "constant 0\0 junk\n"), 8, "NUL byte"),
    "CRLF and comments are fine but a bad number is named": (
        GOOD.replace("\n", "\r\n").replace("constant 0\r", "constant 0,5 # decimal comma\r"), 8, "'0,5'"),
    "empty file": ("", 0, "satmotor-signals 1"),
}


@pytest.mark.parametrize("case", sorted(MALFORMED))
def test_a_malformed_profiles_file_is_an_fmi_error_naming_file_line_and_text(fmu, case, tmp_path):
    text, line, quoted = MALFORMED[case]
    f = tmp_path / "bad profiles.txt"
    f.write_text(text)
    log = []
    s = Slave(fmu, initialize=False, log=log)
    with pytest.raises(FMICallException) as exc:
        s.initialize({"profiles_file": str(f)})
    assert exc.value.status == 3  # fmi2Error
    msg = s.messages(3)
    assert f"{f}, line {line}:" in msg and quoted in msg, msg
    with pytest.raises(FMICallException):  # the instance stays in the error phase
        s.fmu.doStep(0.0, 1e-4)
    s.free()


def test_crlf_comments_blank_lines_and_a_hand_written_file_read_fine(fmu, tmp_path):
    text = ("# a hand-written profiles file\r\n\r\nsatmotor-signals 1   # format\r\ngrid 0\r\n"
            "signal T_load\r\n  step\t0.5  1  2  # N m\r\n\r\nsignal omega_ref\r\ntable 2\r\n0 0\r\n1 10\r\n"
            "signal psi_ref\r\nconstant .9\r\nconstant 1e-2\r\nend\r\n")
    f = tmp_path / "hand.txt"
    f.write_bytes(text.encode())
    s = Slave(fmu, params={"profiles_file": str(f)})
    s.fmu.doStep(0.0, 0.5)
    assert s.get(list(SIGNALS)) == [5.0, 0.9 + 1e-2, 2.0]
    s.free()


def test_a_missing_profiles_file_is_an_fmi_error(fmu, tmp_path):
    s = Slave(fmu, initialize=False)
    with pytest.raises(FMICallException):
        s.initialize({"profiles_file": str(tmp_path / "nowhere.txt")})
    assert "profiles_file = " in s.messages(3) and "nowhere.txt" in s.messages(3)
    s.free()


def test_the_locale_decimal_comma_does_not_change_the_numbers(fmu, tmp_path):
    """A host that set LC_NUMERIC to a decimal-comma locale (in a child process) reads '0.9' as 0.9."""
    import locale

    code = f"""
import locale, sys
sys.path.insert(0, {str(Path(__file__).parent)!r})
for name in ("de_DE.UTF-8", "de_DE.utf8", "fr_FR.UTF-8", "C.UTF-8"):
    try:
        locale.setlocale(locale.LC_NUMERIC, name)
        break
    except locale.Error:
        pass
from fmu_helpers import Slave, open_fmu
s = Slave(open_fmu({str(fmu.path)!r}, {str(fmu.unzip)!r}))
print(locale.localeconv()["decimal_point"], s.get(["psi_ref", "T_load"]))
"""
    env = dict(os.environ)
    if shutil.which("localedef"):  # compile a German locale into tmp_path when none is installed
        made = subprocess.run(["localedef", "-i", "de_DE", "-f", "UTF-8", str(tmp_path / "de_DE.UTF-8")],
                              capture_output=True)
        if made.returncode == 0:
            env["LOCPATH"] = str(tmp_path)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, env=env)
    assert r.returncode == 0, r.stderr
    dp, values = r.stdout.split(" ", 1)
    if dp != ",":
        pytest.skip(f"no decimal-comma locale installed (got {dp!r}, {locale.getlocale()})")
    sc = load_scenario(ROOT / "scenarios" / "ramp_rated_load.yaml")
    assert values.strip() == repr([sc.profiles["psi_ref"].value(0.0), sc.profiles["T_load"].value(0.0)])


def test_python_refuses_what_the_fmu_cannot_hold(tmp_path):
    sc = scenario_of({"T_load": {"type": "table", "points": [[i * 1e-3, 1.0] for i in range(8193)]}},
                     path=str(tmp_path / "big.yaml"))
    with pytest.raises(signals_fmu.UnsupportedProfile) as exc:
        signals_fmu.profiles_text(sc)
    assert str(exc.value).startswith(f"{tmp_path / 'big.yaml'}: profiles.T_load = '8193 points': ")
    terms = [{"type": "constant", "value": 1.0}] * (signals_fmu.MAX_TERMS + 1)
    with pytest.raises(signals_fmu.UnsupportedProfile, match=r"profiles\.omega_ref = '33 terms'"):
        signals_fmu.profiles_text(scenario_of({"omega_ref": terms}))
    nested = scenario_of({})
    nested = Scenario(nested.name, "", Path("n.yaml"), 0.1, 1e-4, profiles=MappingProxyType(
        {**nested.profiles, "T_load": Sum((Constant(1.0), Sum((Constant(2.0), Constant(3.0)))))}))
    with pytest.raises(signals_fmu.UnsupportedProfile, match=r"n\.yaml: profiles\.T_load\[1\] = Sum"):
        signals_fmu.profiles_text(nested)
    alien = Scenario("a", "", Path("a.yaml"), 0.1, 1e-4, profiles=MappingProxyType(
        {"omega_ref": Constant(0.0), "psi_ref": Constant(0.9), "T_load": math.sin}))
    with pytest.raises(signals_fmu.UnsupportedProfile, match=r"a\.yaml: profiles\.T_load = <built-in"):
        signals_fmu.profiles_text(alien)


@pytest.mark.skipif(shutil.which("gcc") is None or shutil.which("nm") is None, reason="needs gcc and nm")
def test_no_global_mutable_state_in_the_model(tmp_path):
    """No writable data (bss/data/common symbols) in the compiled model (with its generated tables and the
    shared value accessors): every instance independent."""
    from orchestration.packaging.native import compiler as native_build
    from orchestration.packaging.native import tables as native_tables

    generated = native_tables.model_files(signals_fmu.MODEL_NAME, tmp_path, signals_fmu.VARIABLES)
    sources = [p for p in [*signals_fmu.sources(), *generated] if p.suffix == ".c"]
    for src in sources:  # the model, its generated tables and the shared value accessors
        obj = tmp_path / (src.stem + ".o")
        subprocess.run(["gcc", "-std=c99", "-O2", "-fPIC", "-c", f"-I{native_build.fmi_headers_dir()}",
                        f"-I{tmp_path}", f"-I{native_build.GLUE_DIR}", f"-I{src.parent}",
                        f"-I{signals_fmu.sources()[1].parent}", str(src), "-o", str(obj)],
                       check=True, capture_output=True)
        out = subprocess.run(["nm", "-f", "sysv", str(obj)], capture_output=True, text=True,
                             check=True).stdout
        rows = [[c.strip() for c in line.split("|")] for line in out.splitlines() if line.count("|") == 6]
        assert rows and [r for r in rows if r[2] in "bBdDcC" and not r[6].startswith(".data.rel.ro")] == []


# --- a C host, under valgrind ---------------------------------------------------------------------

@pytest.mark.slow
@pytest.mark.skipif(shutil.which("valgrind") is None or shutil.which("gcc") is None,
                    reason="needs valgrind and gcc")
def test_a_c_host_under_valgrind_reads_the_profiles_and_refuses_a_bad_file(fmu, tmp_path):
    """tests/native_c_host.c dlopens the FMU: the outputs after 700 steps are the Python values, and a
    malformed resources/profiles.txt fails initialization (exit 5); valgrind finds no error in either."""
    from fmpy import __file__ as fmpy_file

    host = tmp_path / "host"
    headers = Path(fmpy_file).parent / "c-code"
    subprocess.run(["gcc", "-std=c99", "-Wall", "-Wextra", "-Werror", f"-I{headers}",
                    str(ROOT / "tests" / "native_c_host.c"), "-o", str(host), "-ldl"], check=True)
    sc = scenario_of(HAND_MADE["sines"] | {"omega_ref": HAND_MADE["steps"]["omega_ref"]})
    unzipped = tmp_path / "fmu"
    with zipfile.ZipFile(fmu.path) as z:
        z.extractall(unzipped)
    lib = unzipped / "binaries" / "linux64" / "ScenarioSignals.so"
    runs = {}
    for label, text in (("good", signals_fmu.profiles_text(sc)), ("bad", MALFORMED["table too big"][0])):
        (unzipped / "resources" / "profiles.txt").write_text(text)
        cmd = ["valgrind", "--error-exitcode=99", "--leak-check=full", "--errors-for-leak-kinds=definite",
               "-q", str(host), str(lib), fmu.md.guid, (unzipped / "resources").as_uri(), "700", "1e-4",
               "--", "0", "1", "2"]
        runs[label] = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    good, bad = runs["good"], runs["bad"]
    assert good.returncode == 0, good.stderr
    assert [float(x) for x in good.stdout.split()] == [sc.profiles[n].value(700 * 1e-4) for n in SIGNALS]
    assert bad.returncode == 5 and "8193 points does not fit" in bad.stderr, bad.stderr

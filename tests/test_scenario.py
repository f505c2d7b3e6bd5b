"""Scenario files and time profiles: the library is valid, the profiles match hand computations,
the default scenario is satmotor's RampScenario, and every kind of bad file is reported with
its file, field path and value (all problems at once)."""

import copy
import math
import pickle
from pathlib import Path

import pytest

from orchestration.cli.commands import main as cli_main
from orchestration.scenario.load import (
    Scenario,
    ScenarioError,
    interface_variables,
    load_scenario,
)
from orchestration.scenario.problems import Problem
from orchestration.scenario.profiles import (
    Constant,
    Csv,
    Ramp,
    Sine,
    Step,
    Sum,
    Table,
    parse_profile,
)
from orchestration.scenario.validate import check_scenario_file, validate_scenario_file
from satmotor.control.backstepping import ControllerConfig
from satmotor.machine.params import RatedData
from satmotor.simulate import RampScenario

LIBRARY = Path(__file__).resolve().parents[1] / "scenarios"
FILES = sorted(LIBRARY.glob("*.yaml"))


# --- the library -------------------------------------------------------------------------------


def test_library_has_the_required_scenarios():
    names = {f.stem for f in FILES}
    assert len(FILES) >= 7
    assert {"startup_premag", "ramp_rated_load", "speed_reversal", "deep_saturation", "sinusoidal_load",
            "rotor_resistance_mismatch", "field_weakening"} <= names


@pytest.mark.parametrize("path", FILES, ids=[f.stem for f in FILES])
def test_library_scenario_is_valid(path):
    assert validate_scenario_file(path) == []
    assert validate_scenario_file(path, interface_variables()) == []
    assert check_scenario_file(path) == ([], [])  # no silent mismatch, no load beyond the limit
    sc = load_scenario(path)
    assert isinstance(sc, Scenario)
    assert sc.name == path.stem
    assert sc.stop_time <= 2.0
    assert set(sc.profiles) == {"omega_ref", "psi_ref", "T_load"}
    for p in sc.profiles.values():
        for t in (0.0, 0.1 * sc.stop_time, 0.5 * sc.stop_time, sc.stop_time):
            assert math.isfinite(p.value(t))
    assert sc.profiles["psi_ref"].value(sc.stop_time) > 0


def test_library_uses_a_csv_profile_and_a_sum():
    kinds = {type(p) for f in FILES for p in load_scenario(f).profiles.values()}
    assert Csv in kinds and Sum in kinds


def test_default_scenario_reproduces_ramp_scenario():
    sc = load_scenario(LIBRARY / "ramp_rated_load.yaml")
    ref = RampScenario()
    assert sc.stop_time == ref.t_end
    assert sc.Ts == ControllerConfig().Ts and sc.step == 1e-4 and sc.controller_every == 1
    assert sc.algorithm == "gauss-seidel" and dict(sc.plant) == {} and dict(sc.controller) == {}
    assert sc.acceptance.ss_window == (ref.t_steady, ref.t_end)
    assert sc.acceptance.ss_speed == 0.01 and sc.acceptance.ss_flux == 0.01
    assert ref.T_load == round(RatedData().T_n, 2)
    w, psi, load = (sc.profiles[k] for k in ("omega_ref", "psi_ref", "T_load"))
    n = round(sc.stop_time / sc.Ts)
    for k in range(n + 1):  # bit for bit at every sample time of the master (t = k h)
        t = k * sc.step
        assert w.value(t) == ref.omega_ref(t)
        assert load.value(t) == ref.load(t)
        assert psi.value(t) == ref.psi_ref


def test_rotor_resistance_mismatch_overrides_only_the_plant():
    sc = load_scenario(LIBRARY / "rotor_resistance_mismatch.yaml")
    assert dict(sc.plant) == {"R_r": pytest.approx(1.5 * 1.395)} and "R_r" not in sc.controller
    assert sc.mismatch and dict(sc.motor) == {}  # said to be intended


def test_every_library_mismatch_is_declared():
    import yaml

    from satmotor.interface import MOTOR_PARAMETERS

    for f in FILES:
        sc = load_scenario(f)
        differ = [v.name for v in MOTOR_PARAMETERS
                  if sc.plant.get(v.name, v.start) != sc.controller.get(v.name, v.start)]
        # a study that varies the plant's motor: its variants differ from the controller's model
        varied = (yaml.safe_load(f.read_text()).get("sweep") or {}).get("parameters") or {}
        differ += [p for p in varied if p.split(".")[0] == "plant" and p.split(".")[1] in
                   {v.name for v in MOTOR_PARAMETERS}]
        assert bool(differ) == sc.mismatch, (f.stem, differ)


def test_field_weakening_scenarios_leave_the_flux_to_the_drive():
    # psi_ref is the nominal flux (constant); the controller's automatic field weakening (on by default)
    # lowers it above base speed, where the nominal flux would need more than V_dc/sqrt(3)
    from satmotor.control.field_weakening import steady_point_at_flux
    from satmotor.machine.params import MotorParams

    v_max = 540.0 / math.sqrt(3.0)
    for name, w, T in (("field_weakening", 250.0, 16.0), ("rated_point", 150.0, 26.71),
                       ("field_weakening_constant_power", 375.0, 4000.0 / 375.0)):
        sc = load_scenario(LIBRARY / f"{name}.yaml")
        assert sc.controller.get("field_weakening", True) and sc.controller.get("V_dc", 540.0) == 540.0
        assert isinstance(sc.profiles["psi_ref"], Constant) and sc.profiles["psi_ref"].value(0.0) == 0.95
        assert sc.profiles["omega_ref"].value(sc.stop_time) == w
        assert sc.profiles["T_load"].value(sc.stop_time) == pytest.approx(T, rel=1e-4)
        assert steady_point_at_flux(MotorParams(), 0.95, T, w)[1][1] > v_max


# --- profiles against hand computations --------------------------------------------------------


def _parse(spec, file="<string>"):
    p, problems = parse_profile(spec, "profiles.x", file)
    assert problems == []
    return p


def test_constant_and_step():
    assert _parse({"type": "constant", "value": 2}).value(7.0) == 2.0
    s = _parse({"type": "step", "time": 0.5, "value": 3.0, "initial": -1})
    assert isinstance(s, Step)
    assert s.value(0.0) == -1.0 and s.value(0.4999999) == -1.0 and s.value(0.5) == 3.0 and s.value(9) == 3.0
    assert _parse({"type": "step", "time": 1, "value": 4}).value(0.9) == 0.0


def test_ramp():
    r = _parse({"type": "ramp", "start": 1.0, "end": 3.0, "from": 10.0, "to": 30.0})
    assert isinstance(r, Ramp)
    assert r.value(0.0) == 10.0 and r.value(1.0) == 10.0
    assert r.value(2.0) == pytest.approx(20.0, abs=1e-12) and r.value(1.5) == pytest.approx(15.0, abs=1e-12)
    assert r.value(3.0) == pytest.approx(30.0, abs=1e-12) and r.value(100.0) == 30.0
    down = _parse({"type": "ramp", "start": 0, "end": 2, "from": 5, "to": -5})
    assert down.value(0.5) == pytest.approx(2.5, abs=1e-12)
    assert down.value(3) == -5.0 and down.value(-1) == 5.0


def test_table():
    tb = _parse({"type": "table", "points": [[0, 1], [1, 3], [3, -1]]})
    assert isinstance(tb, Table)
    expected = {-1.0: 1.0, 0.0: 1.0, 0.25: 1.5, 0.5: 2.0, 1.0: 3.0, 2.0: 1.0, 2.5: 0.0, 3.0: -1.0, 10.0: -1.0}
    for t, v in expected.items():
        assert tb.value(t) == pytest.approx(v, abs=1e-12), t
    assert _parse({"type": "table", "points": [[0.2, 4.0]]}).value(5.0) == 4.0


def test_sine():
    s = _parse({"type": "sine", "amplitude": 2.0, "frequency": 5.0, "phase": 0.3, "offset": 1.0,
                "start": 0.2})
    assert isinstance(s, Sine)
    assert s.value(0.1) == 0.0
    assert s.value(0.2) == pytest.approx(1.0 + 2.0 * math.sin(0.3), abs=1e-12)
    # 0.05 s after the start is a quarter period of 5 Hz: sin(pi/2 + 0.3) = cos(0.3)
    assert s.value(0.25) == pytest.approx(1.0 + 2.0 * math.cos(0.3), abs=1e-12)
    assert s.value(0.3) == pytest.approx(1.0 - 2.0 * math.sin(0.3), abs=1e-12)  # half a period


def test_csv_with_header_and_columns(tmp_path):
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "p.csv").write_text("a,time,torque\n9,0.0,0.0\n9,1.0,10.0\n9,2.0,4.0\n")
    scen = tmp_path / "s.yaml"  # relative paths resolve against the scenario's directory
    c = _parse({"type": "csv", "file": "data/p.csv", "time_column": 1, "value_column": 2}, str(scen))
    assert isinstance(c, Csv) and c.times == (0.0, 1.0, 2.0)
    assert c.value(0.5) == pytest.approx(5.0) and c.value(1.5) == pytest.approx(7.0)
    assert c.value(-1) == 0.0 and c.value(3.0) == 4.0


def test_library_csv_profile():
    sc = load_scenario(LIBRARY / "load_cycle_csv.yaml")
    p = sc.profiles["T_load"]
    assert p.value(0.5) == 0.0 and p.value(0.925) == pytest.approx(10.0) and p.value(1.0) == 20.0
    assert p.value(1.6) == pytest.approx(26.71) and p.value(2.0) == 10.0


def test_sum():
    s = _parse([{"type": "step", "time": 0.6, "value": 13.0},
                {"type": "sine", "amplitude": 8.0, "frequency": 5.0, "start": 0.6}])
    assert isinstance(s, Sum) and len(s.parts) == 2
    assert s.value(0.5) == 0.0
    for t in (0.6, 0.61, 0.65, 0.73, 1.0, 1.234):
        assert s.value(t) == pytest.approx(13.0 + 8.0 * math.sin(2 * math.pi * 5 * t), abs=1e-9)
    assert _parse([{"type": "constant", "value": 1.5}]) == Constant(1.5)  # one part: no Sum


def test_profile_problems_name_the_path():
    p, problems = parse_profile([{"type": "constant", "value": 1}, {"type": "step", "time": -1, "value": 2,
                                                                    "extra": 0}], "profiles.T_load", "f.yaml")
    assert p is None
    fields = {q.field for q in problems}
    assert fields == {"profiles.T_load[1].time", "profiles.T_load[1].extra"}
    assert all(isinstance(q, Problem) and q.file == "f.yaml" for q in problems)
    _, problems = parse_profile({"type": "constant", "value": float("nan")}, "profiles.x")
    assert problems[0].message == "must be finite"


# --- bad files ---------------------------------------------------------------------------------

BASE = """\
name: t
stop_time: 0.01
step: 1.0e-4
profiles:
  psi_ref: {type: constant, value: 0.95}
  omega_ref: {type: ramp, start: 0.0, end: 0.005, to: 10.0}
  T_load: {type: step, time: 0.005, value: 1.0}
"""


def _edit(old, new):
    assert old in BASE
    return BASE.replace(old, new)


PSI = "  psi_ref: {type: constant, value: 0.95}\n"
W = "  omega_ref: {type: ramp, start: 0.0, end: 0.005, to: 10.0}\n"
TL = "  T_load: {type: step, time: 0.005, value: 1.0}\n"

# (id, text, field path, value as shown) -- the message must hold all three and the file
BAD = [
    ("unknown top-level key", BASE + "colour: red\n", "colour", "'red'"),
    ("missing psi_ref", _edit(PSI, ""), "profiles.psi_ref", "<missing>"),
    ("missing name", _edit("name: t\n", ""), "name", "<missing>"),
    ("negative stop_time", _edit("stop_time: 0.01", "stop_time: -1.0"), "stop_time", "-1.0"),
    ("step not dividing stop_time", _edit("step: 1.0e-4", "step: 3.0e-3"), "stop_time", "0.01"),
    ("unknown profile type", _edit(W, "  omega_ref: {type: square, value: 1.0}\n"), "profiles.omega_ref.type",
     "'square'"),
    ("table times not increasing",
     _edit(W, "  omega_ref: {type: table, points: [[0, 0], [0.5, 1], [0.4, 2]]}\n"),
     "profiles.omega_ref.points[2][0]", "0.4"),
    ("bool for a number", _edit(TL, "  T_load: {type: step, time: true, value: 1.0}\n"),
     "profiles.T_load.time", "True"),
    ("1e-4 read as a string", _edit("step: 1.0e-4", "step: 1e-4"), "step", "'1e-4'"),
    ("unknown plant parameter", BASE + "plant: {R_x: 1.0}\n", "plant.R_x", "1.0"),
    ("overriding a plant output", BASE + "plant: {omega_m: 3.0}\n", "plant.omega_m", "3.0"),
    ("overriding a controller input", BASE + "controller: {psi_ref: 1.0}\n", "controller.psi_ref", "1.0"),
    ("wrong type for a String parameter", BASE + "plant: {curve: 3}\n", "plant.curve", "3"),
    ("unknown curve name", BASE + "plant: {curve: spline}\n", "plant.curve", "'spline'"),
    ("float for an Integer parameter", BASE + "plant: {n_p: 2.5}\n", "plant.n_p", "2.5"),
    ("controller Ts override", BASE + "controller: {Ts: 2.0e-4}\n", "controller.Ts", "0.0002"),
    ("record output that does not exist", BASE + "record: {outputs: [plant.nope]}\n", "record.outputs[0]",
     "'plant.nope'"),
    ("record interval not a multiple", BASE + "record: {interval: 1.5e-4}\n", "record.interval", "0.00015"),
    ("unknown acceptance key", BASE + "acceptance: {ss_torque: 0.1}\n", "acceptance.ss_torque", "0.1"),
    ("negative acceptance bound", BASE + "acceptance: {ss_speed: -0.1}\n", "acceptance.ss_speed", "-0.1"),
    ("ss_window beyond stop_time", BASE + "acceptance: {ss_window: [0.0, 0.5]}\n", "acceptance.ss_window[1]",
     "0.5"),
    ("missing CSV file", _edit(TL, "  T_load: {type: csv, file: nope.csv}\n"), "profiles.T_load.file",
     "'nope.csv'"),
    ("invalid YAML syntax", BASE + "plant: {R_s: [1.0\n", "(yaml syntax)", "'line "),
    ("controller_every zero", BASE + "controller_every: 0\n", "controller_every", "0"),
    ("unknown algorithm", BASE + "algorithm: newton\n", "algorithm", "'newton'"),
    ("bad name", _edit("name: t", "name: my run"), "name", "'my run'"),
    ("non-finite number", _edit("stop_time: 0.01", "stop_time: .inf"), "stop_time", "inf"),
    ("ramp end before start", _edit(W, "  omega_ref: {type: ramp, start: 0.004, end: 0.002, to: 1.0}\n"),
     "profiles.omega_ref.end", "0.002"),
    ("negative fan load", BASE + "plant: {B_2: -1.0e-3}\n", "plant.B_2", "-0.001"),
    ("non-finite fan load", BASE + "plant: {B_2: .nan}\n", "plant.B_2", "nan"),
    ("noise on a signal the controller does not get", BASE + "measurements: {noise: {T_e: 0.1}}\n",
     "measurements.noise.T_e", "0.1"),
    ("negative noise", BASE + "measurements: {noise: {omega_m: -0.1}}\n", "measurements.noise.omega_m",
     "-0.1"),
    ("non-integer seed", BASE + "measurements: {seed: 2.5}\n", "measurements.seed", "2.5"),
    ("sum part problem",
     _edit(TL, "  T_load: [{type: constant, value: 1.0}, {type: sine, amplitude: 1.0}]\n"),
     "profiles.T_load[1].frequency", "<missing>"),
]


@pytest.mark.parametrize("text, field, shown", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_file_is_reported(tmp_path, capsys, text, field, shown):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    msg = str(info.value)
    assert str(path) in msg
    line = next((ln for ln in msg.splitlines() if f": {field} = " in ln), None)
    assert line is not None, msg
    assert f"{field} = {shown}" in line, msg
    assert isinstance(info.value, ValueError) and info.value.problems
    assert validate_scenario_file(path) == info.value.problems  # the validator returns, never raises
    # and the command line says so with a non-zero exit, naming the file and the field
    assert cli_main(["validate", str(path), "--fmus", str(tmp_path / "no_fmus")]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and field in err


def test_string_number_gets_a_spelling_hint(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(_edit("step: 1.0e-4", "step: 1e-4"))
    (problem,) = validate_scenario_file(path)
    assert "write 1.0e-4" in problem.message


def test_three_problems_at_once(tmp_path):
    path = tmp_path / "three.yaml"
    path.write_text(_edit("stop_time: 0.01", "stop_time: -1") + "colour: red\nplant: {R_x: 1.0}\n")
    problems = validate_scenario_file(path)
    assert [p.field for p in problems] == ["colour", "stop_time", "plant.R_x"]
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert "3 problem(s)" in str(info.value)
    for f in ("colour = 'red'", "stop_time = -1", "plant.R_x = 1.0"):
        assert f in str(info.value)


def test_missing_file_and_non_mapping(tmp_path):
    (p,) = validate_scenario_file(tmp_path / "none.yaml")
    assert "cannot read" in p.message and "none.yaml" in str(p)
    path = tmp_path / "list.yaml"
    path.write_text("- 1\n- 2\n")
    (p,) = validate_scenario_file(path)
    assert "mapping" in p.message


def test_variables_from_the_fmus_are_used(tmp_path):
    path = tmp_path / "v.yaml"
    path.write_text(BASE + "plant: {R_s: 1.5, extra_gain: 2}\n")
    assert [p.field for p in validate_scenario_file(path)] == ["plant.extra_gain"]
    variables = interface_variables()
    variables["plant"] = dict(variables["plant"], extra_gain=("parameter", "Integer"))
    del variables["plant"]["R_s"]
    assert [p.field for p in validate_scenario_file(path, variables)] == ["plant.R_s"]


def test_defaults_and_overrides(tmp_path):
    path = tmp_path / "d.yaml"
    path.write_text("name: d\nstop_time: 1\nprofiles: {psi_ref: {type: constant, value: 1}}\n"
                    "step: 5.0e-5\ncontroller_every: 2\nalgorithm: jacobi\n"
                    "plant: {n_p: 2, curve: linear}\ncontroller: {mode: pi, c1: 300}\n")
    sc = load_scenario(path)
    assert sc.Ts == pytest.approx(1e-4) and sc.algorithm == "jacobi" and sc.description == ""
    assert sc.profiles["omega_ref"].value(0.5) == 0.0 and sc.profiles["T_load"].value(0.5) == 0.0
    assert sc.record.interval == 5e-5 and sc.record.outputs == () and sc.acceptance is None
    assert dict(sc.plant) == {"n_p": 2, "curve": "linear"}
    assert dict(sc.controller) == {"mode": "pi", "c1": 300.0}
    with pytest.raises(AttributeError):
        sc.stop_time = 2.0  # frozen


@pytest.mark.parametrize("content, expected", [
    ("t,v\n0,1\n0.5,2\n0.4,3\n", "line 4: time 0.4"),
    ("0,1\n0.5\n", "line 2: 1 column(s)"),
    ("t,v\n0,1\nx,2\n", "line 3: not numbers"),
    ("t,v\n", "holds no data rows"),
    ("0,1\n-1,nan\n", "line 2"),
])
def test_bad_csv_content(tmp_path, content, expected):
    (tmp_path / "p.csv").write_text(content)
    path = tmp_path / "s.yaml"
    path.write_text(_edit(TL, "  T_load: {type: csv, file: p.csv}\n"))
    (problem,) = validate_scenario_file(path)
    assert problem.field == "profiles.T_load.file" and problem.value == "p.csv"
    assert expected in problem.message


def test_scenario_pickles_and_copies():
    for f in FILES:
        sc = load_scenario(f)
        for back in (pickle.loads(pickle.dumps(sc)), copy.deepcopy(sc)):
            assert back == sc
            assert all(back.profiles[k].value(0.75) == sc.profiles[k].value(0.75) for k in sc.profiles)


def test_unhashable_type_and_empty_list(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(_edit(TL, "  T_load: {type: [step]}\n"))
    assert [p.field for p in validate_scenario_file(path)] == ["profiles.T_load.type"]
    path.write_text(_edit(TL, "  T_load: []\n"))
    assert [p.field for p in validate_scenario_file(path)] == ["profiles.T_load"]


# --- the motor: section, mismatch notes, one pass, the load against the current limit ----------


def _notes(path):
    problems, notes = check_scenario_file(path)
    assert problems == []
    return notes


def test_motor_section_goes_to_both_units_and_unit_entries_override_it(tmp_path):
    path = tmp_path / "m.yaml"
    path.write_text(BASE + "motor: {R_r: 1.2, J: 0.02, curve: linear}\n"
                    "plant: {J: 0.02, B_2: 1.0e-3}\ncontroller: {I_max: 25.0}\n")
    sc = load_scenario(path)
    assert dict(sc.plant) == {"R_r": 1.2, "J": 0.02, "curve": "linear", "B_2": 1.0e-3}
    assert dict(sc.controller) == {"R_r": 1.2, "J": 0.02, "curve": "linear", "I_max": 25.0}
    assert dict(sc.motor) == {"R_r": 1.2, "J": 0.02, "curve": "linear"} and not sc.mismatch
    assert sc.notes == () and _notes(path) == []


def test_a_motor_parameter_set_on_one_unit_is_a_note_naming_file_field_and_values(tmp_path, capsys):
    path = tmp_path / "m.yaml"
    path.write_text(BASE + "motor: {R_r: 1.2}\nplant: {R_r: 1.5, J: 0.05}\ncontroller: {L_m0: 0.25}\n")
    notes = _notes(path)
    by_field = {n.field: str(n) for n in notes}
    assert set(by_field) == {"plant.R_r", "plant.J", "controller.L_m0"}  # one line per parameter
    assert by_field["plant.R_r"].startswith(f"{path}: note: plant.R_r: plant 1.5 Ohm, controller 1.2 Ohm")
    assert "plant 0.05 kg m2, controller 0.0131 kg m2 (default)" in by_field["plant.J"]
    assert "plant 0.2772 H (default), controller 0.25 H" in by_field["controller.L_m0"]
    assert all("mismatch: true" in line for line in by_field.values())
    sc = load_scenario(path)
    assert sc.notes == tuple(notes)
    assert pickle.loads(pickle.dumps(sc)) == sc and copy.deepcopy(sc).notes == sc.notes  # process pools
    # validate says it on stderr, one line each, and the file stays valid
    assert cli_main(["validate", str(path), "--fmus", str(tmp_path / "no_fmus")]) == 0
    out, err = capsys.readouterr()
    assert "valid (3 note(s))" in out
    assert sorted(ln for ln in err.splitlines() if ": note: " in ln) == sorted(by_field.values())


def test_mismatch_true_silences_the_notes_and_is_itself_noted_when_nothing_differs(tmp_path):
    path = tmp_path / "m.yaml"
    path.write_text(BASE + "mismatch: true\nplant: {R_r: 2.0925}\n")
    assert _notes(path) == [] and load_scenario(path).mismatch is True
    path.write_text(BASE + "mismatch: true\nmotor: {R_r: 2.0925}\n")
    (note,) = _notes(path)
    assert note.field == "mismatch" and "same motor parameters" in note.message


def test_the_same_value_given_twice_is_no_mismatch(tmp_path):
    path = tmp_path / "m.yaml"
    path.write_text(BASE + "plant: {R_r: 1.5}\ncontroller: {R_r: 1.5}\n")
    assert _notes(path) == []


@pytest.mark.parametrize("text, field, words", [
    ("motor: {B_2: 1.0e-3}\n", "motor.B_2", "a plant parameter only: set it under plant:"),
    ("motor: {I_max: 20.0}\n", "motor.I_max", "a controller parameter only: set it under controller:"),
    ("motor: {omega_m: 1.0}\n", "motor.omega_m", "not a motor parameter"),
    ("motor: [1, 2]\n", "motor", "must be a mapping"),
    ("motor: {R_r: -1.0}\n", "motor.R_r", "> 0"),
    ("motor: {n_p: 2.5}\n", "motor.n_p", "integer"),
    ("motor: {curve: spline}\n", "motor.curve", "must be one of"),
    ("mismatch: yes please\n", "mismatch", "true or false"),
])
def test_bad_motor_section(tmp_path, text, field, words):
    path = tmp_path / "m.yaml"
    path.write_text(BASE + text)
    problems = validate_scenario_file(path)
    assert [p.field for p in problems] == [field]  # a bad motor value: once, not once per unit
    assert words in problems[0].message and str(path) in str(problems[0])


@pytest.mark.parametrize("section, name, bad, choices", [
    ("plant", "dc_link", "capacitr", "ideal, capacitor"), ("plant", "dc_source", "grid", "dc, rectifier"),
    ("plant", "inverter", "PWM", "average, pwm"),
    ("controller", "flux_source", "estimated", "measured, observer"),
    ("controller", "observer", "closed-loop", "closed_loop, current_model"),
    ("controller", "speed_source", "observer", "measured, estimated"),
    ("controller", "load_mode", "Known", "known, estimated"),
])
def test_a_string_parameter_outside_its_choices_is_a_problem_of_the_file(tmp_path, section, name, bad,
                                                                        choices):
    """Every String parameter with choices (satmotor.interface Variable.choices) is checked when the file
    is read, naming the field, the value and the choices (written out here)."""
    path = tmp_path / "s.yaml"
    path.write_text(BASE + f"{section}: {{{name}: {bad}}}\n")
    (problem,) = validate_scenario_file(path)
    assert (problem.field, problem.value) == (f"{section}.{name}", bad)
    assert problem.message == f"must be one of {choices}"


def test_schema_problems_and_bad_values_are_reported_in_one_pass(tmp_path):
    path = tmp_path / "all.yaml"
    path.write_text(BASE + "colour: red\nplant: {R_s: abc, l_s: -1.0e-3}\ncontroller: {I_max: -3}\n"
                    "motor: {R_r: -1.0}\nrecord: {interval: 1.5e-4}\n")
    problems = validate_scenario_file(path)
    assert {(p.field, p.value) for p in problems} == {
        ("colour", "red"), ("plant.R_s", "abc"), ("record.interval", 1.5e-4),  # the schema's
        ("plant.l_s", -1.0e-3), ("controller.I_max", -3.0), ("motor.R_r", -1.0)}  # the physics'
    assert all(p.file == str(path) for p in problems)


def test_an_unreachable_flux_is_found_beside_a_schema_problem(tmp_path):
    path = tmp_path / "psi.yaml"
    path.write_text(_edit(PSI, "  psi_ref: {type: constant, value: 5.0}\n") + "colour: red\n")
    assert [p.field for p in validate_scenario_file(path)] == ["colour", "profiles.psi_ref"]


def _textbook_torque(psi, I_max, L_m=0.2772, l_r=5.839e-3, n_p=2):
    """3/2 n_p L_m/(l_r + L_m) psi_r i_sq with i_sd = psi_r / L_m (constant inductance, k = 1)."""
    return 1.5 * n_p * L_m / (l_r + L_m) * psi * math.sqrt(I_max**2 - (psi / L_m) ** 2)


@pytest.mark.parametrize("share, noted", [(1.01, True), (0.99, False)])
def test_a_load_beyond_the_current_limits_torque_is_noted(tmp_path, share, noted):
    T = share * _textbook_torque(0.95, 20.0)
    path = tmp_path / "load.yaml"
    path.write_text(_edit(TL, f"  T_load: {{type: step, time: 0.005, value: {-T!r}}}\n")
                    + "motor: {curve: linear}\ncontroller: {I_max: 20.0}\n")
    notes = _notes(path)
    assert [n.field for n in notes] == (["profiles.T_load"] if noted else [])
    if noted:
        assert notes[0].value == pytest.approx(T) and "20 A" in notes[0].message
        assert f"{_textbook_torque(0.95, 20.0):.4g} N m" in notes[0].message


def test_the_torque_limit_takes_the_best_flux_of_a_varying_set_point(tmp_path):
    # psi_ref from 0.3 to 0.95 Wb: the limit is the largest torque over those set-points (at 0.95)
    T = 0.99 * _textbook_torque(0.95, 20.0)
    path = tmp_path / "load.yaml"
    path.write_text(_edit(PSI, "  psi_ref: {type: ramp, start: 0.0, end: 0.01, from: 0.3, to: 0.95}\n")
                    .replace(TL, f"  T_load: {{type: constant, value: {T!r}}}\n")
                    + "motor: {curve: linear}\ncontroller: {I_max: 20.0}\n")
    assert _notes(path) == []


# --- a scenario that cannot be silently wrong: a key twice, values off by a unit ----------------------

PLAIN = "name: s\nstop_time: 0.1\nprofiles:\n  psi_ref: {type: constant, value: 0.9}\n"


def test_a_key_given_twice_is_refused_with_its_line(tmp_path, capsys):
    path = tmp_path / "twice.yaml"
    path.write_text("name: twice\nstop_time: 0.1\nmotor: {J: 0.02}\nprofiles:\n"
                    "  psi_ref: {type: constant, value: 0.9}\n"
                    "  T_load: {type: step, time: 0.05, value: 5.0}\n"
                    "  T_load: {type: step, time: 0.05, value: 10.0}\n"
                    "  omega_ref: [{type: step, time: 0.0, value: 1.0, value: 2.0}]\n"
                    "motor:\n  R_s: 1.5\n")
    problems = validate_scenario_file(path)
    assert [(p.field, p.value) for p in problems] == [("profiles.T_load", "line 7"),
                                                      ("profiles.omega_ref[0].value", "line 8"),
                                                      ("motor", "line 9")]
    assert "given twice (first on line 3)" in problems[2].message
    with pytest.raises(ScenarioError, match="given twice"):
        load_scenario(path)
    assert cli_main(["validate", str(path), "--fmus", str(tmp_path / "no_fmus")]) == 2
    assert f"{path}: motor = 'line 9': given twice" in capsys.readouterr().err


def test_a_merge_key_and_an_alias_are_not_duplicates(tmp_path):
    path = tmp_path / "merge.yaml"
    path.write_text("name: merge\nstop_time: 0.1\nprofiles:\n  psi_ref: &flux {type: constant, value: 0.9}\n"
                    "  T_load: {<<: *flux, value: 2.0}\n")
    assert validate_scenario_file(path) == []
    assert load_scenario(path).profiles["T_load"].level == 2.0


@pytest.mark.parametrize("extra, field, words", [
    ("plant: {T_s0: 80.0}\n", "plant.T_s0",
     "T_s0 = 80 K is below 200 K (-193.1 degC): Celsius written for Kelvin? (80 degC = 353.15 K)"),
    ("motor: {J: 13.1}\n", "motor.J", "J = 13.1 kg m2 is 1000 x the default motor's 0.0131 kg m2: far "
     "outside its range (a unit prefix or a misplaced decimal point?)"),
    ("plant: {R_s: 1405}\nmismatch: true\n", "plant.R_s",
     "R_s = 1405 Ohm is 1000 x the default motor's 1.405 Ohm"),
    ("motor: {R_r: 0.01}\n", "motor.R_r",
     "R_r = 0.01 Ohm is 1/139.5 x the default motor's 1.395 Ohm: far outside its range (a typo?)"),
    ("  omega_ref: {type: ramp, start: 0.0, end: 0.05, to: 1430.0}\n", "profiles.omega_ref",
     "1430 rad/s is close to the motor's rated speed in rpm, 1430 rpm: rpm written for rad/s? (1430 rpm = "
     "149.7 rad/s"),
    ("  omega_ref: {type: step, time: 0.0, value: 500.0}\n", "profiles.omega_ref",
     "500 rad/s is 3.34 x the motor's rated speed 149.7 rad/s (1430 rpm): far outside its range"),
    ("plant: {omega_m0: 1500.0}\n", "plant.omega_m0",
     "1500 rad/s is close to the motor's rated speed in rpm"),
], ids=["celsius", "inertia", "resistance", "small_resistance", "rpm", "fast", "rpm_initial"])
def test_a_value_off_by_a_unit_is_noted_with_the_likely_mistake(tmp_path, extra, field, words):
    from satmotor.machine.params import MotorParams

    m = MotorParams()  # the references the notes quote: the default motor and its 1430 rpm name plate
    assert (m.J, m.R_s, m.R_r, RatedData().n_n) == (0.0131, 1.405, 1.395, 1430.0)
    path = tmp_path / "s.yaml"
    path.write_text(PLAIN + extra)
    problems, notes = check_scenario_file(path)
    assert problems == [] and [n.field for n in notes] == [field], notes
    assert words in notes[0].message, notes[0].message


@pytest.mark.parametrize("extra", ["plant: {T_s0: 200.0}\n", "motor: {J: 1.3}\n", "motor: {R_s: 0.0141}\n",
                                   "  omega_ref: {type: step, time: 0.0, value: 440.0}\n",
                                   "plant: {T_amb: 293.15, omega_m0: -440.0}\n"])
def test_values_within_the_bounds_are_not_noted(tmp_path, extra):
    path = tmp_path / "s.yaml"
    path.write_text(PLAIN + extra)
    assert check_scenario_file(path) == ([], [])


def test_a_preset_motor_is_compared_with_its_own_values(tmp_path):
    from satmotor.machine.library import MOTORS

    name = next(n for n in MOTORS if n != "default_4kw")
    J = MOTORS[name].values["J"]
    path = tmp_path / "s.yaml"
    path.write_text(PLAIN + f"motor: {{preset: {name}, J: {J * 150!r}}}\n")
    notes = [n for n in check_scenario_file(path)[1] if n.field == "motor.J"]
    assert len(notes) == 1 and f"the {name} motor's {J:g} kg m2" in notes[0].message


def test_validate_a_directory_checks_what_batch_would_run(tmp_path, capsys):
    d = tmp_path / "many"
    d.mkdir()
    for name in ("a", "b"):
        (d / f"{name}.yaml").write_text(PLAIN.replace("name: s", f"name: {name}"))
    no_fmus = str(tmp_path / "no_fmus")
    assert cli_main(["validate", str(d), "--fmus", no_fmus]) == 0
    out = capsys.readouterr().out
    assert f"{d / 'a.yaml'}: valid" in out and f"{d / 'b.yaml'}: valid" in out
    (d / "c.yaml").write_text(PLAIN.replace("name: s", "name: a"))  # batch refuses two files of one name
    assert cli_main(["validate", str(d), "--fmus", no_fmus]) == 2
    assert "scenario name 'a' is used by 2 files" in capsys.readouterr().err
    (tmp_path / "empty").mkdir()
    assert cli_main(["validate", str(tmp_path / "empty"), "--fmus", no_fmus]) == 2
    assert cli_main(["validate", str(LIBRARY), "--fmus", no_fmus]) == 0

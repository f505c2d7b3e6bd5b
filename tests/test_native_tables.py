"""The generator of the native C tables (orchestration/build/native/tables.py): what it writes, compiled and
read back through ctypes, is what the interface tables and the Python settings dataclasses say; a
parameter added to a table reaches the C struct and its copy from the value store with no C edit."""

from __future__ import annotations

import ctypes
import dataclasses
import re
import shutil
import subprocess

import pytest
from native_core import ControllerParams, MotorParams, PlantParams, load

import satmotor.interface as itf
from orchestration.build.native import tables as native_tables
from satmotor.control.backstepping import BacksteppingGains, ControllerConfig
from satmotor.control.drive import DriveConfig
from satmotor.control.ifoc import IFOCGains

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")


@pytest.fixture(scope="module")
def lib():
    """The session's core library through a CDLL object of its own: the argument types other test
    modules declare on theirs (their own ctypes classes) do not apply here."""
    own = ctypes.CDLL(load()._name)
    for struct in (MotorParams, PlantParams, ControllerParams):
        getattr(own, struct.__name__ + "_size").restype = ctypes.c_size_t
    return own


def _value(struct, name, type_):
    v = getattr(struct, name)
    return v.decode() if type_ == "String" else v


PLANT_OWN = [v for v in itf.PLANT_PARAMETERS if v.c_struct == "plant"]
CONTROLLER_OWN = [v for v in itf.CONTROLLER_PARAMETERS if v.c_struct == "controller"]  # in member order


@pytest.mark.parametrize("struct, table", [(MotorParams, itf.MOTOR_PARAMETERS), (PlantParams, PLANT_OWN),
                                           (ControllerParams, CONTROLLER_OWN)])
def test_the_c_parameter_defaults_are_the_start_values_of_the_table(lib, struct, table):
    p = struct()
    getattr(lib, struct.__name__ + "_default")(ctypes.byref(p))
    assert getattr(lib, struct.__name__ + "_size")() == ctypes.sizeof(struct)
    assert [n for n, _ in struct._fields_] == [v.name for v in table]
    for v in table:
        want = int(v.start) if v.type == "Boolean" else v.start
        assert _value(p, v.name, v.type) == want, v.name


class _Gains(ctypes.Structure):
    _fields_ = [(n, ctypes.c_double) for n in ("c1", "c2", "d1", "d2", "c0", "d0")]


class _LawConfig(ctypes.Structure):  # sm_law.h
    _fields_ = [("V_dc", ctypes.c_double), ("Ts", ctypes.c_double), ("phi_min", ctypes.c_double),
                ("load_estimated", ctypes.c_int), ("g_theta", ctypes.c_double),
                ("theta_max", ctypes.c_double), ("use_stator_flux", ctypes.c_int)]


class _DriveConfig(ctypes.Structure):  # sm_drive.h
    _fields_ = [(n, ctypes.c_double) for n in ("ref_bandwidth", "I_max", "premag_fraction", "premag_boost",
                                               "premag_gain", "premag_time_max", "premag_min_fraction",
                                               "premag_speed_tol")] + [
        ("observer", ctypes.c_int), ("delay_samples", ctypes.c_int), ("closed_loop", ctypes.c_int),
        ("speed_estimated", ctypes.c_int), ("speed_bandwidth", ctypes.c_double),
        ("field_weakening", ctypes.c_int), ("fw_voltage_ratio", ctypes.c_double),
        ("current_limit_gain", ctypes.c_double), ("host_delay_samples", ctypes.c_int)]


class _IFOCGains(ctypes.Structure):  # sm_ifoc.h
    _fields_ = [(n, ctypes.c_double) for n in ("w_c", "w_speed", "I_max", "V_dc")]


def test_the_c_defaults_of_the_settings_structs_are_the_python_dataclass_defaults(lib):
    for fn, struct, py in (("sm_gains_default", _Gains, BacksteppingGains()),
                           ("sm_law_config_default", _LawConfig, ControllerConfig()),
                           ("sm_drive_config_default", _DriveConfig, DriveConfig()),
                           ("sm_ifoc_gains_default", _IFOCGains, IFOCGains())):
        c = struct()
        getattr(lib, fn)(ctypes.byref(c))
        want = dataclasses.asdict(py)
        want.pop("true_i_mu", None)
        if "load_mode" in want:
            want["load_estimated"] = int(want.pop("load_mode") == "estimated")
        if "flux_source" in want:
            want["closed_loop"] = int(want.pop("observer") == "closed_loop")
            want["observer"] = int(want.pop("flux_source") == "observer")
            want["speed_estimated"] = int(want.pop("speed_source") == "estimated")
        got = {n: getattr(c, n) for n, _ in struct._fields_}
        assert got == {k: (int(v) if isinstance(v, bool) else v) for k, v in want.items()}, fn


def test_a_parameter_added_to_a_table_reaches_the_struct_and_the_copy():
    extra = itf.Variable("R_fe", "parameter", "Real", 250.0, "Ohm", "iron-loss resistance", "motor")
    table = (*native_tables.unit_variables("SaturatedInductionMotor"), extra)
    src = native_tables.model_source("SaturatedInductionMotor", table)
    head = native_tables.model_header("SaturatedInductionMotor", table)
    assert f"#define SM_VR_R_fe {len(table) - 1}" in head
    assert "    p->R_fe = v->r[SM_VR_R_fe];" in src.split("void sm_vars_motor_params")[1]
    assert "    v->r[SM_VR_R_fe] = 250.0; /* R_fe [Ohm] */" in src
    assert '{SM_VR_R_fe, FG_REAL, FG_PARAMETER, "R_fe"},' in src


def test_the_generated_inputs_and_outputs_follow_the_tables():
    for name, (inputs, outputs) in {"SaturatedInductionMotor": (itf.PLANT_INPUTS, itf.PLANT_OUTPUTS),
                                    "BacksteppingController": (itf.CONTROLLER_INPUTS,
                                                               itf.CONTROLLER_OUTPUTS)}.items():
        table = native_tables.unit_variables(name)
        src = native_tables.model_source(name, table)
        vr = {v.name: i for i, v in enumerate(table)}
        order = src.split("SM_INPUT_VR[SM_N_INPUTS] = {")[1].split("}")[0]
        assert order == ", ".join(f"SM_VR_{v.name}" for v in inputs)
        order = src.split("SM_OUTPUT_VR[SM_N_OUTPUTS] = {")[1].split("}")[0]
        assert order == ", ".join(f"SM_VR_{v.name}" for v in outputs)
        head = native_tables.model_header(name, table)
        for v in (*inputs, *outputs):
            assert f"#define SM_VR_{v.name} {vr[v.name]}\n" in head


def _c_constants(tmp_path, names):
    """The values of the C constants ``names`` of the generated ``sm_params.h`` (written into ``tmp_path``),
    compiled into a program that prints them."""
    native_tables.core_files(tmp_path)
    (tmp_path / "p.c").write_text('#include <stdio.h>\n#include "sm_params.h"\nint main(void)\n{\n'
                                  + "".join(f'    printf("%d\\n", (int){n});\n' for n in names)
                                  + "    return 0;\n}\n")
    exe = tmp_path / "p"
    subprocess.run([shutil.which("gcc"), "-std=c99", "-Wall", "-Werror", f"-I{tmp_path}", "-o", str(exe),
                    str(tmp_path / "p.c")], check=True)
    run = subprocess.run([str(exe)], check=True, capture_output=True, text=True)
    return [int(s) for s in run.stdout.split()]


MEAS = {"SM_MEAS_I_S_A": "i_s_alpha", "SM_MEAS_I_S_B": "i_s_beta", "SM_MEAS_PSI_R_A": "psi_r_alpha",
        "SM_MEAS_PSI_R_B": "psi_r_beta", "SM_MEAS_PSI_S_A": "psi_s_alpha", "SM_MEAS_PSI_S_B": "psi_s_beta",
        "SM_MEAS_OMEGA_M": "omega_m"}


def test_the_c_measurement_layout_is_the_controllers_input_order_and_the_pythons(tmp_path):
    """SM_MEAS_* (compiled from the generated sm_params.h and printed) are the positions of their inputs
    in CONTROLLER_INPUTS and equal measurements.MEAS_*: sm_controller.c passes its inputs through."""
    from satmotor.control import measurements
    got = _c_constants(tmp_path, (*MEAS, "SM_MEAS_LEN"))
    names = [v.name for v in itf.CONTROLLER_INPUTS]
    assert got[:-1] == [names.index(n) for n in MEAS.values()]
    assert got[:-1] == [getattr(measurements, n[3:]) for n in MEAS]
    assert got[-1] == measurements.MEAS_LEN == len(MEAS)


def test_the_generation_fails_when_the_python_layout_leaves_the_input_order(monkeypatch):
    from satmotor.control import measurements
    monkeypatch.setattr(measurements, "MEAS_NAMES", ("i_s_alpha", "i_s_beta", "psi_r_alpha", "psi_r_beta",
                                                     "omega_m", "psi_s_alpha", "psi_s_beta"))
    with pytest.raises(ValueError, match="not the controller's first inputs"):
        native_tables.core_header()


# --- the String parameters' choices (Variable.choices -> sm_params.h enums and sm_choice_parse) ---------

STRING_PARAMETERS = {v.name: v for table in (itf.PLANT_PARAMETERS, itf.CONTROLLER_PARAMETERS)
                     for v in table if v.type == "String"}
CHOICES = {n: v.choices for n, v in STRING_PARAMETERS.items() if v.choices}
SM_ERR_PARAM, SM_ERR_ARG = 1, 4  # sm_common.h


def test_every_string_parameter_but_the_file_name_has_choices_and_its_description_names_them():
    assert {n for n, v in STRING_PARAMETERS.items() if not v.choices} == {"table_file"}  # any path
    assert set(CHOICES) == {"curve", "dc_link", "dc_source", "inverter", "mode", "load_mode", "flux_source",
                            "observer", "speed_source"}
    for name, choices in CHOICES.items():
        words = set(re.findall(r"[A-Za-z_]+", STRING_PARAMETERS[name].description))
        assert set(choices) <= words, (name, choices)
        assert STRING_PARAMETERS[name].start in choices, name


def _parse(lib, param, value):
    out, msg = ctypes.c_int(-7), ctypes.create_string_buffer(512)
    st = lib.sm_choice_parse(param, value, ctypes.byref(out), msg, ctypes.sizeof(msg))
    return st, out.value, msg.value.decode()


def test_the_c_parser_takes_every_choice_of_the_tables_and_refuses_the_rest_naming_them(lib):
    """Every choice of every String parameter parsed through ctypes to its position in the table's
    tuple; near misses (case, a blank, empty, a quote) refused with "name = 'value': must be one of
    a, b" (written out here from the tables), the output left as it was."""
    lib.sm_choice_param_name.restype = lib.sm_choice_text.restype = ctypes.c_char_p
    names = []
    while (name := lib.sm_choice_param_name(len(names))) is not None:
        names.append(name.decode())
    assert sorted(names) == sorted(CHOICES)
    for k, name in enumerate(names):
        choices = CHOICES[name]
        assert lib.sm_choice_count(k) == len(choices)
        assert [lib.sm_choice_text(k, j).decode() for j in range(len(choices))] == list(choices)
        assert lib.sm_choice_text(k, len(choices)) is None and lib.sm_choice_text(k, -1) is None
        for j, c in enumerate(choices):
            assert _parse(lib, k, c.encode()) == (0, j, ""), (name, c)
        for bad in (choices[0].upper(), choices[-1] + " ", "", "it's"):
            st, out, msg = _parse(lib, k, bad.encode())
            assert (st, out) == (SM_ERR_PARAM, -7), (name, bad)
            assert msg == f"{name} = {bad!r}: must be one of {', '.join(choices)}"
    assert _parse(lib, len(names), b"x")[0] == SM_ERR_ARG and lib.sm_choice_count(len(names)) == 0
    assert lib.sm_choice_param_name(-1) is None


def test_the_c_choice_enums_are_the_positions_in_the_tables(tmp_path):
    """SM_CHOICE_<name>_<value> and SM_CHOICE_PARAM_<name> (compiled from the generated sm_params.h and
    printed): each value its position in the table's choices, each parameter the parser's number of it."""
    consts = [f"SM_CHOICE_{n}_{c}" for n, cs in CHOICES.items() for c in cs]
    got = _c_constants(tmp_path, (*consts, *(f"SM_CHOICE_PARAM_{n}" for n in CHOICES)))
    assert got[:len(consts)] == [j for cs in CHOICES.values() for j in range(len(cs))]
    assert got[len(consts):] == list(range(len(CHOICES)))


def test_choices_on_a_number_or_not_a_c_name_fail_the_generation(monkeypatch):
    for bad in (itf.Variable("R_s", "parameter", "Real", 1.0, "Ohm", "", "motor", ("a", "b")),
                itf.Variable("curve", "parameter", "String", "a b", "", "", "motor", ("a b", "c"))):
        units = {"plant": (itf.PLANT_INPUTS, itf.PLANT_OUTPUTS, (bad,))}
        monkeypatch.setattr(native_tables, "UNITS", units)
        with pytest.raises(ValueError, match="choices"):
            native_tables._choices()

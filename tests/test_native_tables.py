"""The generator of the native C tables (orchestration/packaging/native/tables.py): what it writes,
compiled and read back through ctypes, is what the interface tables and the Python settings dataclasses say; a
parameter added to a table reaches the C struct and its copy from the value store with no C edit."""

from __future__ import annotations

import ctypes
import dataclasses
import random
import re
import shutil
import subprocess

import c_binding
import pytest
from native_core import BINDING, STRUCTS, ControllerParams, MotorParams, PlantParams, load, params

import satmotor.interface as itf
from orchestration.packaging.native import tables as native_tables
from satmotor.control.backstepping import BacksteppingGains, ControllerConfig
from satmotor.control.drive import DriveConfig
from satmotor.control.ifoc import IFOCGains
from satmotor.errors import ParameterError

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")


@pytest.fixture(scope="module")
def lib():
    """The session's core library, its signatures read from the headers (native_core.declare)."""
    return load()


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


# the settings structs, read from the headers (sm_law.h, sm_drive.h, sm_ifoc.h)
_Gains, _LawConfig = STRUCTS["sm_gains"], STRUCTS["sm_law_config"]
_DriveConfig, _IFOCGains = STRUCTS["sm_drive_config"], STRUCTS["sm_ifoc_gains"]


def test_the_c_defaults_of_the_settings_structs_are_the_python_dataclass_defaults(lib):
    for fn, struct, py in (("sm_gains_default", _Gains, BacksteppingGains()),
                           ("sm_law_config_default", _LawConfig, ControllerConfig()),
                           ("sm_drive_config_default", _DriveConfig, DriveConfig()),
                           ("sm_ifoc_gains_default", _IFOCGains, IFOCGains())):
        c = struct()
        getattr(lib, fn)(ctypes.byref(c))
        got = {n: getattr(c, n) for n, _ in struct._fields_}
        assert got == _coded(dataclasses.asdict(py)), fn


def _coded(fields):
    """A settings dataclass's fields as the C struct's members: the strings coded as DATACLASS_STRUCTS
    says (written out here), booleans as 0/1."""
    fields.pop("true_i_mu", None)
    if "load_mode" in fields:
        fields["load_estimated"] = int(fields.pop("load_mode") == "estimated")
    if "modulation" in fields:
        fields["overmodulation"] = int(fields.pop("modulation") == "overmodulation")
    if "flux_source" in fields:
        fields["closed_loop"] = int(fields.pop("observer") == "closed_loop")
        fields["observer"] = int(fields.pop("flux_source") == "observer")
        fields["speed_estimated"] = int(fields.pop("speed_source") == "estimated")
    if "flux_mode" in fields:
        fields["loss_minimizing"] = int(fields.pop("flux_mode") == "loss_minimizing")
    return {k: (int(v) if isinstance(v, bool) else v) for k, v in fields.items()}


def _python_setting(setting, values):
    """The Python dataclass of ``setting`` as ControllerUnit fills it from the flat ``values``, as the C
    struct's members (coded as DATACLASS_STRUCTS says: written out here)."""
    return _coded(dataclasses.asdict(itf.SETTINGS[setting](**{n: values[n] for n in itf.FILLED[setting]})))


@pytest.mark.parametrize("seed", range(4))
def test_the_generated_copy_into_the_settings_structs_is_the_pythons(lib, seed):
    """sm_controller_settings (generated from Variable.fills) at random parameter values: every member of
    the four C structs equals the field of the dataclass ControllerUnit builds from the same values."""
    rng = random.Random(seed)
    filled = {v for v in itf.CONTROLLER_PARAMETERS if any(v.name in names for names in itf.FILLED.values())}
    while True:  # each number a little off its default (up or down), until the dataclasses accept them all
        values = {v.name: rng.choice(v.choices) if v.choices else rng.random() < 0.5 if v.type == "Boolean"
                  else rng.randrange(2) if v.type == "Integer"
                  else v.start * (1.0 + rng.uniform(-0.1, 0.1)) + rng.uniform(0.0, 1e-3) for v in filled}
        values["speed_source"] = rng.choice(("measured", "estimated"))
        try:
            for setting in itf.SETTINGS:
                _python_setting(setting, values)
            break
        except ParameterError:
            continue
    structs = {s: STRUCTS[f"sm_{s}"]() for s in itf.SETTINGS}
    lib.sm_controller_settings(params(lib, ControllerParams, values), *(structs[s] for s in itf.SETTINGS))
    for s, c in structs.items():
        assert {n: getattr(c, n) for n, _ in c._fields_} == _python_setting(s, values), s


def test_a_fill_of_an_unknown_setting_or_field_or_of_an_uncoded_string_fails(monkeypatch):
    c1 = itf.CONTROLLER_PARAMETERS[0]
    monkeypatch.setattr(itf, "CONTROLLER_PARAMETERS", (c1._replace(fills=("gainz",)),))
    with pytest.raises(ValueError, match="c1: fills 'gainz', not one of gains, law_config"):
        itf._filled()
    monkeypatch.setattr(itf, "CONTROLLER_PARAMETERS", (c1._replace(name="c9"),))
    with pytest.raises(ValueError, match="c9: fills 'gains', but BacksteppingGains has no field c9"):
        itf._filled()
    monkeypatch.undo()
    monkeypatch.setattr(itf, "FILLED", {**itf.FILLED, "gains": ("mode",)})
    with pytest.raises(ValueError, match="mode fills gains: a String needs its coding"):
        native_tables.core_source()


def test_the_header_structs_have_the_c_sizes(lib):
    """Every struct the headers declare with a size function (sm_<x>_size, sm_<x>_params_size) has the
    size of its ctypes class read from the headers (tests/c_binding.py: members, types, arrays)."""
    sized = [n for n in BINDING.structs if n + "_size" in BINDING.functions]
    assert {"sm_curve", "sm_motor", "sm_controller", "sm_drive", "sm_inverter",
            "sm_controller_params"} <= set(sized)
    for name in sized:
        assert getattr(lib, name + "_size")() == ctypes.sizeof(BINDING.structs[name]), name


def test_the_header_reader_maps_sizes_and_pointers_and_names_what_it_cannot_map():
    b = c_binding.read([], {"x.h": "#define N 3\ntypedef struct { double a[N * 2]; int k; } sm_ok;\n"
                                   "int f(const sm_ok *p, double x[N], char *msg, size_t n);"})
    assert [(n, ctypes.sizeof(t)) for n, t in b.structs["sm_ok"]._fields_] == [("a", 48), ("k", 4)]
    res, args = b.functions["f"]
    assert res is ctypes.c_int and args[1:] == [ctypes.POINTER(ctypes.c_double), ctypes.c_char_p,
                                                ctypes.c_size_t]
    with pytest.raises(ValueError, match="the declaration of sm_bad: an array size 'M'"):
        c_binding.read([], {"x.h": "typedef struct { double a[M]; } sm_bad;"})
    with pytest.raises(ValueError, match="the declaration of sm_bad: a type '_Bool'"):
        c_binding.read([], {"x.h": "typedef struct { _Bool b; } sm_bad;"})


def test_a_struct_pointer_takes_its_struct_or_a_buffer_and_refuses_another_struct(lib):
    g = STRUCTS["sm_gains"]()
    lib.sm_gains_default(g)
    lib.sm_gains_default(ctypes.byref(g))
    assert g.c1 == BacksteppingGains().c1
    with pytest.raises(ctypes.ArgumentError, match="expected a sm_gains, got a sm_law_config"):
        lib.sm_gains_default(STRUCTS["sm_law_config"]())
    buf = (ctypes.c_double * 6)()  # a raw buffer of the struct's size
    lib.sm_gains_default(buf)
    assert list(buf) == [getattr(g, n) for n, _ in g._fields_]


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
                            "observer", "speed_source", "flux_mode", "modulation"}
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


def test_the_core_library_is_built_into_the_cache_once_and_leaves_no_folder_behind(tmp_path, monkeypatch):
    """tests/native_core.build: the library under build/native_core/, not compiled again on a second call
    (nothing changed), no work folder of this process left there and nothing in the temporary folder."""
    import os
    import tempfile

    import native_core as nc
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))  # a temporary folder would land here
    lib = nc.build()
    assert nc.CACHE in lib.parents and lib.exists()

    def compile_again(*args):
        raise AssertionError("compiled again")

    monkeypatch.setattr(nc, "_compile", compile_again)
    assert nc.build() == lib
    assert not (lib.parent / f"build-{os.getpid()}").exists()
    assert not (lib.parent / f"key-{os.getpid()}").exists()
    assert list(tmp_path.iterdir()) == []

"""``check`` catches defects: broken copies of our FMUs, made here in tmp_path (nothing broken is
shipped), each FAIL the check that should catch them, with a message naming the defect.  The copies:
a native binary that aborts on a NaN input; a native and a pythonfmu FMU whose state-identity check
is compiled / patched out (they take another build's state); native and pythonfmu FMUs whose
modelDescription.xml carries another GUID than the one they were built with.  (tests/test_check.py:
a declared output missing, a reference 1 % off, state declared false.)"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from test_check import rewrite_model_description, run_check

from orchestration.packaging import fmu_build, fmus
from orchestration.packaging.native import compiler as native_build
from orchestration.packaging.native import fmus as native_fmus
from orchestration.packaging.native import model_description as nmd

pytestmark = pytest.mark.slow
PLANT = "SaturatedInductionMotor"
WRONG_GUID = "{0badc0de-0000-4000-8000-000000000000}"


def patched(text, patches, where):
    """``text`` with each ``(old, new)`` of ``patches`` applied; fails if an ``old`` is not in it
    exactly once (after a change of the sources the mutation would silently not happen)."""
    for old, new in patches:
        assert text.count(old) == 1, f"{where}: the text to patch is not there once: {old!r}"
        text = text.replace(old, new)
    return text


def build_native_copy(tmp_path, out, monkeypatch=None, model_patches=(), glue_patches=(), name=PLANT,
                      version="2.0"):
    """The native FMU ``name`` built with the project's build functions, its model's
    ``native_model.c`` and/or glue files patched in copies under ``tmp_path`` (``glue_patches``:
    ``{file name: patches}``)."""
    src = tmp_path / "src"
    src.mkdir(exist_ok=True)
    sources = native_fmus.sources(name)
    if model_patches:
        model = src / "native_model.c"
        model.write_text(patched(sources[-1].read_text(), model_patches, sources[-1]))
        sources[-1] = model
    if glue_patches:
        glue = tmp_path / "glue"
        shutil.copytree(native_build.GLUE_DIR, glue)
        for name_, patches in glue_patches.items():
            f = glue / name_
            f.write_text(patched(f.read_text(), patches, f))
        monkeypatch.setattr(native_build, "GLUE_DIR", glue)
    generated = native_fmus.generated(name, src)
    xml = (nmd.fmi2 if version == "2.0" else nmd.fmi3)(name).decode("utf-8")
    path, _ = native_build.build_native_fmu(name, [*sources, *generated], xml, out, version,
                                            native_fmus.LINUX[version])
    return path


def build_pythonfmu_copy(tmp_path, out_dir, glue_patches, name=PLANT):
    """The pythonfmu FMU ``name`` built by ``fmu_build.build_one`` (in a child, as the build does) with
    a patched copy of the glue; returns its path."""
    glue = tmp_path / "glue" / fmu_build.GLUE.name
    glue.parent.mkdir()
    glue.write_text(patched(fmu_build.GLUE.read_text(), glue_patches, fmu_build.GLUE))
    code = (f"from pathlib import Path\nimport orchestration.packaging.fmu_build as b\n"
            f"b.GLUE = Path({str(glue)!r})\n"
            f"b.build_one({name!r}, {str(out_dir)!r})\n")
    Path(out_dir).mkdir()
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    return Path(out_dir) / f"{name}.fmu"


def failed(verdicts):
    return {key for key, (v, _) in verdicts.items() if v == "FAIL"}


# --- a binary that crashes on a NaN input --------------------------------------------------------------

ABORT_ON_NAN_T_LOAD = (
    ('#include "sm_common.h"\n', '#include <math.h>\n#include <stdlib.h>\n\n#include "sm_common.h"\n'),
    ("    st = sm_plant_unit_step(",
     "    if (isnan(in[SM_PLANT_IN_T_load])) abort(); /* the defect */\n    st = sm_plant_unit_step("))


def test_a_binary_that_aborts_on_a_nan_input_fails_naming_the_input_and_the_signal(tmp_path, capsys):
    broken = build_native_copy(tmp_path, tmp_path / "AbortsOnNaN.fmu", model_patches=ABORT_ON_NAN_T_LOAD)
    code, verdicts = run_check(capsys, broken)  # the check itself lives on: every line printed
    assert code == 1
    assert failed(verdicts) == {(broken.stem, "non-finite-input")}, verdicts
    detail = verdicts[(broken.stem, "non-finite-input")][1]
    # the crash is named with its input and signal; the inputs after and before it are still tried
    assert "T_load=NaN: the child process killed by SIGABRT" in detail, detail
    assert "v_s_alpha=NaN: discard" in detail and "v_s_beta=NaN: discard" in detail, detail
    assert detail.endswith("a fresh instance then steps fine"), detail


# --- a state blob accepted from another FMU --------------------------------------------------------------

NATIVE_NO_STATE_IDENTITY = {"fg_state.c": (  # blob_ok without the model identifier and token comparisons
    ("    if (memcmp(h.model_identifier, mine.model_identifier, FG_TAG_LEN) != 0) {",
     "    if (0) { /* the defect */"),
    ("    if (memcmp(h.token, mine.token, FG_TAG_LEN) != 0) {", "    if (0) { /* the defect */"))}


def assert_accepts_the_other_build(verdicts, broken, good):
    """``broken`` FAILs foreign-state naming the blob it took; the truncated and corrupted copies of
    its own are still refused (what the mutation left in place); ``good`` refuses ``broken``'s blob."""
    verdict, detail = verdicts[(broken.stem, "foreign-state")]
    assert verdict == "FAIL", detail
    assert re.search(rf"the state of {re.escape(str(good))}: ACCEPTED \(deserialize ok, set ok, nothing "
                     r"logged\): a state not its own was taken", detail), detail
    assert "truncated to" in detail and "every byte inverted" in detail
    assert detail.count("ACCEPTED") == 1, detail
    assert {k for k in failed(verdicts) if k[0] == broken.stem} == {(broken.stem, "foreign-state")}
    good_verdict, good_detail = verdicts[(good.stem, "foreign-state")]
    assert good_verdict in ("PASS", "KNOWN") and "ACCEPTED" not in good_detail, good_detail
    assert f"the state of {broken}: refused" in good_detail, good_detail


def test_a_native_fmu_that_takes_another_builds_state_fails_foreign_state(fmu_dir, tmp_path, capsys,
                                                                          monkeypatch):
    broken = build_native_copy(tmp_path, tmp_path / "TakesForeignState.fmu", monkeypatch,
                               glue_patches=NATIVE_NO_STATE_IDENTITY)
    good = fmus.paths(fmu_dir, "native")[0]
    code, verdicts = run_check(capsys, broken, good)
    assert code == 1
    assert_accepts_the_other_build(verdicts, broken, good)
    assert verdicts[(good.stem, "foreign-state")][0] == "PASS"


PYTHONFMU_NO_STATE_IDENTITY = (  # _state_problem without the model/fingerprint/guid comparison
    ("        if not isinstance(tag, dict) or any(tag.get(k) != v for k, v in self._identity.items()):",
     "        if not isinstance(tag, dict):  # the defect"),)


def test_a_pythonfmu_fmu_that_takes_another_builds_state_fails_foreign_state(fmu_dir, tmp_path, capsys):
    built = build_pythonfmu_copy(tmp_path, tmp_path / "out", PYTHONFMU_NO_STATE_IDENTITY)
    broken = built.rename(tmp_path / "TakesForeignState.fmu")
    good = fmus.paths(fmu_dir, "python")[0]
    code, verdicts = run_check(capsys, broken, good)
    assert code == 1
    assert_accepts_the_other_build(verdicts, broken, good)


# --- a wrong GUID ---------------------------------------------------------------------------------------

def with_guid(src, dst, guid):
    attr = "instantiationToken" if "native-fmi3" in str(src) else "guid"
    rewrite_model_description(src, dst, lambda md: re.sub(rf'\b{attr}="[^"]*"', f'{attr}="{guid}"', md,
                                                          count=1))
    return dst


@pytest.mark.parametrize("variant", ["native", "native-fmi3", "python"])
def test_a_model_description_with_another_guid_fails_instantiate_naming_it(variant, fmu_dir, tmp_path,
                                                                            capsys):
    good = fmus.paths(fmu_dir, variant)[0]
    broken = with_guid(good, tmp_path / "WrongGuid.fmu", WRONG_GUID)
    code, verdicts = run_check(capsys, broken)
    assert code == 1
    verdict, detail = verdicts[(broken.stem, "instantiate")]
    assert verdict == "FAIL" and WRONG_GUID in detail, detail
    if variant == "python":  # the glue compares the description with the build's resources/build_guid.txt
        assert f"modelDescription.xml has guid {WRONG_GUID}, but this FMU was built with guid" in detail
    else:  # the binary compares the host's fmuGUID / instantiationToken with its own
        assert "does not match" in detail
    # every run-time check needs an instance: none passes
    assert {c for (_, c), (v, _) in verdicts.items() if v == "PASS"} <= {"validate", "fmutool", "wrong-guid"}


NATIVE_NO_GUID_CHECK = {"fmi2_glue.c": (  # fmi2Instantiate takes any fmuGUID
    ("    if (fmuGUID == NULL || strcmp(fmuGUID, INSTANTIATION_TOKEN) != 0) {",
     "    if (fmuGUID == NULL) { /* the defect */"),)}


def test_a_native_fmu_that_takes_any_guid_fails_wrong_guid(tmp_path, capsys, monkeypatch):
    broken = build_native_copy(tmp_path, tmp_path / "TakesAnyGuid.fmu", monkeypatch,
                               glue_patches=NATIVE_NO_GUID_CHECK)
    code, verdicts = run_check(capsys, broken)
    assert code == 1
    assert failed(verdicts) == {(broken.stem, "wrong-guid")}, verdicts
    detail = verdicts[(broken.stem, "wrong-guid")][1]
    assert re.fullmatch(r"instantiated with fmuGUID \{[-0-9a-f]{36}\} \(the model description has "
                        r"\{[-0-9a-f]{36}\}\): the FMU does not compare the host's fmuGUID", detail), detail

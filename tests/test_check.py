"""``python -m orchestration check``: our two FMUs pass (exit 0, JUnit XML with one testcase per
check), the pythonfmu ones and the native FMI 3.0 ones, broken copies FAIL the check that should
catch them (exit 1), usage errors exit 2."""

from __future__ import annotations

import re
import shutil
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

import pytest

from orchestration.check import checker as check
from orchestration.cli import commands as cli

NAMES = ("SaturatedInductionMotor", "BacksteppingController")
LINE = re.compile(r"^(PASS|FAIL|SKIP|KNOWN) +(\S+)  ([a-z-]+): (.*)$")


def run_check(capsys, *argv):
    code = cli.main(["check", *map(str, argv)])
    lines = capsys.readouterr().out.splitlines()
    verdicts = {}
    for line in lines:
        m = LINE.match(line)
        assert m, line
        verdicts[(Path(m.group(2)).stem, m.group(3))] = (m.group(1), m.group(4))
    return code, verdicts


def rewrite_model_description(src, dst, change):
    with zipfile.ZipFile(src) as z:
        files = {n: z.read(n) for n in z.namelist()}
    files["modelDescription.xml"] = change(files["modelDescription.xml"].decode()).encode()
    with zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as z:
        for n, data in files.items():
            z.writestr(n, data)


def drop_last_output(md):
    """The model description without its last output variable (ModelStructure left as it is)."""
    last = [m for m in re.finditer(r"\s*<ScalarVariable\b.*?</ScalarVariable>", md, re.S)
            if 'causality="output"' in m.group(0)][-1]
    return md[:last.start()] + md[last.end():]


def test_usage_errors_exit_2(tmp_path, capsys):
    not_zip = tmp_path / "x.fmu"
    not_zip.write_text("not a zip")
    assert cli.main(["check", str(tmp_path / "missing.fmu")]) == cli.INVALID
    assert cli.main(["check", str(not_zip)]) == cli.INVALID
    err = capsys.readouterr().err
    assert "no such file" in err and "not a zip archive" in err


def test_junit_layout(tmp_path):
    rows = [("validate", "PASS", "ok", 0.1), ("state", "SKIP", "declared false", 0.0),
            ("bad-parameter", "KNOWN", "fatal", 0.2), ("reference", "FAIL", "off by 1 %", 0.3)]
    check.junit({"a.fmu": rows}, tmp_path / "j.xml")
    suite = ET.parse(tmp_path / "j.xml").getroot().find("testsuite")
    assert (suite.get("tests"), suite.get("failures"), suite.get("skipped")) == ("4", "1", "2")
    cases = {c.get("name"): c for c in suite.iter("testcase")}
    assert cases["reference"].find("failure").get("message") == "off by 1 %"
    assert cases["bad-parameter"].find("skipped").get("message").startswith("KNOWN")
    assert cases["validate"].find("failure") is None and cases["validate"].find("skipped") is None


def assert_junit_no_failure(junit_file, paths, skipped):
    """One testsuite per FMU, every check a testcase, no failure, ``skipped`` skipped (KNOWN or SKIP)."""
    suites = ET.parse(junit_file).getroot().findall("testsuite")
    assert [s.get("name") for s in suites] == [str(p) for p in paths]
    for s in suites:
        assert [c.get("name") for c in s.findall("testcase")] == list(check.CHECKS)
        counts = (s.get("tests"), s.get("failures"), s.get("skipped"))
        assert counts == (str(len(check.CHECKS)), "0", str(skipped))
        assert s.find("testcase/failure") is None


# the pythonfmu FMUs: what pythonfmu 0.7.0 keeps from the FMU (reported, not failing); they carry no C
# sources (the binary is pythonfmu's)
PYTHONFMU_KNOWN = {"bad-parameter": "KNOWN", "wrong-guid": "KNOWN", "foreign-state": "KNOWN",
                   "source-build": "SKIP"}


@pytest.mark.slow
def test_our_fmus_pass_with_a_junit_file(fmu_dir, tmp_path, capsys):
    paths = [Path(fmu_dir) / f"{n}.fmu" for n in NAMES]
    code, verdicts = run_check(capsys, *paths, "--junit", tmp_path / "check.xml")
    assert code == 0, verdicts
    for name, other in (NAMES, NAMES[::-1]):
        assert {c: verdicts[(name, c)][0] for c in check.CHECKS} == {
            **{c: "PASS" for c in check.CHECKS}, **PYTHONFMU_KNOWN}, verdicts
        assert "pythonfmu" in verdicts[(name, "bad-parameter")][1]
        assert "does not pass fmuGUID" in verdicts[(name, "wrong-guid")][1]
        foreign = verdicts[(name, "foreign-state")][1]
        # the other FMU's blob, a truncated and a corrupted own blob: each refused (in the log: fmi2OK)
        assert f"the state of {Path(fmu_dir) / other}.fmu: refused in the log only" in foreign, foreign
        assert foreign.count("refused in the log only") == 3 and "the next doStep discard" in foreign
        assert "replays it bit-identical" in foreign
    assert_junit_no_failure(tmp_path / "check.xml", paths, skipped=4)


@pytest.mark.slow
def test_a_missing_output_fails_validate_and_fmutool(fmu_dir, tmp_path, capsys):
    broken = tmp_path / "SaturatedInductionMotor.fmu"
    rewrite_model_description(Path(fmu_dir) / broken.name, broken, drop_last_output)
    code, verdicts = run_check(capsys, broken, "--junit", tmp_path / "check.xml")
    assert code == 1
    name = broken.stem
    assert verdicts[(name, "validate")][0] == "FAIL"
    assert "ModelStructure/Outputs" in verdicts[(name, "validate")][1]
    assert verdicts[(name, "fmutool")][0] == "FAIL"
    failed = {c.get("name") for c in ET.parse(tmp_path / "check.xml").getroot().iter("testcase")
              if c.find("failure") is not None}
    assert {"validate", "fmutool"} <= failed


def reference_one_percent_off(tmp_path, name, column):
    """A copy of ``reference/`` whose ``name`` reference has ``column`` 1 % high."""
    ref = tmp_path / "reference"
    shutil.copytree(check.REFERENCE_DIR / name, ref / name)
    csv = ref / name / f"{name}_ref.csv"
    head, *rows = csv.read_text().splitlines()
    col = head.split(",").index(column)
    doctored = []
    for row in rows:
        cells = row.split(",")
        cells[col] = repr(float(cells[col]) * 1.01)
        doctored.append(",".join(cells))
    csv.write_text("\n".join([head, *doctored]) + "\n")
    return ref


@pytest.mark.slow
def test_a_reference_one_percent_off_fails_reference(fmu_dir, tmp_path, capsys):
    name = "SaturatedInductionMotor"
    ref = reference_one_percent_off(tmp_path, name, "omega_m")
    code, verdicts = run_check(capsys, Path(fmu_dir) / f"{name}.fmu", "--reference", ref)
    assert code == 1
    verdict, detail = verdicts[(name, "reference")]
    assert verdict == "FAIL" and "omega_m" in detail and "band 1e-09" in detail, detail
    assert all(v == PYTHONFMU_KNOWN.get(c, "PASS") for (n, c), (v, _) in verdicts.items() if c != "reference")


def test_a_crashed_probe_is_named_by_its_signal():
    assert check.died(-6, "") == "the child process killed by SIGABRT"
    assert check.died(134, "corrupted double-linked list").startswith(
        "the child process killed by SIGABRT (exit status 134): corrupted")
    assert check.died(1, "Traceback") == "the child process exit status 1: Traceback"


@pytest.mark.slow
def test_state_declared_false_is_skipped(fmu_dir, tmp_path, capsys):
    copy = tmp_path / "BacksteppingController.fmu"
    rewrite_model_description(Path(fmu_dir) / copy.name, copy, lambda md: md.replace(
        'canGetAndSetFMUstate="true"', 'canGetAndSetFMUstate="false"').replace(
        'canSerializeFMUstate="true"', 'canSerializeFMUstate="false"'))
    code, verdicts = run_check(capsys, copy)
    assert code == 0 and verdicts[(copy.stem, "state")] == ("SKIP", "canGetAndSetFMUstate is false")


@pytest.mark.slow
def test_native_fmi3_fmus_pass_with_a_junit_file(fmu_dir, tmp_path, capsys):
    paths = [Path(fmu_dir) / "native-fmi3" / f"{n}.fmu" for n in NAMES]
    code, verdicts = run_check(capsys, *paths, "--junit", tmp_path / "check.xml")
    assert code == 0, verdicts
    for name in NAMES:
        assert {c: verdicts[(name, c)][0] for c in check.CHECKS} == {
            **{c: "PASS" for c in check.CHECKS}, "fmutool": "SKIP"}, verdicts
        assert "FMI 2.0 only" in verdicts[(name, "fmutool")][1]
        assert verdicts[(name, "bad-parameter")][1].startswith("J = 0.0: error at ")
        assert "fmi3Reset" in verdicts[(name, "reset")][1]
        assert "round trip" in verdicts[(name, "state")][1]
        assert "of this binary" in verdicts[(name, "wrong-guid")][1]
        assert verdicts[(name, "foreign-state")][1].count("refused (deserialize error)") == 3
    assert_junit_no_failure(tmp_path / "check.xml", paths, skipped=1)


@pytest.mark.slow
def test_fmi3_a_reference_one_percent_off_fails_reference(fmu_dir, tmp_path, capsys):
    name = "BacksteppingController"
    ref = reference_one_percent_off(tmp_path, name, "v_s_alpha")
    code, verdicts = run_check(capsys, Path(fmu_dir) / "native-fmi3" / f"{name}.fmu",
                               "--reference", ref)
    assert code == 1
    verdict, detail = verdicts[(name, "reference")]
    assert verdict == "FAIL" and "v_s_alpha" in detail and "band 1e-09" in detail, detail
    assert all(v == ("SKIP" if c == "fmutool" else "PASS")
               for (n, c), (v, _) in verdicts.items() if c != "reference")


@pytest.mark.slow
def test_fmi3_state_declared_false_is_skipped(fmu_dir, tmp_path, capsys):
    copy = tmp_path / "SaturatedInductionMotor.fmu"
    rewrite_model_description(Path(fmu_dir) / "native-fmi3" / copy.name, copy, lambda md: md.replace(
        'canGetAndSetFMUState="true"', 'canGetAndSetFMUState="false"').replace(
        'canSerializeFMUState="true"', 'canSerializeFMUState="false"'))
    code, verdicts = run_check(capsys, copy)
    assert code == 0 and verdicts[(copy.stem, "state")] == ("SKIP", "canGetAndSetFMUstate is false")


def test_a_bad_parameter_refused_only_at_the_next_step_is_flagged_saying_so():
    """pythonfmu: exitInitializationMode returns fmi2OK with the error logged, the next doStep
    discards: KNOWN, and the detail says where the refusal comes (issue 31); a native FMU doing the
    same FAILs."""
    result = {"status": "logged", "param": "J = 0.0", "alive": True, "generationTool": "pythonfmu 0.7.0",
              "where": "initialization (fmi2OK with an error logged; doStep: discard)"}
    verdict, detail = check.judge("bad-parameter", result)
    assert verdict == "KNOWN", detail
    assert "refused at the next doStep" in detail and "exitInitializationMode" in detail, detail
    assert "returns fmi2OK" in detail and "pythonfmu's limit" in detail, detail
    verdict, _ = check.judge("bad-parameter", {**result, "generationTool": "satmotor native C glue"})
    assert verdict == "FAIL"


def test_fatal_for_a_bad_parameter_names_the_fmi_version():
    result = {"status": "fatal", "where": "initialization", "param": "J = 0.0", "alive": True,
              "generationTool": "satmotor native C glue", "fmi": "fmi3"}
    verdict, detail = check.judge("bad-parameter", result)
    assert verdict == "FAIL" and "fmi3Fatal for a bad parameter: expected fmi3Error" in detail
    verdict, detail = check.judge("bad-parameter", {**result, "status": "error"})
    assert verdict == "PASS" and "error at initialization" in detail


def test_foreign_state_verdicts():
    """Each outcome of one offered blob, judged; the worst decides, every blob is named."""
    def blob(outcome, usable=True, **kw):
        return {"outcome": outcome, "deserialize": "ok", "set": "ok", "usable": usable, **kw}

    refused = {"outcome": "refused", "deserialize": "error", "set": None, "usable": True}
    log_only = blob("log-only", next_step="discard")
    cases = [  # (results, generationTool, verdict, text in the detail)
        ({"a": refused}, "x", "PASS", "a: refused (deserialize error)"),
        ({"a": refused, "b": log_only}, "pythonfmu 0.7.0", "KNOWN", "b: refused in the log only"),
        ({"a": log_only}, "another tool", "FAIL",
         "a: refused in the log only (deserialize ok, set ok): the host"),
        ({"a": refused, "b": blob("accepted")}, "x", "FAIL", "b: ACCEPTED (deserialize ok, set ok, nothing"),
        ({"a": blob("fatal", usable=False)}, "x", "FAIL",
         "a: fatal (deserialize ok, set ok): the instance is lost"),
        ({"a": {"crash": "the child process killed by SIGSEGV"}}, "x", "FAIL",
         "a: the child process killed by SIGSEGV"),
        ({"a": {**refused, "usable": False, "why": "the replay from its own state differs"}}, "x", "FAIL",
         "a: refused (deserialize error); the instance is not usable after it: the replay from its own"),
    ]
    for results, tool, verdict, text in cases:
        got, detail = check.judge("foreign-state", {"results": results, "generationTool": tool})
        assert (got, text in detail) == (verdict, True), (results, got, detail)

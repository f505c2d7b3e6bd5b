"""`check`'s ``steps`` probe (orchestration/check/probes.py) and its verdicts (checker.judge_steps): the
communication steps hosts make, 2 h, h + 4 ulps and 1.5 h, on our FMUs and on hand-made probe results
for the FMUs that behave otherwise."""

import pytest

from orchestration.check import checker


def _result(variable=False, alive=True, **patterns):
    base = {"multiple": {"step": 2e-4, "status": "ok", "log": "", "same": True},
            "ulp-off": {"step": 1.0000000000000006e-4, "status": "ok", "log": "", "same": True},
            "refused": {"step": 1.5e-4, "status": "discard", "log": "communicationStepSize = 0.00015: no",
                        "same": None}}
    for k, v in patterns.items():
        base[k.replace("_", "-")] = {**base[k.replace("_", "-")], **v}
    return {"h": 1e-4, "variable": variable, "alive": alive, **base}


@pytest.mark.parametrize("result, verdict, says", [
    (_result(), "PASS", "refused with: communicationStepSize"),
    (_result(multiple={"status": "discard", "same": None}), "KNOWN", "FMU Compliance Checker"),
    (_result(variable=True, multiple={"status": "discard", "same": None}), "FAIL", "2 h = 0.0002 s: discard"),
    (_result(ulp_off={"status": "discard", "same": None}), "FAIL", "drifts off h by ulps"),
    (_result(refused={"log": ""}), "FAIL", "without a message"),
    (_result(variable=True), "FAIL", "canHandleVariableCommunicationStepSize = true"),
    (_result(refused={"status": "ok"}), "PASS", "(accepted)"),
    (_result(multiple={"status": "fatal", "same": None}), "FAIL", "the instance is lost"),
    (_result(alive=False), "FAIL", "a fresh instance then FAILS"),
])
def test_judge_steps(result, verdict, says):
    got, detail = checker.judge("steps", result)
    assert (got, says in detail) == (verdict, True), detail


@pytest.mark.parametrize("variant", ["native/BacksteppingController.fmu",
                                     "native-fmi3/BacksteppingController.fmu", "BacksteppingController.fmu",
                                     "native/SaturatedInductionMotor.fmu"])
def test_our_fmus_pass_the_step_patterns(fmu_dir, variant):
    code, result, tail = checker.run_probe("steps", fmu_dir / variant)
    assert code == 0 and result is not None, tail
    verdict, detail = checker.judge("steps", result)
    assert verdict == "PASS", detail
    if "Controller" in variant:  # a sampled system: n samples with the inputs held, bit for bit
        assert detail.count("bit-identical") == 2, detail
        assert "must be a whole multiple of the sample period Ts = 0.0001 s" in detail, detail
    else:
        assert "(accepted)" in detail, detail


# --- source-build -------------------------------------------------------------------------------------

BUILT = {"built": "gcc", "shipped": True, "steps": 20}

@pytest.mark.parametrize("result, verdict, says", [
    ({"unlisted": True, "detail": "sources/ holds C files but no file list"}, "KNOWN", "no file list"),
    ({**BUILT, "identical": True, "worst": 0.0}, "PASS", "bit-identical"),
    ({**BUILT, "identical": False, "worst": 1e-12}, "PASS", "within 1e-12"),
    ({**BUILT, "identical": False, "worst": 1e-3}, "FAIL", "within 0.001"),
    ({"built": "gcc", "shipped": False, "steps": 20}, "PASS", "no shipped binary"),
    ({"ok": False, "detail": "gcc ... failed: x.c:1: error"}, "FAIL", "failed"),
    ({"skip": "no sources (a binary-only FMU)"}, "SKIP", "binary-only"),
])
def test_judge_source_build(result, verdict, says):
    got, detail = checker.judge("source-build", result)
    assert (got, says in detail) == (verdict, True), detail


def test_source_build_fails_a_source_that_does_not_compile_and_knows_an_unlisted_one(fmu_dir, tmp_path):
    """Two broken copies of the native controller: a C file cut in half (FAIL, naming the compiler's
    error), and the FMI 2.0 file list removed (KNOWN)."""
    import re
    import zipfile

    src = fmu_dir / "native" / "BacksteppingController.fmu"
    with zipfile.ZipFile(src) as z:
        files = {n: z.read(n) for n in z.namelist()}
    cut = dict(files)
    cut["sources/sm_law.c"] = files["sources/sm_law.c"][: len(files["sources/sm_law.c"]) // 2]
    unlisted = dict(files)
    unlisted["modelDescription.xml"] = re.sub(rb"\s*<SourceFiles>.*?</SourceFiles>", b"",
                                              files["modelDescription.xml"], flags=re.S)
    for label, content, verdict, says in (("cut", cut, "FAIL", "sm_law.c"),
                                          ("unlisted", unlisted, "KNOWN", "no file list")):
        path = tmp_path / label / "BacksteppingController.fmu"
        path.parent.mkdir()
        with zipfile.ZipFile(path, "w") as z:
            for n, b in content.items():
                z.writestr(n, b)
        code, result, tail = checker.run_probe("source-build", path)
        assert code == 0 and result is not None, tail
        got, detail = checker.judge("source-build", result)
        assert (got, says in detail) == (verdict, True), (label, detail)

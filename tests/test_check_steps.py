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

"""The help texts as a user reads them: the usage line names the command as it was typed, and what
the help says about FMI versions, checks and speed agrees with the code, the README and
bench/RESULTS.md."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from orchestration.check import checker as check
from orchestration.cli import commands as cli

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = Path(sys.executable).with_name("satmotor-cosim")  # the console script pip installed beside python


def _help(*args, command=None):
    command = command or [sys.executable, "-m", "orchestration"]
    out = subprocess.run([*command, *args, "--help"], capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    return " ".join(out.stdout.split())  # argparse wraps lines: compare words


@pytest.mark.parametrize("argv0, prog", [
    ("/any/where/orchestration/__main__.py", "python -m orchestration"),
    ("/any/where/bin/satmotor-cosim", "satmotor-cosim"),
    ("satmotor-cosim", "satmotor-cosim"),
    ("", "satmotor-cosim"),
    ("-c", "satmotor-cosim"),
])
def test_prog_name_is_the_command_as_typed(argv0, prog):
    assert cli.prog_name(argv0) == prog


def test_python_dash_m_names_itself_in_the_usage():
    assert _help().startswith("usage: python -m orchestration [-h]")
    assert _help("run").startswith("usage: python -m orchestration run ")


@pytest.mark.skipif(not SCRIPT.exists(), reason="satmotor-cosim is not installed beside this python")
def test_the_installed_command_names_itself_in_the_usage():
    assert _help(command=[str(SCRIPT)]).startswith("usage: satmotor-cosim [-h]")
    assert _help("check", command=[str(SCRIPT)]).startswith("usage: satmotor-cosim check ")


def test_check_help_names_both_fmi_versions_and_every_check():
    text = _help("check")
    assert "FMI 2.0 or FMI 3.0" in text
    assert "FMI 2.0 co-simulation FMU)" not in text  # the old text, which said FMI 2.0 only
    described = text[text.index("Check any"):]
    for name in check.CHECKS:
        if name not in ("validate", "fmutool"):  # named as the tools that run them
            assert name in described, name


def test_the_speed_up_in_the_run_help_is_the_measured_one():
    text = _help("run")
    ratios = re.findall(r"(\d+\.\d+)x", text)
    assert ratios == ["5.25", "4.96"]
    results = (ROOT / "bench" / "RESULTS.md").read_text(encoding="utf-8")
    for r in ratios:
        assert f"**{r}x**" in results, r
    assert "about" not in text[text.index("--variant"):text.index("--no-build")]


def test_every_command_of_the_help_is_on_the_readme():
    usage = _help()
    commands = re.search(r"\{([a-z,-]+)\}", usage).group(1).split(",")
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(commands) == 8
    for c in commands:
        assert f"satmotor-cosim {c} " in readme, c

"""The README and docs/ against the code: links resolve, the variable tables are the interface's, and
the README's Python host runs and prints what the plain-Python closed loop computes."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

from orchestration.build import variable_tables
from orchestration.run.reference import plain_reference
from orchestration.scenario.load import load_scenario

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = sorted((ROOT / "docs").glob("*.md"))
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
FENCE = re.compile(r"^```.*?^```", re.S | re.M)


def _slug(heading):
    """GitHub's anchor of a Markdown heading: lower case, punctuation dropped, spaces to hyphens."""
    text = heading.strip().lower().replace("`", "")
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def _anchors(path):
    text = FENCE.sub("", path.read_text(encoding="utf-8"))
    return {_slug(m.group(1)) for m in re.finditer(r"^#+ (.*)$", text, re.M)}


def _relative_links(path):
    text = FENCE.sub("", path.read_text(encoding="utf-8"))
    text = re.sub(r"`[^`\n]*`", "", text)  # code spans are not links
    for target in LINK.findall(text):
        if not re.match(r"[a-z]+:", target):  # http:, https:, mailto: are not checked here
            yield target


def test_slug_matches_githubs_rule():
    assert _slug("Process exit and pythonfmu (an upstream defect)") == \
        "process-exit-and-pythonfmu-an-upstream-defect"
    assert _slug("The seed's claim, in numbers") == "the-seeds-claim-in-numbers"
    assert _slug("Measurement noise (`measurements:`)") == "measurement-noise-measurements"


@pytest.mark.parametrize("page", [README, *DOCS], ids=lambda p: p.relative_to(ROOT).as_posix())
def test_every_relative_link_points_to_an_existing_file_and_heading(page):
    links = list(_relative_links(page))
    assert links or page.name == "errata.md"
    for link in links:
        file, _, anchor = link.partition("#")
        target = (page.parent / file).resolve() if file else page
        assert target.is_file(), f"{page.name}: link {link!r}: no file {target}"
        if anchor:
            assert target.suffix == ".md", f"{page.name}: link {link!r}: an anchor into a non-Markdown file"
            assert anchor in _anchors(target), f"{page.name}: link {link!r}: no heading #{anchor} in {file}"


def test_readme_variable_tables_are_the_generated_ones():
    text = README.read_text(encoding="utf-8")
    assert variable_tables.replace_block(text) == text, (
        "README.md's variable tables differ from satmotor/interface.py: run "
        "`python -m orchestration.build.variable_tables --write README.md`")


def test_generated_tables_hold_every_variable_once():
    from satmotor.interface import ControllerUnit, PlantUnit

    md = variable_tables.markdown()
    names = re.findall(r"^\| `([^`]+)` \|", md, re.M)
    plant_end = md.index("### `BacksteppingController`")
    plant_names = re.findall(r"^\| `([^`]+)` \|", md[:plant_end], re.M)
    assert len(set(plant_names)) == len(plant_names)
    assert set(PlantUnit.OUTPUTS) <= set(plant_names)
    assert set(ControllerUnit.OUTPUTS) <= set(names[len(plant_names):])


def _python_block():
    blocks = re.findall(r"^```python\n(.*?)^```", README.read_text(encoding="utf-8"), re.S | re.M)
    assert len(blocks) == 1, "the README has one Python example"
    return blocks[0]


@pytest.mark.slow
def test_readme_python_host_runs_and_matches_the_plain_loop(fmu_dir, tmp_path):
    code = _python_block()
    assert "build/fmus/native/" in code
    script = tmp_path / "host.py"
    script.write_text(code.replace("build/fmus/", f"{fmu_dir.as_posix()}/"), encoding="utf-8")
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300,
                         cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    line = out.stdout.strip()
    # the README quotes the line it prints
    assert f"It prints `{line}`" in README.read_text(encoding="utf-8")
    omega, psi = map(float, re.fullmatch(r"omega_m = (\S+) rad/s, \|psi_r\| = (\S+) Wb", line).groups())

    # the same run as a scenario through the plain-Python twin (no FMI, its own wiring)
    sc_file = tmp_path / "readme_host.yaml"
    sc_file.write_text(
        "name: readme_host\nstop_time: 1.0\nstep: 1.0e-4\n"
        "profiles:\n  psi_ref: {type: constant, value: 0.95}\n"
        "  omega_ref: {type: ramp, start: 0.2, end: 0.7, from: 0.0, to: 100.0}\n"
        "  T_load: {type: constant, value: 0.0}\n", encoding="utf-8")
    ref = plain_reference(load_scenario(sc_file)).iloc[-1]
    assert ref["time"] == pytest.approx(1.0)
    assert omega == pytest.approx(ref["plant.omega_m"], abs=5.1e-4)
    assert psi == pytest.approx(float(abs(complex(ref["plant.psi_r_alpha"], ref["plant.psi_r_beta"]))),
                                abs=5.1e-5)

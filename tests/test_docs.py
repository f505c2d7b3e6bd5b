"""The README and docs/ against the code: links resolve, the variables page is the interface's, the
README's Python hosts (FMI 2.0 and 3.0) run and print what the plain-Python closed loop computes, and
a claim has one figure wherever it is made."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

from orchestration.packaging import variable_tables
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


def test_the_variables_page_is_the_generated_one():
    text = (ROOT / variable_tables.PAGE).read_text(encoding="utf-8")
    assert text == variable_tables.page(), (
        f"{variable_tables.PAGE} differs from satmotor/interface.py: run "
        f"`python -m orchestration.packaging.variable_tables --write {variable_tables.PAGE}`")


def test_the_generator_writes_the_page_it_checks(tmp_path):
    out = tmp_path / "variables.md"
    out.write_text("stale\n", encoding="utf-8")
    assert variable_tables.main(["--write", str(out)]) == 0
    assert out.read_text(encoding="utf-8") == variable_tables.page()


def test_the_variables_page_has_a_row_for_every_variable_of_the_interface():
    from satmotor import interface

    text = (ROOT / variable_tables.PAGE).read_text(encoding="utf-8")
    rows = set(re.findall(r"^\| `([^`]+)` \| (Real|Integer|Boolean|String) \|", text, re.M))
    tables = [interface.PLANT_INPUTS, interface.PLANT_OUTPUTS, interface.PLANT_PARAMETERS,
              interface.CONTROLLER_INPUTS, interface.CONTROLLER_OUTPUTS, interface.CONTROLLER_PARAMETERS]
    assert {(v.name, v.type) for t in tables for v in t} == {(n, t) for n, t in rows}


def test_generated_tables_hold_every_variable_once():
    from satmotor.interface import ControllerUnit, PlantUnit

    md = variable_tables.markdown()
    names = re.findall(r"^\| `([^`]+)` \|", md, re.M)
    plant_end = md.index("## `BacksteppingController`")
    plant_names = re.findall(r"^\| `([^`]+)` \|", md[:plant_end], re.M)
    assert len(set(plant_names)) == len(plant_names)
    assert set(PlantUnit.OUTPUTS) <= set(plant_names)
    assert set(ControllerUnit.OUTPUTS) <= set(names[len(plant_names):])


def _python_blocks():
    blocks = re.findall(r"^```python\n(.*?)^```", README.read_text(encoding="utf-8"), re.S | re.M)
    assert len(blocks) == 2, "the README has two Python examples: an FMI 2.0 host and an FMI 3.0 host"
    return dict(zip(("fmi2", "fmi3"), blocks))


def test_the_two_hosts_load_the_fmi_version_they_say():
    blocks = _python_blocks()
    assert blocks["fmi2"].count("build/fmus/native/") == 2 and "native-fmi3" not in blocks["fmi2"]
    assert "setupExperiment" in blocks["fmi2"] and "getReal" in blocks["fmi2"]
    assert blocks["fmi3"].count("build/fmus/native-fmi3/") == 2
    assert "setupExperiment" not in blocks["fmi3"] and "getReal" not in blocks["fmi3"]


@pytest.mark.slow
@pytest.mark.parametrize("version, fmus", [("fmi2", "native/"), ("fmi3", "native-fmi3/"), ("fmi2", "")],
                         ids=["fmi2-native", "fmi3-native", "fmi2-pythonfmu"])
def test_readme_python_host_runs_and_matches_the_plain_loop(version, fmus, fmu_dir, tmp_path):
    code = _python_blocks()[version]
    native_dir = "build/fmus/native/" if version == "fmi2" else "build/fmus/native-fmi3/"
    script = tmp_path / "host.py"
    script.write_text(code.replace(native_dir, f"{fmu_dir.as_posix()}/{fmus}"), encoding="utf-8")
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300,
                         cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    line = out.stdout.strip()
    # the README quotes the line both hosts print, and the pythonfmu FMUs print the same
    assert f"Both print `{line}`" in README.read_text(encoding="utf-8")
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


# --- the README as a front page -----------------------------------------------------------------------

def _readme_lines():
    return README.read_text(encoding="utf-8").splitlines()


def test_the_readme_is_a_front_page_of_at_most_300_lines():
    assert 0 < len(_readme_lines()) <= 300


def test_the_first_screen_has_the_two_commands_what_they_install_and_how_long_they_take():
    first = "\n".join(_readme_lines()[:60])
    assert re.search(r"^```sh\nmake demo .*\nmake test .*\n```$", first, re.M), "the two commands in a block"
    for command in ("make demo", "make test"):
        item = re.search(rf"^\* \*\*`{command}`\*\*(.*?)(?=^\* |\Z)", first, re.S | re.M)
        assert item, f"a bullet on {command}"
        assert re.search(r"\binstall", item.group(1)), f"{command}: what it installs"
        # how long it takes: a measured duration ("43 s", "11 min 36 s"), not a placeholder
        assert re.search(r"\b\d+ (s|min)\b", item.group(1)), f"{command}: how long it takes"
        assert "TODO" not in item.group(1), f"{command}: a placeholder left in"


def test_the_readme_links_every_documentation_page():
    text = README.read_text(encoding="utf-8")
    for page in [*DOCS, ROOT / "bench" / "RESULTS.md"]:
        rel = page.relative_to(ROOT).as_posix()
        assert f"]({rel})" in text, f"the README's documentation table misses {rel}"


def test_the_readme_says_what_it_means_without_internal_words():
    text = README.read_text(encoding="utf-8").lower()
    for word in ("the seed", "seed's", "executable specification"):
        assert word not in text, word
    assert "ouadi, giri and ikhouane" in text


def test_where_the_docs_say_the_seed_they_say_it_is_the_paper():
    for page in DOCS:
        text = page.read_text(encoding="utf-8")
        # the paper, not a random generator's seed
        first = re.search(r"\bthe seed\b|\bseed's\b|\bseed (?:paper|§|eq|H1)", text, re.I)
        if first is None:
            continue
        before = text[:first.start() + 400]
        assert "Ouadi" in before, f"{page.name} says 'seed' before it says which paper that is"


def test_no_file_holds_a_path_of_the_authors_machine():
    pages = [README, *DOCS, ROOT / "bench" / "RESULTS.md", ROOT / "CITATION.cff"]
    for page in pages:
        for m in re.finditer(r"(/home/|/root/|/Users/|/work/|/tmp/)\S*", page.read_text(encoding="utf-8")):
            raise AssertionError(f"{page.relative_to(ROOT)}: {m.group(0)}")


def _native_ratios():
    """The native FMUs' speed-up over pythonfmu under the master, FMI 2.0 and 3.0, from the generated
    section of bench/RESULTS.md (the 'this' column, CPU)."""
    text = (ROOT / "bench" / "RESULTS.md").read_text(encoding="utf-8")
    section = text[text.index("<!-- native:start -->"):text.index("<!-- native:end -->")]
    row = re.compile(r"^\| native C, FMI (\d\.\d) \|.*\| \*\*(\d+\.\d+)x\*\* \(\d+\.\d+x\) \|$", re.M)
    rows = {m.group(1): m.group(2) for m in row.finditer(section)}
    return rows["2.0"], rows["3.0"]


def test_the_native_speed_up_has_one_figure_everywhere():
    fmi2, fmi3 = _native_ratios()
    pages = [README, *DOCS]
    claims = 0
    for page in pages:
        text = page.read_text(encoding="utf-8")
        assert not re.search(r"about (two|three|four|five|six|seven|\d+) times faster", text), page.name
        for m in re.finditer(r"(\d+\.\d+) times\s+(?:faster|the pythonfmu)", text):
            claims += 1
            assert m.group(1) == fmi2, f"{page.name}: {m.group(0)} (bench/RESULTS.md: {fmi2})"
            assert f"FMI 3.0: {fmi3} times" in text[m.end():m.end() + 200], f"{page.name}: {m.group(0)}"
    assert claims >= 4  # the README twice, docs/scenarios.md, docs/fmus.md


def test_the_readme_speed_summary_is_three_lines_copied_from_bench_results():
    text = README.read_text(encoding="utf-8")
    section = text[text.index("## Speed\n"):text.index("\n## ", text.index("## Speed\n") + 1)]
    bullets = [line for line in section.splitlines() if line.startswith("* ")]
    assert len(bullets) == 3
    results = (ROOT / "bench" / "RESULTS.md").read_text(encoding="utf-8")
    for figure in re.findall(r"(\d+\.\d+)(?= times|x)", section):
        assert re.search(rf"\b{re.escape(figure)}(x\b|\s+\||\s+times)", results), figure

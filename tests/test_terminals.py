"""FMI 3.0 terminals (``terminalsAndIcons/terminalsAndIcons.xml``) of the native FMI 3.0 plant and
controller: valid against the standard's schema (the copy fmpy ships), every member a variable of
the FMU, and the terminals the two FMUs share connect exactly the plant-controller connections
of :data:`orchestration.scenario.system.DEFAULT_CONNECTIONS` (each member an output on one side
and an input on the other), so a tool that connects terminals by name wires the pair as our
master does.
"""

from __future__ import annotations

import zipfile
from pathlib import Path

import fmpy
import pytest
from fmpy import read_model_description

from orchestration.packaging import fmus
from orchestration.scenario.system import DEFAULT_CONNECTIONS

FILE = "terminalsAndIcons/terminalsAndIcons.xml"
SCHEMA = Path(fmpy.__file__).parent / "schema" / "fmi3" / "fmi3TerminalsAndIcons.xsd"


def terminals(path):
    from lxml import etree

    with zipfile.ZipFile(path) as z:
        root = etree.fromstring(z.read(FILE))
    return root, {t.get("name"): (t.get("matchingRule"),
                                  {m.get("memberName"): m.get("variableName")
                                   for m in t.findall("TerminalMemberVariable")})
                  for t in root.findall("Terminals/Terminal")}


@pytest.fixture(scope="module")
def pair(fmu_dir):
    return fmus.paths(fmu_dir, "native-fmi3")


def test_the_terminals_validate_against_the_fmi3_schema(pair):
    from lxml import etree

    schema = etree.XMLSchema(file=str(SCHEMA))
    for path in pair:
        root, found = terminals(path)
        assert schema.validate(etree.ElementTree(root)), schema.error_log
        assert found, f"{path.name}: no terminal"


def test_every_member_is_a_variable_of_its_fmu(pair):
    for path in pair:
        names = {v.name for v in read_model_description(str(path)).modelVariables}
        _, found = terminals(path)
        for tname, (_, members) in found.items():
            assert set(members.values()) <= names, f"{path.name} terminal {tname}"


def test_the_shared_terminals_connect_the_pair_as_the_master_does(pair):
    plant, ctrl = pair
    causality = {unit: {v.name: v.causality for v in read_model_description(str(p)).modelVariables}
                 for unit, p in (("plant", plant), ("controller", ctrl))}
    (_, tp), (_, tc) = terminals(plant), terminals(ctrl)
    links = set()
    for name in tp.keys() & tc.keys():
        (rule_p, mp), (rule_c, mc) = tp[name], tc[name]
        assert rule_p == rule_c == "plug" and mp.keys() == mc.keys(), name
        for member in mp:
            ends = {("plant", mp[member]), ("controller", mc[member])}
            out = [e for e in ends if causality[e[0]][e[1]] == "output"]
            inp = [e for e in ends if causality[e[0]][e[1]] == "input"]
            assert len(out) == len(inp) == 1, f"{name}.{member}: {ends}"
            links.add((f"{out[0][0]}.{out[0][1]}", f"{inp[0][0]}.{inp[0][1]}"))
    want = {(c.source, c.target) for c in DEFAULT_CONNECTIONS
            if c.source.split(".")[0] != "profile" and c.target.split(".")[0] != "profile"}
    assert links == want


def test_the_fmi2_fmus_carry_no_terminals(fmu_dir):
    for path in fmus.paths(fmu_dir, "native"):
        with zipfile.ZipFile(path) as z:
            assert FILE not in z.namelist()

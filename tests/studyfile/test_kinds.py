"""The registry of the kinds of study (cyclomesh.studyfile.kinds): every entry resolves to
its StudyKind, its section, its options and its command, so that a kind is one entry."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from cyclomesh.cli import app
from cyclomesh.cli.options import ARGUMENTS, OPTIONS
from cyclomesh.studies.execute import StudyKind, load_kind
from cyclomesh.studies.preflight import COMMANDS
from cyclomesh.studyfile.kinds import KINDS, kind_spec
from cyclomesh.studyfile.schema import StudyFile
from cyclomesh.studyfile.usage import KINDS as CHECKED_KINDS
from cyclomesh.studyfile.usage import OWN_SECTIONS, REFUSED, USED

SPECS = {spec.command: spec for spec in KINDS}


def test_commands_are_the_registry():
    assert len(SPECS) == len(KINDS), "a command is registered twice"
    assert COMMANDS == tuple(SPECS)
    assert set(CHECKED_KINDS) == {c for c, s in SPECS.items() if s.used is not None}
    assert set(OWN_SECTIONS) == set(SPECS)
    assert set(USED) == set(REFUSED) == set(CHECKED_KINDS)
    with pytest.raises(KeyError):
        kind_spec("no-such-kind")


@pytest.mark.parametrize("command", list(SPECS))
def test_entry_resolves(command):
    spec = SPECS[command]
    kind = load_kind(command)
    assert isinstance(kind, StudyKind) and kind.command == command
    assert spec.argument in ARGUMENTS
    assert all(name in OPTIONS for name in spec.options)
    assert spec.help.strip() and spec.help.strip()[0].isupper()
    if spec.section is not None:
        field, model = spec.section
        annotation = StudyFile.model_fields[field].annotation
        assert model in str(annotation), f"StudyFile.{field} is {annotation}"
    if spec.argument != "study":  # the file must have the section the argument names
        assert spec.written_for is not None


def test_every_kind_section_is_a_field_and_none_is_left_over():
    sections = {spec.section[0] for spec in KINDS if spec.section}
    fields = set(StudyFile.model_fields)
    assert sections <= fields
    assert fields - sections == {
        "title", "description", "design", "modification", "material", "load", "errors",
        "analysis", "figures", "cases", "stage", "friction", "requirements",
    }  # fmt: skip


@pytest.mark.parametrize("command", list(SPECS))
def test_each_command_takes_its_options(command):
    out = CliRunner().invoke(app, [command, "--help"], terminal_width=200)
    assert out.exit_code == 0
    for name in SPECS[command].options:
        flag = "--" + name.replace("_", "-")
        assert flag in out.output, f"cyclomesh {command} lacks {flag}"
    assert "--out" in out.output and "STUDY.toml" in out.output

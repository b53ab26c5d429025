"""The command pauses Python's cyclic garbage collector while it starts and turns it back
on (with what it imported frozen) before it works (cyclomesh.execution.runtime.pause_gc,
resume_gc); a command run in a process (``app([...])``) and library calls leave it alone."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

SEEN = """
import atexit, gc, sys
from cyclomesh.execution import runtime
seen = []
atexit.register(lambda: print(seen))  # the entry ends the process after atexit
resume = runtime.resume_gc
def spy():
    seen.append(("before", gc.isenabled()))
    resume()
    seen.append(("after", gc.isenabled(), gc.get_freeze_count() > 0))
runtime.resume_gc = spy
"""


def _seen(code: str) -> str:
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-3000:]
    return done.stdout.strip().splitlines()[-1]


@pytest.mark.parametrize("command", ["run", "check"])
def test_the_command_resumes_the_collector_it_paused(tmp_path, command):
    """From the command's entry: off while it starts, on again (imports frozen) before
    ``run`` computes and in ``check`` (the command group's callback)."""
    args = [command, str(EXAMPLES / "table2.toml")]
    if command == "run":
        args += ["--out", str(tmp_path / "out"), "-q", "--figures", "none"]
        args += ["--crank-step-deg", "30"]
    code = (
        SEEN + f"sys.argv = ['cyclomesh', *{args!r}]\nfrom cyclomesh.__main__ import main\nmain()\n"
    )
    assert _seen(code) == "[('before', False), ('after', True, True)]"


def test_a_command_run_in_a_process_leaves_the_collector_alone(tmp_path):
    """``app([...])`` (no entry, no pause): the collector stays on and nothing is frozen."""
    args = ["run", str(EXAMPLES / "table2.toml"), "--out", str(tmp_path / "out"), "-q"]
    args += ["--figures", "none", "--crank-step-deg", "30"]
    code = SEEN + (
        "from cyclomesh.cli import app\n"
        f"try:\n    app({args!r})\nexcept SystemExit as exc:\n    assert not exc.code\n"
        "seen.append(('end', gc.isenabled(), gc.get_freeze_count()))\n"
    )
    assert _seen(code) == "[('before', True), ('after', True, False), ('end', True, 0)]"

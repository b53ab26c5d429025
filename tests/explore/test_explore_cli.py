"""``cyclomesh explore``: one address line, loopback only, Ctrl-C stops cleanly, and a bad
study or a taken port is refused in one line with exit status 2."""

from __future__ import annotations

import socket
import subprocess
import sys

import pytest

from .conftest import EXAMPLES, Server

pytest.importorskip("uvicorn", reason="the explore extra (uvicorn) is not installed")


def _cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "cyclomesh", *map(str, args)], capture_output=True, text=True
    )


def test_serves_on_loopback_says_its_address_and_stops_on_ctrl_c():
    server = Server(EXAMPLES / "requirements.toml")
    try:
        assert server.url.startswith("http://127.0.0.1:")
        assert server.line.endswith("(Ctrl-C stops)")
        assert server.get("/api/health")["study"] == "requirements.toml"
    finally:
        code, out, err = server.stop()
    assert code == 0, err
    assert "Traceback" not in err and "Traceback" not in out
    assert out.strip() == ""  # the address line was the one line


def test_a_bad_study_is_refused_before_serving(tmp_path):
    study = tmp_path / "bad.toml"
    text = (EXAMPLES / "table2.toml").read_text().replace("pins = 40", "pins = 2")
    study.write_text(text)
    out = _cli("explore", study, "--no-browser", "--port", "0")
    assert out.returncode == 2
    assert out.stderr.startswith("error: design.pins:") and out.stderr.count("\n") == 1


def test_a_port_in_use_is_refused_in_one_line():
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        out = _cli("explore", EXAMPLES / "table2.toml", "--no-browser", "--port", port)
    assert out.returncode == 2
    assert out.stderr.startswith("error: ") and out.stderr.count("\n") == 1
    assert "in use" in out.stderr


def test_without_the_explore_extra_the_command_says_how_to_install_it():
    code = (
        "import sys; sys.modules['uvicorn'] = None; from cyclomesh.cli import app; "
        f"app(['explore', {str(EXAMPLES / 'table2.toml')!r}, '--no-browser'])"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 2
    assert out.stderr.strip() == (
        "error: cyclomesh explore needs the explore extra (starlette, uvicorn, plotly): "
        "pip install -e '.[explore]'"
    )

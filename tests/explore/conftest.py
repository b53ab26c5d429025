"""A real ``cyclomesh explore`` server on a free loopback port, stopped with Ctrl-C."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


class Server:
    """A ``cyclomesh explore STUDY --port 0 --no-browser`` process and its address."""

    def __init__(self, study: Path) -> None:
        env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        self.proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "cyclomesh",
                "explore",
                str(study),
                "--port",
                "0",
                "--no-browser",
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )
        self.line = self.proc.stdout.readline().strip()
        if " at http://127.0.0.1:" not in self.line:
            self.proc.kill()
            raise AssertionError(f"no address line: {self.line!r} {self.proc.stderr.read()}")
        self.url = self.line.split(" at ", 1)[1].split()[0]

    def get(self, path: str) -> dict:
        with urllib.request.urlopen(self.url + path.lstrip("/"), timeout=30) as response:
            return json.loads(response.read())

    def stop(self) -> tuple[int, str, str]:
        """Ctrl-C (SIGINT), then the exit status, the rest of stdout and stderr."""
        self.proc.send_signal(signal.SIGINT)
        try:
            out, err = self.proc.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            out, err = self.proc.communicate()
            raise AssertionError("the server did not stop on Ctrl-C") from None
        return self.proc.returncode, out, err


@pytest.fixture(scope="module")
def server() -> Iterator[Server]:
    pytest.importorskip("uvicorn", reason="the explore extra (uvicorn) is not installed")
    running = Server(EXAMPLES / "table2.toml")
    deadline = time.monotonic() + 30
    while True:
        try:
            running.get("/api/health")
            break
        except OSError:
            if time.monotonic() > deadline:
                running.stop()
                raise
            time.sleep(0.1)
    yield running
    if running.proc.poll() is None:
        running.stop()

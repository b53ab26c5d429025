"""A real ``cyclomesh explore`` server on a free loopback port, stopped with Ctrl-C."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import urllib.error
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


class Answer:
    """An HTTP answer: ``status_code``, ``content``, ``text``, ``json()``."""

    def __init__(self, status_code: int, content: bytes) -> None:
        self.status_code = status_code
        self.content = content
        self.text = content.decode("utf-8")

    def json(self):
        return json.loads(self.content)


class LiveApp:
    """The explorer's app of a :class:`~cyclomesh.explore.session.Session` on uvicorn in
    a thread of this process, on a free loopback port, spoken to over real HTTP."""

    def __init__(self, study: Path) -> None:
        import socket
        import threading

        import uvicorn

        from cyclomesh.explore.app import create_app
        from cyclomesh.explore.session import Session

        self.session = Session(study)
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(16)
        self.url = f"http://127.0.0.1:{self.sock.getsockname()[1]}"
        config = uvicorn.Config(create_app(self.session), log_level="warning", lifespan="off")
        self.server = uvicorn.Server(config)
        self.server.install_signal_handlers = lambda: None  # not the main thread
        self.thread = threading.Thread(target=self.server.run, kwargs={"sockets": [self.sock]})
        self.thread.start()

    def _call(self, method: str, path: str, data: bytes | None = None) -> Answer:
        request = urllib.request.Request(self.url + path, data=data, method=method)
        request.add_header("Content-Type", "application/json")
        try:
            with urllib.request.urlopen(request, timeout=120) as response:
                return Answer(response.status, response.read())
        except urllib.error.HTTPError as exc:
            return Answer(exc.code, exc.read())

    def get(self, path: str) -> Answer:
        return self._call("GET", path)

    def post(self, path: str, json: dict | None = None, content: bytes | None = None) -> Answer:
        data = content if content is not None else _json_bytes(json or {})
        return self._call("POST", path, data)

    def close(self) -> None:
        self.server.should_exit = True
        self.thread.join(timeout=30)
        self.sock.close()
        self.session.close()


def _json_bytes(body: dict) -> bytes:
    return json.dumps(body).encode()

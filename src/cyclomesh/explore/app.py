"""The explorer's web server: a Starlette app on uvicorn, bound to 127.0.0.1.

Routes (the page uses the same JSON API that scripts and tests do):

- ``GET /``: the page; ``GET /static/plotly.min.js`` is Plotly's own bundle from the
  installed ``plotly`` package, so the page fetches nothing from outside (works offline);
- ``GET /api/health``: ``{"status": "ok", ...}``;
- ``GET /api/defaults?case=NAME``: the values of the controls for a case of the study;
- ``POST /api/analyse``: ``{"overrides": {"modification.pin_radius_um": 5.0, ...},
  "pin_errors": {"mode": "scaled", "factor": 2.0, "seed": 0}, "crank_angle_deg": 30,
  "exaggeration": 1, "torsion": false, "case": NAME}`` (all optional) → the summary
  metrics of ``summary.json`` (same names, ``units``), the requirement checks, the
  warnings and the plot arrays; a refused value → HTTP 422 ``{"error": one line,
  "key": dotted key}``;
- ``POST /api/study``: the same body → the state as a one-case study file (TOML) that
  ``cyclomesh run`` reproduces.

Needs the ``explore`` extra (starlette, uvicorn, plotly).
"""

from __future__ import annotations

import json
import signal
import socket
import threading
from importlib import resources
from pathlib import Path
from typing import Any

from cyclomesh.exceptions import StudyError
from cyclomesh.explore.session import ExploreError, Session

__all__ = ["EXPLORE_EXTRA_MESSAGE", "create_app", "serve", "plotly_js"]

EXPLORE_EXTRA_MESSAGE = (
    "cyclomesh explore needs the explore extra (starlette, uvicorn, plotly): "
    "pip install -e '.[explore]'"
)


def plotly_js() -> Path:
    """Plotly's JavaScript bundle as the installed ``plotly`` package ships it."""
    import plotly

    path = Path(plotly.__file__).parent / "package_data" / "plotly.min.js"
    if not path.is_file():
        raise StudyError(f"{path}: plotly.min.js missing from the plotly package; reinstall it")
    return path


def _static(name: str) -> str:
    return resources.files("cyclomesh.explore").joinpath("static", name).read_text("utf-8")


def _error_key(exc: Exception, body: Any) -> str:
    """The dotted key a refused value belongs to: the explorer's own, else the first
    override named in the message, else ''."""
    if isinstance(exc, ExploreError) and exc.key:
        return exc.key
    message = str(exc)
    overrides = body.get("overrides") if isinstance(body, dict) else None
    if isinstance(overrides, dict):
        for key in overrides:
            if message.startswith(f"{key}:") or f" {key}:" in message:
                return str(key)
        for key in overrides:  # "modification.pin_radius" in a core message
            stem = str(key).rsplit("_", 1)[0]
            if stem in message:
                return str(key)
    return ""


def create_app(session: Session) -> Any:
    """The Starlette application serving ``session``."""
    from starlette.applications import Starlette
    from starlette.requests import Request
    from starlette.responses import FileResponse, HTMLResponse, JSONResponse, Response
    from starlette.routing import Route

    from cyclomesh.publish.report import cyclomesh_version

    plotly_path = plotly_js()
    page = _static("index.html")
    scripts = {"explore.js": "text/javascript", "explore.css": "text/css"}

    def index(request: Request) -> Response:
        return HTMLResponse(page)

    def static(request: Request) -> Response:
        name = request.path_params["name"]
        if name == "plotly.min.js":
            return FileResponse(plotly_path, media_type="text/javascript")
        if name in scripts:
            return Response(_static(name), media_type=scripts[name])
        return JSONResponse({"error": f"{name}: not found"}, status_code=404)

    def health(request: Request) -> Response:
        return JSONResponse(
            {"status": "ok", "study": session.path.name, "version": cyclomesh_version()}
        )

    def _refused(exc: Exception, body: Any) -> Response:
        line = " ".join(str(exc).split())
        return JSONResponse({"error": line, "key": _error_key(exc, body)}, status_code=422)

    def defaults(request: Request) -> Response:
        try:
            return JSONResponse(session.defaults(request.query_params.get("case")))
        except StudyError as exc:
            return _refused(exc, {})

    async def _body(request: Request) -> Any:
        try:
            return json.loads(await request.body() or b"{}")
        except (ValueError, UnicodeDecodeError) as exc:
            raise ExploreError(f"request body: invalid JSON ({exc})") from None

    async def analyse(request: Request) -> Response:
        from starlette.concurrency import run_in_threadpool

        body: Any = {}
        try:
            body = await _body(request)
            result = await run_in_threadpool(session.analyse, body)
        except StudyError as exc:
            return _refused(exc, body)
        return Response(json.dumps(result, allow_nan=False), media_type="application/json")

    async def study(request: Request) -> Response:
        from starlette.concurrency import run_in_threadpool

        body: Any = {}
        try:
            body = await _body(request)
            text = await run_in_threadpool(session.study_text, body)
        except StudyError as exc:
            return _refused(exc, body)
        name = session.path.stem + "-explored.toml"
        return Response(
            text,
            media_type="application/toml",
            headers={"Content-Disposition": f'attachment; filename="{name}"'},
        )

    return Starlette(
        routes=[
            Route("/", index),
            Route("/static/{name}", static),
            Route("/favicon.ico", lambda request: Response(status_code=204)),
            Route("/api/health", health),
            Route("/api/defaults", defaults),
            Route("/api/analyse", analyse, methods=["POST"]),
            Route("/api/study", study, methods=["POST"]),
        ]
    )


def serve(
    study: str | Path,
    port: int = 8050,
    open_browser: bool = True,
    echo: Any = print,
) -> None:
    """Serve the explorer of ``study`` on http://127.0.0.1:PORT/ until Ctrl-C.

    The study is loaded and validated first (a bad file is refused in one line before
    anything listens); ``port = 0`` takes a free port. One line gives the address.

    Raises
    ------
    StudyError
        The study file is refused, or the explore extra is missing.
    OSError
        The port cannot be bound (e.g. in use).
    """
    try:
        import uvicorn
    except ImportError:
        raise StudyError(EXPLORE_EXTRA_MESSAGE) from None
    try:
        session = Session(study)
        app = create_app(session)
    except ImportError:
        raise StudyError(EXPLORE_EXTRA_MESSAGE) from None
    try:  # imports and caches warmed up: the page's first answer is as fast as the next
        session.analyse({"overrides": session.defaults()["overrides"]})
    except StudyError:
        pass  # the page shows the one line
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(("127.0.0.1", port))
        sock.listen(128)  # connections wait from now on, while uvicorn starts
    except OSError:
        sock.close()
        session.close()
        raise
    address = f"http://127.0.0.1:{sock.getsockname()[1]}/"
    config = uvicorn.Config(app, log_level="warning", access_log=False, lifespan="off")
    server = uvicorn.Server(config)
    echo(f"cyclomesh explore: {session.path.name} at {address} (Ctrl-C stops)")
    if open_browser:
        import webbrowser

        threading.Timer(0.5, webbrowser.open, (address,)).start()
    # Ctrl-C is the way to stop: uvicorn shuts down, then hands the signal back to the
    # handler it found, here Python's own (a KeyboardInterrupt, caught: exit status 0)
    # rather than the one-line "interrupted" of a command that was cut short
    main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, signal.default_int_handler) if main else None
    try:
        server.run(sockets=[sock])
    except KeyboardInterrupt:
        pass
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
        sock.close()
        session.close()

"""Benchmark of the explorer: how fast ``POST /api/analyse`` answers a 360-step case.

Starts ``cyclomesh explore examples/table2.toml --port 0 --no-browser`` (a real server,
loopback only), then posts states as the page does, over HTTP, timing each answer from
request to parsed JSON (the page's whole round trip minus drawing):

- ``new Δρ``: a new modification every request (solve + disc outline, nothing cached);
- ``new torque``: a new torque every request (solve, outline cached);
- ``crank angle``: the same state at another crank angle (cached solve: redraw only).

Target (issue 28, on a 2-core shared machine): a 360-step case answers in < 0.3 s
(median). Requests are bounded in number and go to 127.0.0.1 only.

    .venv/bin/python benchmarks/bench_explore.py --requests 21
"""

from __future__ import annotations

import argparse
import json
import signal
import statistics
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STUDY = ROOT / "examples" / "table2.toml"


def _post(url: str, body: dict) -> tuple[float, dict]:
    data = json.dumps(body).encode()
    request = urllib.request.Request(
        url + "api/analyse", data=data, headers={"Content-Type": "application/json"}
    )
    start = time.perf_counter()
    with urllib.request.urlopen(request, timeout=60) as response:
        answer = json.loads(response.read())
    return time.perf_counter() - start, answer


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--requests", type=int, default=21, help="requests per kind")
    args = parser.parse_args()
    proc = subprocess.Popen(
        [sys.executable, "-m", "cyclomesh", "explore", str(STUDY), "--port", "0", "--no-browser"],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        line = proc.stdout.readline()
        url = line.split(" at ", 1)[1].split()[0]
        base = {"analysis.crank_step_deg": 1.0}
        kinds = {
            "new Δρ": lambda k: {"overrides": {**base, "modification.pin_radius_um": 4 + 0.25 * k}},
            "new torque": lambda k: {"overrides": {**base, "load.torque_nm": 100.0 + 10 * k}},
            "crank angle": lambda k: {"overrides": base, "crank_angle_deg": 7.0 * k},
        }
        _post(url, kinds["new Δρ"](-1))  # first request: nothing to learn from it
        print(f"cyclomesh explore, {STUDY.name} case 1, 360 crank angles x 40 pins")
        for name, body in kinds.items():
            times, solves = [], []
            for k in range(args.requests):
                seconds, answer = _post(url, body(k))
                assert len(answer["plots"]["crank_angle_deg"]) == 360
                times.append(seconds)
                solves.append(answer["seconds"])
            print(
                f"  {name:12s} median {1e3 * statistics.median(times):6.1f} ms  "
                f"(min {1e3 * min(times):5.1f}, max {1e3 * max(times):6.1f}; "
                f"pipeline {1e3 * statistics.median(solves):5.1f} ms)  n = {len(times)}"
            )
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=30)


if __name__ == "__main__":
    main()

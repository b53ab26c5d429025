"""Screenshots of the explorer for docs/explore.md (1366 px wide, headless Chromium).

    .venv/bin/python benchmarks/explore_screenshots.py docs/

Starts ``cyclomesh explore examples/requirements.toml`` on a free loopback port and
drives the page with Playwright through Debian's ``chromium`` (never ``playwright
install``): the page as it opens, then Δρ = 12 µm with the deformation exaggerated and
the torsion curve, then a refused value.
"""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

from playwright.sync_api import sync_playwright

ROOT = Path(__file__).resolve().parents[1]
ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]


def _settle(page) -> None:
    page.wait_for_function("() => !document.body.classList.contains('busy')")
    page.wait_for_timeout(700)


def main(out: Path) -> None:
    study = ROOT / "examples" / "requirements.toml"
    proc = subprocess.Popen(
        [sys.executable, "-m", "cyclomesh", "explore", str(study), "--port", "0", "--no-browser"],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        url = proc.stdout.readline().split(" at ", 1)[1].split()[0]
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=ARGS)
            page = browser.new_page(viewport={"width": 1366, "height": 900})
            page.goto(url)
            page.wait_for_selector("#metric-max_contact_stress_mpa")
            page.fill("#crank", "0")
            _settle(page)
            page.screenshot(path=out / "explore.png", full_page=True)
            page.fill("#drho", "12")
            page.dispatch_event("#drho", "change")
            page.check("#exag")
            page.fill("#exagf", "100")
            page.dispatch_event("#exagf", "change")
            page.check("#torsion")
            _settle(page)
            page.screenshot(path=out / "explore-deformed.png", full_page=True)
            page.fill("#drho", "-40")
            page.dispatch_event("#drho", "change")
            _settle(page)
            page.screenshot(
                path=out / "explore-refused.png",
                clip={"x": 0, "y": 0, "width": 1366, "height": 520},
            )
            browser.close()
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=30)


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "docs"))

"""The real page in headless Chromium (Debian's ``chromium`` through Playwright): change
Δρ and the peak stress changes in the page, a bad value shows its one-line message
beside the control, the downloaded study reproduces the shown numbers through
``cyclomesh run``. Skipped, with the reason, where no browser can be had."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import tomllib
import urllib.request

import pytest

CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]


def _chromium() -> str | None:
    for name in ("chromium", "chromium-browser"):
        path = shutil.which(name)
        if path:
            return path
    return None


@pytest.fixture(scope="module")
def browser():
    try:
        from playwright.sync_api import Error, sync_playwright
    except ImportError:
        pytest.skip("no browser: the playwright package is not installed (dev extra)")
    path = _chromium()
    if path is None:
        pytest.skip("no browser: Debian's chromium is not installed (apt-get install chromium)")
    with sync_playwright() as p:
        try:
            chromium = p.chromium.launch(executable_path=path, args=CHROMIUM_ARGS)
        except Error as exc:
            pytest.skip(f"no browser: {path} does not start headless ({str(exc).splitlines()[0]})")
        yield chromium
        chromium.close()


@pytest.fixture
def page(browser, server):
    context = browser.new_context(viewport={"width": 1366, "height": 900}, accept_downloads=True)
    tab = context.new_page()
    outside = []
    tab.on(
        "request",
        lambda r: outside.append(r.url) if not r.url.startswith(server.url) else None,
    )
    tab.goto(server.url)
    tab.wait_for_selector("#metric-max_contact_stress_mpa", timeout=60_000)
    yield tab
    context.close()
    assert not [u for u in outside if not u.startswith(("blob:", "data:"))], outside


def _value(page, name):
    return json.loads(page.get_attribute(f"#metric-{name}", "data-value"))


def _set(page, selector, text):
    page.fill(selector, text)
    page.dispatch_event(selector, "change")


def _wait_for_new(page, name, old):
    page.wait_for_function(
        "([name, old]) => { const r = document.getElementById('metric-' + name);"
        " return r && r.dataset.value !== old; }",
        arg=[name, json.dumps(old)],
        timeout=30_000,
    )
    return _value(page, name)


def test_changing_the_pin_radius_modification_changes_the_peak_stress(page):
    assert page.input_value("#drho") == "8"  # Table 2's TPM
    before = _value(page, "max_contact_stress_mpa")
    _set(page, "#drho", "16")
    after = _wait_for_new(page, "max_contact_stress_mpa", before)
    # a larger Δρ loads fewer pins, each harder
    assert after > before
    shown = page.inner_text("#metric-max_contact_stress_mpa td.v")
    assert float(shown) == pytest.approx(after, rel=1e-4)
    assert f"peak {shown} MPa" in page.inner_text("#stress")
    assert page.inner_text("#status").startswith("answered in")
    # the crank angle moves the drawing and the pin loads, not the metrics
    page.fill("#crank", "90")
    page.dispatch_event("#crank", "input")
    page.wait_for_function(
        "() => document.getElementById('loads').textContent.includes('φ = 90°')", timeout=30_000
    )
    assert "φ = 90°" in page.text_content("#scene")
    assert _value(page, "max_contact_stress_mpa") == after


def test_a_bad_value_shows_its_one_line_message_beside_the_control(page, server):
    _set(page, "#drho", "abc")
    box = page.locator('.err[data-err="modification.pin_radius_um"]')
    box.wait_for(state="visible", timeout=30_000)
    request = urllib.request.Request(
        server.url + "api/analyse",
        data=json.dumps({"overrides": {"modification.pin_radius_um": "abc"}}).encode(),
        headers={"Content-Type": "application/json"},
    )
    with pytest.raises(urllib.error.HTTPError) as refused:
        urllib.request.urlopen(request, timeout=30)
    assert refused.value.code == 422
    message = json.loads(refused.value.read())["error"]
    assert box.inner_text() == message
    assert message == 'modification.pin_radius_um: expected a number, got "abc"'
    # the control is marked, and a good value clears the message
    assert "bad" in page.get_attribute("#drho", "class")
    _set(page, "#drho", "10")
    box.wait_for(state="hidden", timeout=30_000)


def test_the_downloaded_study_reproduces_the_shown_numbers(page, tmp_path):
    before = _value(page, "max_contact_stress_mpa")
    _set(page, "#drho", "12")
    _wait_for_new(page, "max_contact_stress_mpa", before)
    before = _value(page, "max_contact_stress_mpa")
    page.select_option("#direction", "-1")
    page.dispatch_event("#direction", "change")
    page.select_option("#emode", "scaled")
    _set(page, "#efactor", "2")  # table2 has no pin errors: twice none is none
    page.check("#groove")
    _wait_for_new(page, "max_contact_stress_mpa", before)
    page.wait_for_function("() => window.exploreIdle()", timeout=60_000)  # nothing in flight
    rows = page.eval_on_selector_all(
        "#summary tbody tr",
        "rows => rows.map(r => [r.id.slice(7), JSON.parse(r.dataset.value)])",
    )
    shown = dict(rows)
    with page.expect_download() as download:
        page.click("#download")
    study = tmp_path / download.value.suggested_filename
    download.value.save_as(study)
    assert study.name == "table2-explored.toml"
    out = subprocess.run(
        [sys.executable, "-m", "cyclomesh", "run", str(study), "--out", str(tmp_path / "out")]
        + ["--figures", "none", "-q"],
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stderr
    record = json.loads((tmp_path / "out" / "summary.json").read_text())["cases"][0]
    differ = {name: (value, record.get(name)) for name, value in shown.items()}
    differ = {name: pair for name, pair in differ.items() if pair[0] != pair[1]}
    assert shown and not differ
    table = tomllib.loads(study.read_text())
    assert table["load"]["torque_nm"] == -250 and table["analysis"]["groove_deformation"]
    assert table["modification"]["pin_radius_um"] == 12


def test_tables_of_summary_json_are_shown_as_text_with_their_units(browser):
    """A friction study's summary holds a table (losses per path, W) and the input speed
    (rpm): every row shows its unit from the quantities registry and no row shows a raw
    JavaScript object."""
    from .conftest import EXAMPLES, Server

    running = Server(EXAMPLES / "efficiency.toml")
    context = browser.new_context(viewport={"width": 1366, "height": 900})
    try:
        tab = context.new_page()
        tab.goto(running.url)
        tab.wait_for_selector("#metric-power_loss_w", timeout=60_000)
        rows = tab.eval_on_selector_all(
            "#summary tbody tr",
            "rows => rows.map(r => [r.id.slice(7), Array.from(r.cells, c => c.textContent)])",
        )
        shown = dict(rows)
        assert not [name for name, cells in shown.items() if "object" in cells[1]]
        assert shown["input_speed_rpm"][2] == "rpm"
        assert shown["power_loss_w"][2] == "W" and "tooth" in shown["power_loss_w"][1]
    finally:
        context.close()
        running.stop()

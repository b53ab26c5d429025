"""The overview's figure process imports matplotlib its own way
(:func:`cyclomesh.figures.worker._import_matplotlib`: no 3D toolkit, no property tables
in docstrings while it imports) and draws exactly what a plain import of matplotlib
draws; matplotlib is left as it was (``kwdoc`` restored)."""

from __future__ import annotations

import json
import subprocess
import sys

DRAW = """
import base64, json, re, sys
import numpy as np
{importing}
import matplotlib.artist
matplotlib.rcParams["svg.hashsalt"] = "fixed"  # SVG ids are random otherwise
from cyclomesh.figures.overview import OverviewCase, plot_overview
from cyclomesh.figures.render import FigureJob, render_job

angles = np.arange(0.0, 360.0, 10.0)
cases = {{
    name: OverviewCase(
        crank_angle=angles,
        pin=np.arange(1, 41),
        pin_load_at=0.0,
        pin_load=np.linspace(0.0, 900.0, 40) * (1 + k),
        transmission_error=np.cos(np.radians(angles)) + k,
        max_contact_stress=900.0 + 10.0 * np.sin(np.radians(angles + 30 * k)),
        contacts=np.full(angles.size, 9 + k),
    )
    for k, name in enumerate(["Case 1", "Case 2 µm"])
}}
job = FigureJob("overview", plot_overview, (cases,))
drawn = render_job(job, ("png", "svg"), 80)
svg = re.sub(rb"<dc:date>.*?</dc:date>", b"", drawn["svg"])
print(json.dumps({{
    "png": base64.b64encode(drawn["png"]).decode(),
    "svg": base64.b64encode(svg).decode(),
    "kwdoc": matplotlib.artist.kwdoc(matplotlib.artist.Artist)[:40],
    "set_doc": "Properties:" in (matplotlib.artist.Artist.set.__doc__ or ""),
}}))
"""


def _draw(importing: str) -> dict:
    done = subprocess.run(
        [sys.executable, "-c", DRAW.format(importing=importing)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_the_figure_process_draws_what_a_plain_import_draws():
    """The overview (two cases, a legend, a non-ASCII label) in PNG and SVG, byte for
    byte the same after the figure process's import as after ``import matplotlib``;
    ``matplotlib.artist.kwdoc`` works again afterwards."""
    ours = _draw("from cyclomesh.figures.worker import _import_matplotlib\n_import_matplotlib()")
    plain = _draw("import matplotlib.figure, matplotlib.backends.backend_agg")
    assert ours["png"] == plain["png"]
    assert ours["svg"] == plain["svg"]
    assert ours["kwdoc"] == plain["kwdoc"] and ours["kwdoc"].startswith("Properties:")
    assert plain["set_doc"]  # Artist's own set() docstring is built before the stand-in

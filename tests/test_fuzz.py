"""Fuzz: mutate the examples' study files and run every command on them in-process.

For every mutated file and every command that takes it, the outcome must be either
exit 0 with a complete result folder (``cyclomesh.load_results``) whose NetCDF numbers
are finite (except in variables that document what a non-finite value means, in their
``nonfinite`` attribute), or exit 2 with one line ``error: ...`` and nothing written:
the folder (one per example and command, so each mutant runs into the complete result
of an earlier one) holds that earlier result byte for byte, or nothing if there was none.
No traceback, no "internal error", no NumPy RuntimeWarning (overflow, invalid value),
no hang. ``CYCLOMESH_FUZZ_SEED`` picks other mutations.

The commands are check, run, stiffness, tolerance, allocate, design, efficiency and
export (fe: check only, its model takes minutes). The examples are first made cheap
(coarse crank steps, few rings, points and candidates, no figures) so that a few
hundred cases run in about a minute; the mutations then hit one key each (or add or
delete one). The counts are printed
(``pytest -s``) and checked against a floor so that the test cannot pass vacuously.
"""

from __future__ import annotations

import math
import os
import random
import shutil
import time
import tomllib
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

from cyclomesh.cli import app
from cyclomesh.output.folder import load_results
from cyclomesh.output.writers import toml_dumps

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
CASES_PER_EXAMPLE = 45
SEED = int(os.environ.get("CYCLOMESH_FUZZ_SEED", "15"))

CHEAP = {
    "table2": {"analysis.crank_step_deg": 30.0},
    "section42": {"analysis.crank_step_deg": 30.0},
    "measured": {"analysis.crank_step_deg": 30.0},
    "stiffness": {"analysis.crank_step_deg": 30.0, "stiffness.points": 5},
    "tolerance": {
        "tolerance.crank_step_deg": 30.0,
        "tolerance.rings": 6,
        "tolerance.allocation.factor_steps": 2,
        "tolerance.allocation.bisections": 1,
    },
    "design": {
        "analysis.crank_step_deg": 30.0,
        "design_space.pin_circle_radius_um.points": 2,
        "design_space.pin_radius_um.points": 3,
    },
    "fe_table1": {},
    "efficiency": {
        "analysis.crank_step_deg": 3.0,
        "efficiency.torque_nm.points": 2,
        "efficiency.input_speed_rpm.points": 2,
        "stiffness.points": 3,
        "tolerance.rings": 2,
    },
}
COMMANDS = {
    "table2": ["check", "run", "export"],
    "section42": ["check", "run"],
    "measured": ["check", "run"],
    "stiffness": ["check", "stiffness"],
    "tolerance": ["check", "tolerance", "allocate"],
    "design": ["check", "design"],
    "fe_table1": ["check"],
    "efficiency": ["check", "efficiency"],
}
EXTRA = {
    "run": ["--figures", "none"],
    "stiffness": ["--figures", "none"],
    "tolerance": ["--figures", "none", "--workers", "1"],
    "allocate": ["--figures", "none", "--workers", "1"],
    "design": ["--figures", "none", "--workers", "1"],
    "efficiency": ["--figures", "none"],
    "export": ["--format", "dxf,csv"],
}


def _set(raw: dict, path: list[str], value: Any) -> None:
    for part in path[:-1]:
        raw = raw.setdefault(part, {})
    raw[path[-1]] = value


def _leaves(node: Any, path: tuple = ()) -> list[tuple]:
    if isinstance(node, dict):
        return [leaf for k, v in node.items() for leaf in _leaves(v, (*path, k))]
    if isinstance(node, list) and node and all(isinstance(v, dict) for v in node):
        return [leaf for i, v in enumerate(node) for leaf in _leaves(v, (*path, i))]
    return [path]


def _get(node: Any, path: tuple) -> Any:
    for part in path:
        node = node[part]
    return node


def _mutant_value(rng: random.Random, old: Any) -> Any:
    number = old if isinstance(old, int | float) and not isinstance(old, bool) else 1.0
    choices = [
        0,
        0.0,
        -1.0,
        -number,
        number * 10,
        number * 1e6,
        number * 1e-6,
        1e300,
        -1e300,
        1e-300,
        2**62,
        3,
        "x",
        "",
        True,
        [],
        [1.0, 2.0],
        [[[1.0]]],
        {"a": 1},
        math.inf,
        math.nan,
    ]
    if isinstance(old, list) and old:
        choices += [old[:-1], old + old[:1], [x * 1e3 for x in old if isinstance(x, float)]]
    if isinstance(old, str):
        choices += ["$x^{$", "\x7fname", old + "/../.."]
    return rng.choice(choices)


def mutate(raw: dict, rng: random.Random) -> str:
    """Change one thing in ``raw`` in place; return what."""
    leaves = [p for p in _leaves(raw) if p]
    kind = rng.random()
    path = rng.choice(leaves)
    if kind < 0.1:  # delete a key
        parent = _get(raw, path[:-1])
        parent.pop(path[-1]) if isinstance(parent, dict) else None
        return f"del {'.'.join(map(str, path))}"
    if kind < 0.15:  # an unknown key
        _get(raw, path[:-1])["no_such_key"] = 1 if isinstance(_get(raw, path[:-1]), dict) else 0
        return f"add {'.'.join(map(str, path[:-1]))}.no_such_key"
    value = _mutant_value(rng, _get(raw, path))
    parent = _get(raw, path[:-1])
    parent[path[-1]] = value
    return f"{'.'.join(map(str, path))} = {value!r}"


def _finite_or_documented(folder: Path) -> None:
    results = load_results(folder)  # refuses an incomplete folder
    for nc in results.netcdf:
        ds = results.dataset(nc.relative_to(folder).as_posix())
        for name, var in ds.variables.items():
            if var.dtype.kind != "f":
                continue
            if not np.isfinite(var.values).all():
                assert "nonfinite" in var.attrs, f"{nc.name}: {name} has undocumented inf/NaN"


def _complete_snapshot(folder: Path) -> dict[str, bytes] | None:
    """Every file of a complete result folder (None if there is none)."""
    try:
        load_results(folder)
    except Exception:
        return None
    return {
        p.relative_to(folder).as_posix(): p.read_bytes()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and p.name != ".cyclomesh.lock"
    }


@pytest.mark.filterwarnings("error::RuntimeWarning")  # an overflow is a bug, not a result
def test_fuzz_examples(tmp_path):
    rng = random.Random(SEED)
    runner = CliRunner()
    counts: Counter[str] = Counter()
    start = time.perf_counter()
    for example, cheap in CHEAP.items():
        base = tomllib.loads((EXAMPLES / f"{example}.toml").read_text())
        for dotted, value in cheap.items():
            _set(base, dotted.split("."), value)
        for index in range(CASES_PER_EXAMPLE):
            raw = tomllib.loads(toml_dumps(base))  # a deep copy
            what = mutate(raw, rng) if index else "unchanged"
            folder = tmp_path / f"{example}-{index}"
            folder.mkdir()
            shutil.copy(EXAMPLES / "measured_pins.csv", folder / "measured_pins.csv")
            study = folder / "study.toml"
            try:
                study.write_text(toml_dumps(raw), encoding="utf-8")
            except TypeError:
                continue
            for command in COMMANDS[example]:
                # one folder per example and command: each mutant runs into the complete
                # result of an earlier one (the unchanged file's first)
                out = tmp_path / f"{example}-out-{command}"
                before = _complete_snapshot(out)
                args = [command, str(study)]
                if command != "check":
                    args += ["--out", str(out), "-q", *EXTRA[command]]
                result = runner.invoke(app, args)
                label = f"{example} [{what}] {command}"
                counts["cases"] += 1
                if result.exit_code == 0:
                    counts["exit 0"] += 1
                    if command != "check":
                        _finite_or_documented(out)
                    continue
                lines = [line for line in result.output.splitlines() if line.strip()]
                assert result.exit_code == 2, (label, result.exit_code, result.output)
                assert len(lines) == 1 and lines[0].startswith("error: "), (label, result.output)
                assert "internal error" not in lines[0], (label, lines[0])
                if before is None:
                    assert not out.exists(), (label, sorted(out.rglob("*")))
                else:  # refused: the earlier complete result is kept, byte for byte
                    assert _complete_snapshot(out) == before, label
                    counts["data kept on error"] += 1
                counts["exit 2"] += 1
    seconds = time.perf_counter() - start
    print(f"\nfuzz: {dict(counts)} in {seconds:.1f} s")
    assert counts["cases"] >= 300 and counts["exit 0"] >= 50 and counts["exit 2"] >= 100
    assert counts["data kept on error"] >= 50
    assert counts["exit 0"] + counts["exit 2"] == counts["cases"]


# --- physically impossible accepted (issue 23) ---------------------------------------
#
# Mutations that no real pair or stage can have: an eccentricity error beyond the play
# (the pins jam the disc) or beyond e/2, a pin radius error at or below -ρp (a pin of
# no radius), a radial error beyond ρp, a groove wider than the pin pitch allows
# (ρg ≥ a·sin(π/n1)), a clearance deeper than the teeth (Δρ ≥ 2e), a negative Δρ (the
# pins overlap the disc), rollers longer than the disc, hole errors far beyond the
# bearing clearance. Each must end as a refusal (exit 2, one line naming it) or, where
# the pins jam the disc (negative play), as a run whose "jam" verdict row fails and
# whose summary.json warns; never as a result that looks fine.

IMPOSSIBLE_CASES = 36
STAGE_CHEAP = {"analysis.crank_step_deg": 30.0, "stiffness.points": 3}


def _impossible(rng: random.Random) -> tuple[str, dict[str, Any], str]:
    """(example, {dotted key: value}, what) of one impossible mutation."""
    u = rng.uniform(0.0, 1.0)
    a, e, rho = 82.0, 1.5, 3.5  # mm, table2 and measured (Table 1 of the paper)
    pitch_half_chord = a * math.sin(math.pi / 40)
    families = [
        # beyond the play (Δρ = 8 µm) but within |εe| < e/2: computed, the pins jam
        ("table2", {"errors.eccentricity_um": -(100.0 + 640.0 * u)}, "εe beyond the play"),
        ("table2", {"errors.eccentricity_um": -(1.0 + u) * e * 500.0}, "εe beyond e/2"),
        ("table2", {"modification.pin_radius_um": -(0.5 + 200.0 * u)}, "Δρ < 0"),
        ("table2", {"modification.pin_radius_um": 2 * e * 1e3 * (1.0 + 0.15 * u)}, "Δρ ≥ 2e"),
        ("table2", {"errors.pin_radius_um": -rho * 1e3 * (1.0 + u)}, "ερ ≤ -ρp"),
        ("table2", {"errors.radial_um": rng.choice([-1, 1]) * rho * 1e3 * (1 + u)}, "|εa| ≥ ρp"),
        ("table2", {"design.groove_radius_mm": pitch_half_chord * (1 + u)}, "ρg ≥ a·sin(π/n1)"),
        ("measured", {"csv.pin_radius_um": -rho * 1e3 * (1.0 + u)}, "measured ερ ≤ -ρp"),
        ("rv_stage", {"stage.crank_bearing.roller_length_mm": 10.0 * (1 + u)}, "rollers > B"),
        ("rv_stage", {"stage.hole_error_radial_um": 200.0 + 800.0 * u}, "hole error ≫ clearance"),
        ("rv_stage", {"design.groove_radius_mm": 64.0 * math.sin(math.pi / 40) * (1 + u)}, "ρg"),
    ]
    return rng.choice(families)


def _jam_warned(out: Path) -> bool:
    """A complete result whose summary.json warns of jamming and has a failing jam row."""
    summary = load_results(out).summary
    cases = summary["cases"].values() if isinstance(summary["cases"], dict) else summary["cases"]
    rows = [row for case in cases for row in case["checks"]["rows"] if row["check"] == "jam"]
    warned = any("jam" in warning for warning in summary["warnings"])
    return warned and any(row["verdict"] == "fail" for row in rows)


def test_fuzz_physically_impossible_is_refused_or_flagged(tmp_path):
    rng = random.Random(SEED + 1)
    runner = CliRunner()
    counts: Counter[str] = Counter()
    for index in range(IMPOSSIBLE_CASES):
        example, change, what = _impossible(rng)
        folder = tmp_path / f"impossible-{index}"
        folder.mkdir()
        raw = tomllib.loads((EXAMPLES / f"{example}.toml").read_text())
        cheap = STAGE_CHEAP if example == "rv_stage" else {"analysis.crank_step_deg": 30.0}
        for dotted, value in {**cheap, **change}.items():
            if dotted == "csv.pin_radius_um":  # pin 7's row of the measured file
                rows = (EXAMPLES / "measured_pins.csv").read_text().splitlines()
                k = next(i for i, r in enumerate(rows) if r.startswith("7,"))
                rows[k] = ",".join([*rows[k].split(",")[:3], f"{value:.6g}"])
                (folder / "measured_pins.csv").write_text("\n".join(rows) + "\n")
            else:
                _set(raw, dotted.split("."), value)
        study = folder / "study.toml"
        study.write_text(toml_dumps(raw), encoding="utf-8")
        commands = ["check", "run"] + (["stiffness"] if example == "rv_stage" else [])
        checked = None
        for command in commands:
            out = folder / f"out-{command}"
            args = [command, str(study)]
            if command != "check":
                args += ["--out", str(out), "-q", *EXTRA[command]]
            result = runner.invoke(app, args)
            label = f"{example} [{what}: {change}] {command}"
            counts["impossible cases"] += 1
            lines = [line for line in result.output.splitlines() if line.strip()]
            if command == "check":
                checked = result.exit_code
            if result.exit_code == 2:
                assert len(lines) == 1 and lines[0].startswith("error: "), (label, result.output)
                assert "internal error" not in lines[0], (label, lines[0])
                assert not out.exists(), label
                counts["impossible refused"] += 1
                continue
            assert result.exit_code == 0, (label, result.exit_code, result.output)
            assert checked == 0, (label, "check refused what the command accepts")
            if command == "check":
                counts["check ok (computed)"] += 1
                continue
            # accepted: only a jam may be computed, and it must be flagged
            assert _jam_warned(out), (label, "accepted as if fine")
            counts["impossible warned (jam)"] += 1
    print(f"\nfuzz, physically impossible: {dict(counts)}")
    assert counts["impossible cases"] >= 60
    assert counts["impossible refused"] >= 20 and counts["impossible warned (jam)"] >= 1

"""The README's Python example runs as written (documentation examples are tests)."""

import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")


def test_readme_python_example_runs():
    text = (Path(__file__).parents[1] / "README.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert blocks, "the README shows the Python API"
    namespace: dict = {}
    exec(compile(blocks[0], "README.md", "exec"), namespace)  # noqa: S102
    summary = namespace["summarize"](namespace["ds"])
    assert float(summary["max_contact_stress_mpa"]) > 0
    import matplotlib.pyplot as plt

    plt.close("all")

"""``python -m cyclomesh``: the ``cyclomesh`` command."""

from cyclomesh.cli import app

app(prog_name="cyclomesh")

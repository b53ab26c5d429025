"""``python -m cyclomesh`` and the ``cyclomesh`` command: :func:`main`."""

import sys


def main() -> None:
    """The ``cyclomesh`` command. A command line that draws the overview forks its figure
    process first (:func:`cyclomesh.figures.early.fork_early`), before typer, the
    command line's modules and NumPy are imported, so that the process imports NumPy
    and matplotlib while this one imports the rest."""
    from cyclomesh.figures.early import fork_early

    fork_early(sys.argv[1:])
    from cyclomesh.cli import app

    app(prog_name="cyclomesh")


if __name__ == "__main__":
    main()

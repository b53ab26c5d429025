"""``python -m cyclomesh`` and the ``cyclomesh`` command: :func:`main`."""

import sys


def main() -> None:
    """The ``cyclomesh`` command. A command line that draws the overview forks its figure
    process first (:func:`cyclomesh.figures.early.fork_early`), once NumPy is imported
    (both processes need it: imported once) and before typer and the command line's
    modules are, so that the process imports matplotlib while this one imports the
    rest. Python's cyclic garbage collector is paused while the command starts
    (:func:`cyclomesh.execution.runtime.pause_gc`). The process ends by
    :func:`end_process` once the command has finished."""
    from cyclomesh.execution.runtime import pause_gc

    pause_gc()  # resumed once the command has started (runtime.resume_gc)
    from cyclomesh.figures.early import fork_early

    fork_early(sys.argv[1:])
    from cyclomesh.cli import app

    try:
        app(prog_name="cyclomesh")
    except SystemExit as exc:
        end_process(exc.code)
        raise
    end_process(0)


def end_process(code: object) -> None:
    """End the command's process with exit status ``code`` (as :class:`SystemExit`'s),
    skipping the interpreter's teardown of its modules once everything is done.

    After the command, Python would free every module's objects and run the
    libraries' C++ destructors (pyarrow's, HDF5's): 0.05–0.07 s of a 0.45 s run,
    measured. Here the ``atexit`` functions run as at a normal exit (the early figure
    process closed, temporary folders removed, logging shut down), the standard streams
    are flushed, and the process ends with ``os._exit``. Every file of the command is
    closed by then (the writers close what they open). Where a thread other than this
    one is still alive (a Dask cluster's, a server's), or the status is not a number,
    nothing is done here and Python exits as usual.
    """
    import atexit
    import os
    import threading

    if not isinstance(code, int | None) or threading.active_count() > 1:
        return
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError, AttributeError):  # closed, or replaced by None
            pass
    os._exit(code or 0)


if __name__ == "__main__":
    main()

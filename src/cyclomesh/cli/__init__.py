"""The ``cyclomesh`` command: options in, one :func:`~cyclomesh.studies.execute.execute`
per kind of study, tables out.

``cyclomesh run STUDY.toml --out DIR`` runs the cases of a study file, ``stiffness`` the
torsion curve of every case, ``tolerance`` and ``allocate`` its ``[tolerance]`` section,
``design`` its ``[design_space]``, ``fe`` the finite-element check, ``export`` writes the
disc profile for manufacturing, ``efficiency`` maps the efficiency, ``explore`` serves
the explorer in the browser (``docs/explore.md``) and ``check`` validates every section
without running anything (``docs/study-files.md``, ``docs/pipeline.md``). The commands
of the kinds of study are built in one loop from their registry
(:data:`cyclomesh.studyfile.kinds.KINDS`: help, argument, options) and run one body,
:func:`run_kind`, with each kind's own steps
(:class:`~cyclomesh.studies.execute.CommandSteps`). Every refused input comes out
as ``error: <one line>`` on stderr with exit status 2 (:mod:`cyclomesh.cli.errors`);
options and the progress display are in :mod:`cyclomesh.cli.options`, the tables in
:mod:`cyclomesh.publish.console`. Heavy modules are imported inside the commands, so
``--help`` is fast.
"""

from __future__ import annotations

import inspect
from typing import Annotated, Any

import typer

from cyclomesh.cli.errors import EXIT_INPUT_ERROR, OneLineUsage, cli_errors, fail
from cyclomesh.cli.options import (
    ARGUMENTS,
    OPTIONS,
    KindOption,
    NoLimitOption,
    OutOption,
    StepOption,
    StudyArg,
    bar,
    output_options,
    overrides,
    progress_bar,
    run_backend,
    say,
    show_version,
    stderr_console,
    use_cache_dir,
)
from cyclomesh.exceptions import StudyError
from cyclomesh.explore.options import NoBrowserOption, PortOption
from cyclomesh.figures.early import early_figures
from cyclomesh.studies.preflight import preflight
from cyclomesh.studyfile.kinds import KINDS, KindSpec

__all__ = [
    "app",
    "cli_errors",
    "fail",
    "stderr_console",
    "progress_bar",
    "output_options",
    "EXIT_INPUT_ERROR",
]

app = typer.Typer(
    name="cyclomesh",
    cls=OneLineUsage,
    help="Loaded tooth contact analysis of cycloid-pin gear pairs (RV reducers).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_show_locals=False,
    rich_markup_mode=None,  # keep "[deg]" and "[tolerance]" in help texts as typed
)


@app.callback()
def main(
    ctx: typer.Context,
    version: Annotated[
        bool,
        typer.Option("--version", callback=show_version, is_eager=True, help="Show the version."),
    ] = False,
) -> None:
    """Loaded tooth contact analysis of cycloid-pin gear pairs (Li et al., Machines 2022)."""
    from cyclomesh.execution.runtime import (
        resume_gc,
        skip_pydantic_plugins,
        tune_allocator,
        tune_blas,
    )

    tune_blas()
    tune_allocator()
    skip_pydantic_plugins()
    if ctx.invoked_subcommand not in _KIND_COMMANDS:  # a kind's command resumes it itself
        resume_gc()


@app.command()
@cli_errors()
def check(
    study: StudyArg,
    crank_step_deg: StepOption = None,
    no_work_limit: NoLimitOption = False,
    kind: KindOption = None,
) -> None:
    """Validate a study file (every section) without running it, and refuse what the
    commands would refuse before computing: with --kind that command's refusals, else
    those of every command the file is written for (run, and stiffness, tolerance,
    allocate, design, fe or efficiency when it has their section)."""
    from cyclomesh.studies.preflight import check_kinds
    from cyclomesh.studyfile import load_study
    from cyclomesh.studyfile.kinds import check_study_work

    loaded = load_study(study, overrides(crank_step_deg))
    check_study_work(loaded, "check", allow=no_work_limit)
    if any(case.analysis.disc_body == "fe" for case in loaded.cases):
        from cyclomesh.results.dataset import FE_EXTRA_MESSAGE, fe_extra_available

        if not fe_extra_available():
            raise StudyError(f"{study}: [analysis] {FE_EXTRA_MESSAGE}")
    kinds = check_kinds(loaded, kind, allow_work=no_work_limit)
    names = ", ".join(case.name for case in loaded.cases)
    more = "; [tolerance] OK" if loaded.tolerance is not None else ""
    if any(case.stiffness is not None for case in loaded.cases):
        more += "; [stiffness] OK"
    if loaded.file.design_space is not None:
        more += "; [design_space] OK"
    if loaded.file.fe is not None:
        more += "; [fe] OK"
    if any(inputs.friction is not None for inputs in loaded.inputs):
        more += "; [friction] OK"
    if loaded.file.efficiency is not None:
        more += "; [efficiency] OK"
    if loaded.file.requirements != type(loaded.file.requirements)():
        more += "; [requirements] OK"
    typer.echo(f"{study}: {len(loaded.cases)} case(s) OK: {names}{more}; for {', '.join(kinds)}")


def run_kind(command: str, options: dict[str, Any]) -> None:
    """The body of every kind's command: the steps every command takes, in order, and
    the kind's own (:class:`~cyclomesh.studies.execute.CommandSteps`) between them."""
    if "cache_dir" in options:
        use_cache_dir(options["cache_dir"])
    with early_figures(command, options.get("figures")) as figures:
        _run_kind(command, options, figures)


def _run_kind(command: str, options: dict[str, Any], figures: Any) -> None:
    from cyclomesh.execution.runtime import resume_gc
    from cyclomesh.studies.execute import execute, load_kind
    from cyclomesh.studyfile.kinds import check_study_work

    kind = load_kind(command)
    steps = kind.steps
    quiet = options["quiet"]
    compute = dict(steps.before(options)) if steps.before else {}
    if steps.load is not None:
        loaded = steps.load(options["study"], options)
    else:
        from cyclomesh.studyfile import load_study

        loaded = load_study(options["study"], overrides(options.get("crank_step_deg")))
    if "no_work_limit" in options:
        rings = options.get("rings")
        check_study_work(loaded, command, rings=rings, allow=options["no_work_limit"])
    preflight(loaded, command, work=False)  # what check --kind <command> refuses
    if steps.check is not None:
        steps.check(loaded, options)
    resume_gc()  # the command has started: before its workers are forked and it computes
    run: dict[str, Any] = {}
    backend = None
    if steps.parallel is not None:
        backend = run_backend(
            options["scheduler"], options["workers"], steps.parallel(loaded, options)
        )
        run.update(backend=backend, parallel=True)
    if steps.output is not None:
        output = steps.output(loaded, options)
    else:
        output = output_options(loaded, options.get("figures"), options.get("csv", False))
    if steps.banner is not None:
        say(steps.banner(loaded, options, backend.workers if backend else 1), quiet)
    if steps.progress is not None:
        run["progress"] = bar(*steps.progress(loaded, options), quiet)
    if steps.log:
        compute["log"] = stderr_console(quiet).print
    if steps.compute is not None:
        compute.update(steps.compute(loaded, options, backend))
    if figures is not None:
        run["figure_process"] = figures
    result = execute(kind, loaded, options["out"], output, **run, **compute)
    if not quiet and steps.show is not None:
        steps.show(result, options["out"], options)


class KindCommand:
    """``cyclomesh <spec.command>`` as typer reads it: the registry entry's argument and
    options as the signature, its help as the doc, and :func:`run_kind` as the body."""

    def __init__(self, spec: KindSpec) -> None:
        plain = inspect.Parameter.POSITIONAL_OR_KEYWORD
        params = [
            inspect.Parameter("study", plain, annotation=ARGUMENTS[spec.argument]),
            inspect.Parameter("out", plain, annotation=OutOption),
        ]
        for name in spec.options:
            annotation, default = OPTIONS[name]
            params.append(inspect.Parameter(name, plain, annotation=annotation, default=default))
        self.command = spec.command
        self.__signature__ = inspect.Signature(params, return_annotation=None)
        self.__doc__ = spec.help
        self.__name__ = self.__qualname__ = spec.command

    def __call__(self, **options: Any) -> None:
        run_kind(self.command, options)


_KIND_COMMANDS = frozenset(spec.command for spec in KINDS)
"""The commands :func:`run_kind` runs (they resume the collector once started)."""

for _spec in KINDS:  # one command per kind of study, in the registry's order
    app.command(name=_spec.command)(cli_errors()(KindCommand(_spec)))


@app.command()
@cli_errors()
def explore(study: StudyArg, port: PortOption = 8050, no_browser: NoBrowserOption = False) -> None:
    """Explore a study in the browser: change the modification, load or pin errors and see
    loads, stresses and TE at once (needs the explore extra; docs/explore.md)."""
    from cyclomesh.explore.app import serve

    serve(study, port=port, open_browser=not no_browser, echo=typer.echo)

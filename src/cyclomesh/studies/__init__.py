"""Kinds of study, one module each, all on one pipeline (see ``docs/pipeline.md``).

- :mod:`cyclomesh.studies.run`: the cases of a study file, each through a crank
  revolution (``cyclomesh run``);
- :mod:`cyclomesh.studies.tolerance`: Monte Carlo tolerance studies (``cyclomesh
  tolerance``), :mod:`cyclomesh.studies.allocate`: tolerance allocation (``cyclomesh
  allocate``), both on the rings of :mod:`cyclomesh.studies.rings`;
- :mod:`cyclomesh.studies.designmap`: design maps over the modification space, nominal or
  robust over rings (``cyclomesh design``).

Every kind has the same parts: a section of the study file schema
(:mod:`cyclomesh.studyfile.schema`), a compute function that returns results in memory
(parallel work through :mod:`cyclomesh.execution.backends`), a writer of its result files
(:mod:`cyclomesh.output.writers`), figure jobs (:mod:`cyclomesh.figures`) and report
sections (:mod:`cyclomesh.publish.report`); :mod:`cyclomesh.publish.pipeline` renders the
figures and writes the report. Each kind's ``StudyKind`` (:mod:`cyclomesh.studies.execute`)
is named by its entry in the one registry, :data:`cyclomesh.studyfile.kinds.KINDS`, from
which the key usage, the work limits and the command line are built.
"""

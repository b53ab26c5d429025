"""Monte Carlo tolerance numerics of the pin ring (issue 4).

``sampling`` draws reproducible per-ring errors; ``tasks`` turns rings into metrics
through the core (chunk functions for :mod:`cyclomesh.execution.backends`); ``statistics`` and
``allocation`` reduce them. The ``[tolerance]`` section is part of the one study file
schema (:class:`cyclomesh.studyfile.schema.ToleranceSection`); the study itself (files,
figures, report) is :mod:`cyclomesh.studies.tolerance` and
:mod:`cyclomesh.studies.allocate`.
"""

from cyclomesh.tolerance.sampling import RingErrors, ToleranceSpec, draw_ring_errors

__all__ = ["RingErrors", "ToleranceSpec", "draw_ring_errors"]

"""Monte Carlo tolerance studies of the pin ring (issue 4).

``spec`` validates the ``[tolerance]`` section of a study file; ``sampling`` draws
reproducible per-ring errors; ``engine`` runs chunks of rings serially, on local cores
or on a Dask cluster; ``tasks`` turns rings into metrics through the core;
``statistics`` and ``allocation`` reduce them; ``output``, ``figures`` and ``runner``
write the files; ``commands`` holds the ``cyclomesh tolerance`` and ``cyclomesh
allocate`` commands. Nothing here imports ``distributed`` until a scheduler is used.
"""

from cyclomesh.tolerance.sampling import RingErrors, draw_ring_errors
from cyclomesh.tolerance.spec import ToleranceSpec, parse_tolerance

__all__ = ["RingErrors", "ToleranceSpec", "draw_ring_errors", "parse_tolerance"]

"""A cheap chunk function for the tolerance engine tests (importable by worker processes)."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

import numpy as np

from cyclomesh.studyfile.schema import ToleranceSection
from cyclomesh.tolerance.sampling import draw_ring_errors


@dataclass(frozen=True)
class DummyTask:
    """Per-ring 'metrics' computed from the sampled errors only."""

    spec: ToleranceSection
    pins: int = 40
    sleep_s: float = 0.0

    def __call__(self, start: int, stop: int) -> dict[str, np.ndarray]:
        errors = draw_ring_errors(self.spec, self.pins, 82e-3, range(start, stop))
        if self.sleep_s:
            time.sleep(self.sleep_s)
        radial_um = errors.radial_um
        return {
            "ring": errors.rings,
            "max_contact_stress_mpa": 1000.0 + 25.0 * np.abs(radial_um).max(axis=1),
            "radial_um": radial_um,
            "pid": np.full(stop - start, os.getpid()),
        }

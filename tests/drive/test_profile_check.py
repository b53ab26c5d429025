"""core.case's check of the profile once per passing (design, modification) pair."""

import dataclasses

import numpy as np
import pytest

import cyclomesh.core.case as case_module
from cyclomesh import TABLE1, DesignError, Modification
from cyclomesh.core.pair import PinErrors


def test_a_passing_pair_is_checked_once_and_a_failing_one_every_time(monkeypatch):
    """check_pair runs check_profile once for an equal (design, modification) that passes
    (an equal copy included), again for another pair, and every time for one that fails
    (it raises each time, nothing is kept)."""
    calls = []
    real = case_module.check_profile

    def counted(design, modification):
        calls.append((design, modification))
        real(design, modification)

    monkeypatch.setattr(case_module, "check_profile", counted)
    case_module._profile_passed.cache_clear()
    mod = Modification(pin_radius=3e-6)
    for _ in range(3):
        assert case_module.check_pair(TABLE1, mod, PinErrors()) == ()
    case_module.check_pair(dataclasses.replace(TABLE1), Modification(pin_radius=3e-6), PinErrors())
    assert len(calls) == 1
    case_module.check_pair(TABLE1, Modification(pin_radius=4e-6), PinErrors())
    assert len(calls) == 2
    errors = PinErrors(radial=np.zeros(TABLE1.pins))  # errors do not enter the profile
    assert case_module.check_pair(TABLE1, mod, errors) == ()
    assert len(calls) == 2
    undercut = dataclasses.replace(
        TABLE1, eccentricity=1.9e-3, pin_radius=4.5e-3, groove_radius=4.6e-3
    )
    for k in range(2):
        with pytest.raises(DesignError, match="undercut"):
            case_module.check_pair(undercut, Modification(), PinErrors())
        assert len(calls) == 3 + k


def test_the_kept_pairs_are_bounded():
    """At most _PROFILES_KEPT pairs are kept (the least recently used goes first)."""
    case_module._profile_passed.cache_clear()
    for k in range(case_module._PROFILES_KEPT + 5):
        case_module.check_pair(TABLE1, Modification(pin_radius=1e-7 * k), PinErrors())
        info = case_module._profile_passed.cache_info()
        assert info.currsize <= case_module._PROFILES_KEPT
    assert info.currsize == case_module._PROFILES_KEPT
    case_module._profile_passed.cache_clear()

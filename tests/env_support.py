"""Helpers shared by the environment's tests."""

from __future__ import annotations

import warnings

from gymnasium.utils.env_checker import check_env


def quiet_check(env) -> None:
    """check_env, failing on any warning it raises as well as on its assertions."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env)
    complaints = [str(w.message) for w in caught if issubclass(w.category, UserWarning)]
    assert not complaints, complaints

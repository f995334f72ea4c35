"""The paper's action cost lives in the core (:mod:`phyrogen_core.actions`), since puzzle files
record it too; the solver's modules import it from here."""

from phyrogen_core.actions import (  # noqa: F401 (re-exported)
    MOVE_TOLERANCE,
    Action,
    Factors,
    action_labels,
    action_sequence,
    count_actions,
    factor_membership,
    moved_factors,
    split_actions,
)

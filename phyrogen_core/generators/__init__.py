"""The six generators of the paper's Table I, registered by name on import."""

from . import (  # noqa: F401
    continuous_space,
    grid_world,
    lockbox_random,
    move_n_times,
    rooms,
    simple_slider,
)

PAPER_GENERATORS = (
    "simple_slider",
    "continuous_space",
    "grid_world",
    "lockbox_random",
    "move_n_times",
    "rooms",
)

"""The six generators of the paper's Table I, registered by name when this package is imported.

Import the registry (:mod:`phyrogen_core.registry`), not this package: it loads
the generators the first time it is asked. :mod:`.kit` holds what the
generators share.
"""

from . import (  # noqa: F401  (each module registers its generator)
    continuous_space,
    grid_world,
    lockbox_random,
    move_n_times,
    rooms,
    simple_slider,
)

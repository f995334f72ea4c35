"""The six generators of the paper's Table I, one module each; :mod:`.kit` holds what they share.

Nothing is imported here: each generator is declared in the ``phyrogen.generators`` entry points of
``pyproject.toml``, as a generator from another package is, and the registry
(:mod:`phyrogen_core.registry`) loads them the first time it is asked. Ask the registry, not this package.
"""

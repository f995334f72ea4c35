"""Imported once by the generation server process (see :mod:`solver.generation`).

It compiles the collision kernels there, so every worker forked from the
server starts with them loaded instead of paying about 0.2 s each.
"""

from .collision import warm_up

warm_up()

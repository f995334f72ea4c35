"""Imported once by the generation server process (see :mod:`solver.pipelines.generation`).

It compiles the collision kernels and the judge's loop there (or loads them from numba's cache), so
every worker forked from the server starts with them loaded instead of paying about 0.2 s each.
"""

from solver.collision.model import warm_up
from solver.validation.judge import warm_up as warm_up_judge

warm_up()
warm_up_judge()

"""Imported once by the generation server process (see :mod:`solver.generation`).

It compiles the collision kernels and the judge's loop there (or loads them from numba's cache), so
every worker forked from the server starts with them loaded instead of paying about 0.2 s each.
"""

from .collision import warm_up
from .judge import warm_up as warm_up_judge

warm_up()
warm_up_judge()

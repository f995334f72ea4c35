"""Imported once by the generation server process (see :mod:`solver.pipelines.generation`).

It compiles the collision kernels, the judge's loop and the necessity proof's test there (or loads them
from numba's cache), so every worker forked from the server starts with them loaded instead of paying
about 0.2 s each. Then it moves everything imported so far out of the garbage collector's reach
(``gc.freeze``): a worker's first collections would otherwise visit, and so copy, every page of the
server's objects that it shares; a fresh dataset worker cost about 0.11 CPU s before its first puzzle,
0.05 with the freeze (2-core machine).
"""

from solver.collision.model import warm_up
from solver.validation.blocking import warm_up as warm_up_proof
from solver.validation.judge import warm_up as warm_up_judge

warm_up()
warm_up_judge()
warm_up_proof()

import gc  # noqa: E402

gc.freeze()

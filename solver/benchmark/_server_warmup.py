"""Imported once by the benchmark's server process (see :data:`solver.benchmark.jobs._PRELOAD`).

Every run is a fresh process forked from that server. Loading the compiled collision kernels from
numba's cache costs each such process most of a second of CPU before its clock starts (more than a
quick run's planning on a small puzzle); loaded once here, every run inherits them.
"""

import numpy as np

from solver.collision.kernels import nearest_l1
from solver.collision.model import warm_up

warm_up()
nearest_l1(np.zeros((2, 2)), 2, np.zeros(2), np.ones(2))  # LA-RRT's nearest neighbour

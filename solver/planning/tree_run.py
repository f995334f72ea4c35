"""What every run of our own tree planners (LA-RRT, LBT-RRT) is set up with."""

from __future__ import annotations

from typing import Any

import numpy as np

from solver.planning.anytime import planning_steps
from solver.planning.problem import Problem


class TreeRun:
    """One run's problem, settings (with a ``resolution`` in metres), random generator and goal source,
    the problem's collision model, and the joint steps between checked states at that resolution."""

    def __init__(self, problem: Problem, rng: np.random.Generator, settings: Any, goals: Any):
        self.problem = problem
        self.settings = settings
        self.rng = rng
        self.goals = goals
        self.model = problem.model
        self.steps = planning_steps(problem, settings.resolution)

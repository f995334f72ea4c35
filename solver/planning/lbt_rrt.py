"""LBT-RRT, the lower-bound tree RRT (Salzman & Halperin, arXiv 1308.0189), on our collision model.

The ``ompl`` wheel does not expose OMPL's ``LBTRRT`` to Python, so this is an
implementation of the same algorithm (after OMPL's ``LBTRRT``). One vertex
set carries two structures:

- the approximation tree: an RRT whose every edge has been collision-checked;
- the lower-bound graph: every k-nearest edge, *not* checked, with the
  shortest-path tree from the start kept up to date as edges come and go.

Invariant: approximation cost <= (1 + epsilon) x lower-bound cost at every
vertex. When an inserted edge lowers lower-bound costs so that a vertex
breaks it, the vertex's lower-bound parent edge is checked: if free, the
vertex is re-parented in the approximation tree; if not, the edge leaves the
lower-bound graph and the affected costs are recomputed. Asymptotically
near-optimal: epsilon 0 behaves like RRT*, a large epsilon like RRT.

Edge cost is the same additive bound on the action cost as for RRT* and BIT*
(:class:`solver.planning.ompl_planners.ObjectsMovedObjective`): the number of objects
an edge moves. Distances (nearest neighbours, steering) are Euclidean in
joint space, as in OMPL. The goal bias steers toward the run's shared valid
goal states (:mod:`solver.planning.goal_sampling`), as RRT*'s does; a run may stop at
its first solution that holds at fine resolution (``until_first``).
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np

from phyrogen_core.actions import factor_membership
from solver.planning.anytime import (
    PLANNING_RESOLUTION,
    AnytimeRecorder,
    Offer,
    PlanResult,
    count_checks,
)
from solver.planning.goal_sampling import GoalSampler, default_goal_seed
from solver.planning.problem import Problem, in_goal, problem_factors
from solver.planning.tree_run import TreeRun


@dataclass(frozen=True)
class LbtRrtSettings:
    """OMPL's defaults for LBTRRT."""

    epsilon: float = 0.4
    range_fraction: float = 0.2
    """Steering range as a fraction of the space's largest (Euclidean) extent."""
    goal_bias: float = 0.05
    resolution: float = PLANNING_RESOLUTION

    def __post_init__(self) -> None:
        if self.epsilon < 0:
            raise ValueError(f"epsilon must be >= 0, got {self.epsilon!r}")
        if not 0 < self.range_fraction <= 1:
            raise ValueError(f"range_fraction must be in (0, 1], got {self.range_fraction!r}")
        if not 0 <= self.goal_bias <= 1:
            raise ValueError(f"goal_bias must be in [0, 1], got {self.goal_bias!r}")


class LbtRrt(TreeRun):
    """One LBT-RRT run on ``problem``."""

    def __init__(self, problem: Problem, rng: np.random.Generator, settings: LbtRrtSettings | None = None,
                 goals: GoalSampler | None = None):
        # The benchmark passes the run's shared sampler; on its own, one seeded from ``rng``.
        goals = goals if goals is not None else GoalSampler(problem, int(rng.integers(1, 2**31 - 1)))
        super().__init__(problem, rng, settings or LbtRrtSettings(), goals)
        dimension = len(problem.start)
        self.membership = factor_membership(problem_factors(problem), dimension)
        self.range = self.settings.range_fraction * float(np.linalg.norm(problem.upper - problem.lower))
        self.k_rrg = math.e * (1.0 + 1.0 / dimension)
        self._restart()
        self.iterations = 0

    def _restart(self) -> None:
        """A tree of the start alone (a new run, or a restart after a clipped first path)."""
        self.states = np.empty((1024, len(self.problem.start)))
        self.size = 0
        self.parent_apx: list[int] = []
        self.cost_apx: list[float] = []
        self.children_apx: list[set[int]] = []
        self.edges: list[dict[int, float]] = []  # lower-bound graph, undirected
        self.parent_lb: list[int] = []
        self.cost_lb: list[float] = []
        self.children_lb: list[set[int]] = []
        self.goal_nodes: list[int] = []
        root = self._add(self.problem.start)
        self.cost_apx[root] = self.cost_lb[root] = 0.0

    # -- helpers -----------------------------------------------------------
    def _cost(self, a: int, b: int) -> float:
        moved = np.abs(self.states[b] - self.states[a]) > 1e-6
        return float(np.count_nonzero(moved @ self.membership))

    def _add(self, state: np.ndarray) -> int:
        if self.size == len(self.states):
            self.states = np.concatenate([self.states, np.empty_like(self.states)])
        self.states[self.size] = state
        self.size += 1
        for table in (self.children_apx, self.children_lb):
            table.append(set())
        self.edges.append({})
        self.parent_apx.append(-1)
        self.parent_lb.append(-1)
        self.cost_apx.append(math.inf)
        self.cost_lb.append(math.inf)
        return self.size - 1

    def _sample(self) -> np.ndarray:
        """A shared valid goal state with probability ``goal_bias``, else a uniform state."""
        p = self.problem
        if self.rng.random() < self.settings.goal_bias:
            goal = self.goals.sample(self.rng)
            if goal is not None:
                return goal
        return p.lower + (p.upper - p.lower) * self.rng.random(len(p.start))

    def _set_apx_parent(self, node: int, parent: int, cost: float) -> None:
        old = self.parent_apx[node]
        if old >= 0:
            self.children_apx[old].discard(node)
        self.parent_apx[node] = parent
        self.children_apx[parent].add(node)
        delta = self.cost_apx[parent] + cost - self.cost_apx[node]
        stack = [node]
        while stack:
            n = stack.pop()
            self.cost_apx[n] += delta
            stack.extend(self.children_apx[n])

    def _set_lb_parent(self, node: int, parent: int) -> None:
        old = self.parent_lb[node]
        if old >= 0:
            self.children_lb[old].discard(node)
        self.parent_lb[node] = parent
        if parent >= 0:
            self.children_lb[parent].add(node)

    # -- lower-bound graph -------------------------------------------------
    def _lower(self, seeds: list[int]) -> list[int]:
        """Dijkstra from vertices whose lower-bound cost just dropped; returns every vertex it lowered."""
        heap = [(self.cost_lb[s], s) for s in seeds]
        heapq.heapify(heap)
        affected = list(seeds)
        while heap:
            cost, u = heapq.heappop(heap)
            if cost > self.cost_lb[u]:
                continue
            for v, c in self.edges[u].items():
                if cost + c < self.cost_lb[v] - 1e-12:
                    self.cost_lb[v] = cost + c
                    self._set_lb_parent(v, u)
                    affected.append(v)
                    heapq.heappush(heap, (cost + c, v))
        return affected

    def _add_edge(self, u: int, v: int, c: float) -> list[int]:
        self.edges[u][v] = c
        self.edges[v][u] = c
        seeds = []
        for a, b in ((u, v), (v, u)):
            if self.cost_lb[a] + c < self.cost_lb[b] - 1e-12:
                self.cost_lb[b] = self.cost_lb[a] + c
                self._set_lb_parent(b, a)
                seeds.append(b)
        return self._lower(seeds) if seeds else []

    def _remove_edge(self, u: int, v: int) -> list[int]:
        """Remove u-v (u is v's lower-bound parent) and recompute the costs it supported."""
        del self.edges[u][v]
        del self.edges[v][u]
        subtree, stack = [], [v]
        while stack:
            n = stack.pop()
            subtree.append(n)
            stack.extend(self.children_lb[n])
        inside = set(subtree)
        for n in subtree:
            self.cost_lb[n] = math.inf
            self._set_lb_parent(n, -1)
        seeds = []
        for n in subtree:
            for w, c in self.edges[n].items():
                if w not in inside and self.cost_lb[w] + c < self.cost_lb[n]:
                    self.cost_lb[n] = self.cost_lb[w] + c
                    self._set_lb_parent(n, w)
            if math.isfinite(self.cost_lb[n]):
                seeds.append(n)
        self._lower(seeds)
        return subtree

    def _violated(self, n: int) -> bool:
        return self.cost_apx[n] > (1.0 + self.settings.epsilon) * self.cost_lb[n] + 1e-9

    def _consider_edge(self, u: int, v: int) -> None:
        if v in self.edges[u]:
            return
        affected = self._add_edge(u, v, self._cost(u, v))
        queue = [(self.cost_lb[n], n) for n in set(affected) if self._violated(n)]
        heapq.heapify(queue)
        while queue:
            _, m = heapq.heappop(queue)
            if not self._violated(m):
                continue
            p = self.parent_lb[m]
            if p < 0:
                continue
            c = self.edges[p][m]
            if self.cost_apx[p] + c >= self.cost_apx[m]:
                continue  # p is not settled yet (or would form a cycle); it is handled first by cost order
            if self.model.check_motion(self.states[p], self.states[m], self.steps):
                self._set_apx_parent(m, p, c)
            else:
                changed = self._remove_edge(p, m)
                for n in changed:
                    if self._violated(n):
                        heapq.heappush(queue, (self.cost_lb[n], n))

    # -- main loop ---------------------------------------------------------
    def _best_goal(self) -> int:
        return min(self.goal_nodes, key=lambda n: self.cost_apx[n], default=-1)

    def _branch(self, node: int) -> list[np.ndarray]:
        out = []
        while node >= 0:
            out.append(self.states[node].copy())
            node = self.parent_apx[node]
        return out[::-1]

    def solve(self, recorder: AnytimeRecorder, until_first: bool = False) -> PlanResult:
        """Grow until ``recorder`` expires, or until the first solution that holds at fine
        resolution when ``until_first``."""
        problem = self.problem
        if not self.model.is_valid(problem.start):
            return recorder.result(0, "Invalid start")
        if in_goal(problem, problem.start):
            recorder.offer([problem.start])
        offered = math.inf
        while not recorder.expired():
            self.iterations += 1
            recorder.sample(self.iterations)
            sample = self._sample()
            distances = np.linalg.norm(self.states[: self.size] - sample, axis=1)
            near = int(np.argmin(distances))
            if distances[near] > self.range:
                sample = self.states[near] + (sample - self.states[near]) * (self.range / distances[near])
            if distances[near] < 1e-9 or not self.model.check_motion(self.states[near], sample, self.steps):
                continue
            new = self._add(sample)
            c = self._cost(near, new)
            self.cost_apx[new] = self.cost_apx[near] + c
            self.parent_apx[new] = near
            self.children_apx[near].add(new)
            self.edges[near][new] = self.edges[new][near] = c
            self.cost_lb[new] = self.cost_lb[near] + c
            self._set_lb_parent(new, near)
            k = min(self.size - 1, int(math.ceil(self.k_rrg * math.log(self.size + 1))))
            d = np.linalg.norm(self.states[: self.size - 1] - sample, axis=1)
            neighbours = np.argpartition(d, k - 1)[:k] if k < len(d) else np.arange(len(d))
            for n in neighbours.tolist():
                if n != near:
                    self._consider_edge(n, new)
            for n in neighbours.tolist():
                if n != near:
                    self._consider_edge(new, n)
            if in_goal(problem, sample):
                self.goal_nodes.append(new)
            best = self._best_goal()
            if best < 0 or self.cost_apx[best] >= offered:
                continue
            offered = self.cost_apx[best]
            offer = recorder.offer_checked(self._branch(best))
            if offer is Offer.BEST and until_first:
                break
            if offer is Offer.CLIPPED:
                # It clips a corner at fine resolution, and so would every later branch through
                # the clipping edge: start a fresh tree, as the OMPL planners do
                # (:func:`solver.planning.ompl_planners.run_ompl`).
                self._restart()
                offered = math.inf
        return recorder.result(self.iterations)


def plan_lbt_rrt(problem: Problem, time_limit: float, seed: int, progress_interval: float = 0.1,
                 settings: LbtRrtSettings | None = None, *, until_first: bool = False,
                 goal_seed: int | None = None, budget_checks: int | None = None,
                 budget_cpu: float | None = None) -> PlanResult:
    """Run LBT-RRT for ``time_limit`` seconds, or ``budget_checks`` collision checks (motions charged
    by their length) or ``budget_cpu`` CPU seconds with the time limit as a backstop (or until its
    first solution); its own draws from ``seed``, goal states from the shared sampler seeded with
    ``goal_seed`` (default: from ``seed``)."""
    problem = count_checks(problem, by_length=True)
    goals = GoalSampler(problem, default_goal_seed(seed) if goal_seed is None else goal_seed)
    planner = LbtRrt(problem, np.random.default_rng(seed), settings, goals)
    recorder = AnytimeRecorder("LBT-RRT", problem, time_limit, progress_interval, budget_checks, budget_cpu)
    return planner.solve(recorder, until_first)

"""LA-RRT's settings (:class:`LaRrtSettings`) and the four entries' values of them: ours with pushes
(the defaults), the paper's, and the paper's two ablations; :mod:`solver.planning.la_rrt` says what
each changes over the original implementation."""

from __future__ import annotations

from dataclasses import dataclass, replace

from solver.planning.anytime import PLANNING_RESOLUTION

EXTENSIONS = ("staircase", "isolate")
GOAL_ROOT_RULES = ("probability", "half_tree")
FACTOR_ORDERS = ("random", "fixed")


@dataclass(frozen=True)
class LaRrtSettings:
    """Tuning of LA-RRT; the defaults were chosen on the paper's 24 puzzles."""

    range_fraction: float = 0.1
    """Extension budget as a fraction of the weighted L1 extent of the space."""
    goal_root_probability: float = 0.05
    """Chance per iteration of adding one more goal state as a root of the goal tree."""
    goal_sample_attempts: int = 50
    """Goal-region candidates per batch (uniform ones, then as many projected from the start tree)
    tried for a new goal root before giving up for this iteration."""
    resolution: float = PLANNING_RESOLUTION
    """Metres any collision point may move between two checked states while planning."""
    single_factor_probability: float = 0.5
    """Chance that an extension moves one random factor only, instead of walking the whole staircase."""
    limit_probability: float = 0.1
    """Chance per joint that a sample puts it at one of its limits instead of a uniform value."""
    max_pushes: int = 2
    """Most blocking objects one extension may push aside (0: plain staircases)."""
    push_attempts: int = 3
    """Candidate values tried for a pushed object."""
    defragment_share: float = 0.5
    """Largest share of the run time spent defragmenting; connections found while
    over it are dropped undefragmented (the first one is always defragmented)."""
    extension: str = "staircase"
    """How a tree grows toward a state. "staircase": the factors move one after another in a
    random order, whole moves first, within the range (``single_factor_probability``: one factor
    only), the valid prefix of a blocked staircase kept, a connection in one staircase.
    "isolate", the original's: the whole state steps toward the target by at most the range, then
    the factors that changed move one after another in a random order, all or nothing; a
    connection repeats such steps until it reaches the target or is blocked (RRT-Connect)."""
    weighted_metric: bool = True
    """Distances (nearest neighbours, the range) in metres of motion, each joint weighted by how
    far a unit of it moves any collision point; False: plain L1 over joint values (a radian
    counts as a metre), the original's."""
    goal_root_rule: str = "probability"
    """When a goal root is added (always while the goal tree is empty). "probability":
    ``goal_root_probability`` per iteration; "half_tree", the original's (OMPL RRT-Connect's):
    whenever fewer goal states were drawn than half the goal tree's nodes."""
    factor_order: str = "random"
    """The order in which the factors of a step (isolated or staircase) move. "random": drawn afresh
    at every step; "fixed", the original's: the problem's factor order (the target first), which
    stalls wherever the first factor is blocked (the ablation ``la_rrt_fixed_order``)."""
    check_isolated_segment: bool = False
    """An isolated step first checks the straight multi-factor segment it replaces by its staircase
    and is trapped when that segment collides, as the original did (the segment is never added to
    the tree; the ablation ``la_rrt_segment_check``). False: only the staircase is checked."""

    def __post_init__(self) -> None:
        if not 0 < self.range_fraction <= 1:
            raise ValueError(f"range_fraction must be in (0, 1], got {self.range_fraction!r}")
        if not 0 <= self.goal_root_probability <= 1:
            raise ValueError(f"goal_root_probability must be in [0, 1], got {self.goal_root_probability!r}")
        if self.goal_sample_attempts < 1:
            raise ValueError(f"goal_sample_attempts must be at least 1, got {self.goal_sample_attempts!r}")
        if not self.resolution > 0:
            raise ValueError(f"resolution must be positive metres, got {self.resolution!r}")
        if not 0 <= self.single_factor_probability <= 1:
            raise ValueError(f"single_factor_probability must be in [0, 1], got {self.single_factor_probability!r}")
        if not 0 <= self.limit_probability <= 1:
            raise ValueError(f"limit_probability must be in [0, 1], got {self.limit_probability!r}")
        if self.max_pushes < 0:
            raise ValueError(f"max_pushes must be at least 0, got {self.max_pushes!r}")
        if self.push_attempts < 1:
            raise ValueError(f"push_attempts must be at least 1, got {self.push_attempts!r}")
        if not 0 < self.defragment_share <= 1:
            raise ValueError(f"defragment_share must be in (0, 1], got {self.defragment_share!r}")
        if self.extension not in EXTENSIONS:
            raise ValueError(f"extension must be one of {EXTENSIONS}, got {self.extension!r}")
        if self.goal_root_rule not in GOAL_ROOT_RULES:
            raise ValueError(f"goal_root_rule must be one of {GOAL_ROOT_RULES}, got {self.goal_root_rule!r}")
        if self.factor_order not in FACTOR_ORDERS:
            raise ValueError(f"factor_order must be one of {FACTOR_ORDERS}, got {self.factor_order!r}")


PUSH_SETTINGS = LaRrtSettings()
"""LA-RRT+push (ours): the defaults, chosen on the paper's 24 puzzles (see :mod:`solver.planning.la_rrt`)."""

PAPER_SETTINGS = LaRrtSettings(
    range_fraction=0.2,  # OMPL's SelfConfig default range, 0.2 of the space's (L1) extent
    single_factor_probability=0.0,
    limit_probability=0.0,  # uniform samples
    max_pushes=0,
    defragment_share=1.0,  # every connection is defragmented
    extension="isolate",
    weighted_metric=False,
    goal_root_rule="half_tree",
)
"""LA-RRT as the paper (Bayraktar et al., RA-L 2023) and the authors' code (``serboba/robowflex``,
``LARRT.cpp``) define it: RRT-Connect in the factored space, every extension isolated into one
move per factor, the path defragmented at every connection, anytime. Kept from our
implementation because they fix bugs of the original, not because they help it:

- the factors of an isolated step move in a fresh random order (the original's fixed order
  stalls whenever the first factor is blocked; the authors' 2025 port shuffles it too);
- a step is at most the range long and ends at the sample when that is within the range: the
  original passed the range where OMPL's ``interpolate`` expects the fraction of the way, so a
  step went that multiple of the way (past the sample, out of the joint limits, when the range
  exceeds 1) or that fraction of it, and a step reported as reaching the sample could end short
  of it (a connection then joined two different states, unchecked);
- the straight multi-factor segment an isolated step replaces is not checked (the original
  checked it and its staircase, and the segment is never added to the tree);
- a factor that changes by less than 1e-4 still moves (the original left it behind, so a
  connection could join two states that differ, unchecked);
- defragmentation collapses an action to one segment only when that segment is valid.

Goal roots come from the shared goal sampler, in the original's rule; the original drew uniform
goal states from OMPL's goal region instead (almost never valid on a lockbox).

Two of these are behaviour changes, not only bug fixes, and each has an ablation that switches it
back to the original (:data:`FIXED_ORDER_SETTINGS`, :data:`SEGMENT_CHECK_SETTINGS`)."""

FIXED_ORDER_SETTINGS = replace(PAPER_SETTINGS, factor_order="fixed")
"""The ablation "LA-RRT, fixed factor order": :data:`PAPER_SETTINGS` with the original's fixed order."""

SEGMENT_CHECK_SETTINGS = replace(PAPER_SETTINGS, check_isolated_segment=True)
"""The ablation "LA-RRT, original segment check": :data:`PAPER_SETTINGS` that also checks the straight
multi-factor segment an isolated step replaces, as the original did."""

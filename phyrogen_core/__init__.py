"""PhyRoGen core: the chain model, the Maker, the generators and export (numpy only)."""

from .chain import Geometry, Joint, JointType, KinematicChain, Link, Role
from .geometry import Box, ConvexPrism, Cylinder, Pose
from .maker import GenerationError, MakerInput, make
from .objects import Motion, PuzzleObject, build_chain
from .puzzle import Goal, Puzzle
from .registry import (
    GeneratorSpec,
    ParameterError,
    all_generators,
    describe_generators,
    get_generator,
    paper_generators,
)

__version__ = "0.1.0"

__all__ = [
    "Box", "ConvexPrism", "Cylinder", "GenerationError", "Geometry", "GeneratorSpec", "Goal",
    "Joint", "JointType", "KinematicChain", "Link", "MakerInput", "Motion", "ParameterError",
    "Pose", "Puzzle", "PuzzleObject", "Role", "all_generators", "build_chain", "describe_generators", "get_generator",
    "make", "paper_generators",
]

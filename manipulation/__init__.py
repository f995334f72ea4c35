"""Manipulation: a KUKA LBR iiwa on a mobile base executes a puzzle's solution in PyBullet.

Public entry points: :func:`execute_puzzle` (one puzzle folder -> report,
recording, scene), :func:`write_outputs` (frames, video, report.json) and
:func:`manipulate_folders` (what ``phyrogen manipulate`` runs).
"""

from . import _pybullet  # noqa: F401  (first: pybullet without its build-time banner on stderr)
from .batch import manipulate_folders
from .execution import ExecutionSettings, ManipulationReport, execute_puzzle
from .outputs import summary_table, write_outputs

__all__ = ["ExecutionSettings", "ManipulationReport", "execute_puzzle", "manipulate_folders", "summary_table",
           "write_outputs"]

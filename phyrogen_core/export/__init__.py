"""Export of puzzles to files: URDF, SRDF, ``puzzle.json``, atomic puzzle folders, and reading them back."""

from ..folder import atomic_directory
from .metadata import metadata_json, puzzle_metadata
from .output import puzzle_folder, write_export_files, write_puzzle
from .reader import LoadedPuzzle, PuzzleFormatError, read_puzzle_dir, read_urdf
from .srdf import chain_to_srdf
from .urdf import chain_to_urdf

__all__ = [
    "LoadedPuzzle", "PuzzleFormatError", "atomic_directory", "chain_to_srdf", "chain_to_urdf",
    "metadata_json", "puzzle_folder", "puzzle_metadata", "read_puzzle_dir", "read_urdf", "write_export_files",
    "write_puzzle",
]

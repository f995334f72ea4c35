"""Export of puzzles to files: URDF, SRDF, MJCF, ``puzzle.json``, atomic puzzle folders, and reading them back."""

from ..atomic_writes import atomic_directory
from .metadata import metadata_json, puzzle_metadata
from .mjcf import MJCF_FOLDER, chain_to_mjcf, mjcf_path, write_mjcf
from .output import puzzle_folder, write_export_files, write_puzzle
from .reader import LoadedPuzzle, PuzzleFormatError, read_puzzle_dir, read_urdf
from .srdf import chain_to_srdf
from .urdf import chain_to_urdf

__all__ = [
    "MJCF_FOLDER", "LoadedPuzzle", "PuzzleFormatError", "atomic_directory", "chain_to_mjcf", "chain_to_srdf",
    "chain_to_urdf", "metadata_json", "mjcf_path", "puzzle_folder", "puzzle_metadata", "read_puzzle_dir", "read_urdf",
    "write_export_files", "write_mjcf", "write_puzzle",
]

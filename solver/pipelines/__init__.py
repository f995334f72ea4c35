"""The solver put to work on many puzzles: generation, datasets, audit, import, re-planning.

The top of the solver: may import every other subpackage.
"""

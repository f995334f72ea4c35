"""The solver: collision checking, planning, validation, benchmark and the pipelines built on them.

Six subpackages, layered like the project (docs/architecture.md): collision and parallel at the
bottom, then planning, validation, benchmark and pipelines; each imports only those below it, and
no ``__init__`` imports anything, so using one module never loads its siblings.
"""

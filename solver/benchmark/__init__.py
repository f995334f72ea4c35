"""Planners against each other: runs, OMPL logs, the SQLite database (runner) and the figures (plots).

Imports planning, collision and parallel.
"""

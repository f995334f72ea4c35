"""The Maker's questions: is a puzzle solvable (validator) and is an object necessary (judge).

Imports planning and collision.
"""

"""The planning problem over a puzzle chain and the planners that solve it.

problem (OMPL-free: densify, check and split paths; the dependency graph), ompl_setup (our
collision model inside OMPL), the planners (la_rrt, lbt_rrt, ompl_planners), what they share
(anytime, goal_sampling, defragment) and their registry. Imports collision and the core.
"""

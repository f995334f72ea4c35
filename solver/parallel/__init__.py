"""Where work runs: fresh worker processes (pool), Ray (ray_pool), and the one switch between them (tasks).

Ground floor of the solver: imports nothing else of it, and no OMPL.
"""

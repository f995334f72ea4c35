"""The exact collision model built from a kinematic chain (model) and its compiled loops (kernels).

Ground floor of the solver: imports only the core and numba.
"""

"""Compiled kernels (numba only; nothing here imports from the layers above).

``laws`` (damping laws as data), ``scheme`` (the one step of the central-difference
scheme, status codes), ``integrate`` (whole periods of one or many trajectories, and the
instruments), ``tangent`` (the one-period map with its exact Jacobian).
"""

"""Numerical building blocks shared by every package.

Batch ODE integrators, the LMI solve-and-verify discipline, level sets of quadratic forms,
the one bisection helper and the memory layout of the batched hot path.
"""

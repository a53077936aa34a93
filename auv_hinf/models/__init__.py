"""The physical world.

The 3-DOF vehicle and its batched plants, the operating envelope and its lambda, and the
Jacobi formation coordinates.
"""

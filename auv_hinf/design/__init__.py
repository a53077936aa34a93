"""Gain design.

Theorem 1, the Riccati and LMI routes, python-control blocks, sigma bounds, cross-checks
and the Gains type.
"""

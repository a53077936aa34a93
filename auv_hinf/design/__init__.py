"""Theorem 1 gain design and its checks.

The three alphas, sigma over the envelope (vehicle and Jacobi coordinates), the Riccati and
bounded-real-lemma routes, python-control blocks and the four-way cross-check.
"""

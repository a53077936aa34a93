"""The controller as it runs: sampled, held, delayed and noisy.

Its description, its Lyapunov-Krasovskii LMIs, sample-time and delay limits, the bounds of
the lagged loop and their certificate, seeded noise and delay draws, and the sampled-data
simulation loop.
"""

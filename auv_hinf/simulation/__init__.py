"""Closed-loop simulation.

The per-vehicle law, batched integrators, scenarios, results and streamed metrics.
"""

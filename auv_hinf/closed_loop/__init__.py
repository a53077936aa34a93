"""The nominal closed-loop certificate.

Decay rates, invariant start regions and their Lyapunov LMIs, the region within the
actuator limits, and the coverage of one run.
"""

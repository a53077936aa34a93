"""The nominal closed-loop certificate.

Decay rates, invariant regions, envelope margins, thrust and start coverage.
"""

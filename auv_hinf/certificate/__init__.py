"""The certificate of a fleet, assembled from parts.

The design point of a configuration, the part protocol and its registry, each part (the
paper's Theorem 1, the closed loop, robust, actuators, implementation), the Certificate with
its text and stored document, and run plans.
"""

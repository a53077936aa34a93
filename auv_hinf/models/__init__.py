"""The physical world.

Vehicles, envelopes, formations and Jacobi maps, mission paths, fleet references and
their tubes.
"""

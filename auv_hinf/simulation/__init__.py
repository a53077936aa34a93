"""Closed-loop simulation.

Scenarios and batches, the continuous engine (the sampled loop is in
:mod:`auv_hinf.implementation`), results, streamed metrics and Parquet trajectories.
"""

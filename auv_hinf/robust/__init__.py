"""The robust certificate: a declared plant box and an ocean current.

The parameter box and the perturbed error loops, the robust invariant set and its LMIs,
margins (how far the box can grow, also within the actuator limits), and robust gain design.
"""

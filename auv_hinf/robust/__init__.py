"""The robust certificate.

The declared parameter box, perturbed error loops, margins and the bandwidth design.
"""

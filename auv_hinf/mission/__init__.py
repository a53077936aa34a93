"""What the fleet is asked to do.

Mission paths with provable bounds, the fleet reference (offsets in the inertial or path
frame, shaped starts), its sound tubes, and the envelope margins of error bounds along it.
"""

"""What the vehicles can push and what the law asks of them.

Per-channel limits and saturation, thruster allocation polytopes, and sound bounds of the
commanded force from bounds of the tracking errors.
"""

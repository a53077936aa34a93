"""The formation control law.

The gains, the per-vehicle law of Yang & Zhang in its O(N) form, and its python-control
interconnection.
"""

"""One pass per command.

The design point of a configuration, the Certificate, its files and python-control
export, run plans.
"""

"""The ``auv-hinf`` command line."""

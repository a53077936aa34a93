"""The certificate of the line-of-sight cascade: a propeller-and-rudder vehicle, every plant, every current."""

"""The composed certificate: one vehicle's deployed loop, every declared effect at once."""

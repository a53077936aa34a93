"""Every matplotlib figure of the toolbox: simulations, the sigma map, surveys, the implementation."""

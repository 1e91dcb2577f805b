"""The simulated world: generated cliffs and worlds for the simulated camera, and the
benchmark regimes drawn from them."""

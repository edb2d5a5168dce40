"""fem_cloth_fit: the simulation's parameters fitted to a recording of a cloth (docs/fitting.md)."""

"""Applications on top of the engine: demos (and later the viewer and RL environments)."""

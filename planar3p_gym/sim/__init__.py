"""The simulation: the pymunk model of the closed chain, its projection onto the constraint
manifold, the batched projection of the native vector env, and rendering."""

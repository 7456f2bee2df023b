"""The scenes stage: the planar steering model, the planner and the scene result kind."""

"""The solvers stage: the public wrappers that validate, allocate and call the kernels."""

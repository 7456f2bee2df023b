"""Numba kernels: loops only, called through the validating wrappers of :mod:`study.solvers`."""

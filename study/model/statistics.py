"""Statistical constants the averages of irregular motions are reported with.

Declared here, below every stage, so that the kernels that average
(:mod:`study.kernels.time_average`), the result variables that state the confidence
interval (:mod:`study.studies.variables`) and the figures that draw it read one value.
"""

__all__ = ["Z_95"]

#: The two-sided 95 % quantile of the normal distribution: the confidence half-width
#: of a batch-means average is this times its standard error (the batch means number
#: at least 32).
Z_95 = 1.959963984540054

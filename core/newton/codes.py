"""The integer codes shared by the compiled solver and its Python callers: the kernels (as
`core.kernels` names them), the shifts of Eq. 19-20, the output modes and the per-point status."""

from __future__ import annotations

# Kernel identifiers shared with core.kernels.
MAXIMUM_LIKELIHOOD = 0


PSEUDO_HARMONIC = 1


POWER = 2


HARMONIC_LIKE = 3


MODIFIED_MEAN_VALUE = 4


MODIFIED_MEAN_VALUE_SQUARED = 5


MEAN_VALUE = 6


WACHSPRESS = 7


LAPLACE = 8


SHIFT_NONE = 0


SHIFT_INTEGRAL = 1


SHIFT_MEAN = 2


OUTPUT_SAMPLES = 0  # lambda lumped onto the N samples, row sums to 1 / h


OUTPUT_BASIS = 1  # G_i = sum_j w_j lambda_j N_i(t_j), row sums to 1


STATUS_CONVERGED = 0


STATUS_NOT_CONVERGED = 1


STATUS_OUTSIDE = 2


STATUS_AT_FEASIBLE_EDGE = 3

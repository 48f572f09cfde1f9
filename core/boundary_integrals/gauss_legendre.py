"""The Gauss–Legendre rule of every panel, and the Legendre polynomials at its nodes.

A leaf: `panels` places the rule on the curve, `cauchy_integrals` and `compiled_integrals`
integrate with it, `two_grid` restricts to a coarser rule.  Compiled code freezes these
arrays into its machine code (`core.jit_cache` stamps the cache with this module).
"""

from __future__ import annotations

import numpy as np

#: Gauss–Legendre nodes per panel.
ORDER = 16

#: The nodes s_j in [-1, 1] and weights w_j of the ORDER-point rule, each (ORDER,).
NODES, WEIGHTS = np.polynomial.legendre.leggauss(ORDER)

#: P_k(s_j) at the Gauss–Legendre nodes, (ORDER (j), ORDER (k)).
LEGENDRE_VALUES = np.polynomial.legendre.legvander(NODES, ORDER - 1)

#: L (ORDER, ORDER): L[j, k] = w_j (2k + 1) / 2 P_k(s_j), so that Σ_j L[j, k] f(s_j) is f's
#: k-th Legendre coefficient for f of degree < ORDER, and
#: ∫ f(s) g(s) ds = Σ_j f(s_j) Σ_k L[j, k] ∫ P_k(s) g(s) ds.
LEGENDRE_WEIGHTS = WEIGHTS[:, None] * (np.arange(ORDER) + 0.5) * LEGENDRE_VALUES

"""The boundary-integral kernels: Gauss panels, Cauchy integrals, the Poisson kernel, Cauchy-Green."""

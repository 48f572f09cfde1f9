"""The per-point Newton solver of the point kernels (Eq. 16-17), its gradients and its compilation."""

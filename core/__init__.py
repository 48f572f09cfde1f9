"""Transfinite barycentric coordinates on closed quadratic B-spline domains.

Pure numerics (numpy, scipy, numba): never imports `app`, moderngl, glfw or imgui.
See .docs/architecture.md in the repository for the data flow and the paper's equation numbers.
"""

# First, before numpy loads OpenBLAS and before numba starts its OpenMP pool: their idle threads
# spin briefly or not at all (`core.library_threads`).
import core.library_threads  # noqa: F401, I001

# Then: the compiled functions of the package compile uncached where numba cannot cache.
import core.jit_cache  # noqa: F401, I001
from core.basis import basis_functions
from core.curves.boundary import Boundary
from core.curves.bspline import ClosedBSpline
from core.newton.compilation import compile_solver
from core.deformation import deform
from core.gradients import basis_gradients, kernel_gradients
from core.meshes.harmonic import harmonic_basis
from core.injectivity.certificate import InjectivityCertificate, certify_injective
from core.injectivity.composite import fold_free_deform
from core.pins.pin_deform import PIN_KERNELS, PinDeformation, pin_deform
from core.kernel_table import BOUNDARY_INTEGRAL_KERNELS, COMPLEX_KERNELS, DEFAULT_KERNEL, MESH_ONLY_KERNELS
from core.kernels import KERNELS, ConvergenceWarning, SolveReport, kernel
from core.meshes.mesh import Mesh, folded_triangles
from core.mesh_basis import CacheWarning, mesh_basis_functions
from core.meshes.pgw import pgw_basis
from core.meshes.triangulation import triangulate

__all__ = [
    "BOUNDARY_INTEGRAL_KERNELS",
    "COMPLEX_KERNELS",
    "DEFAULT_KERNEL",
    "KERNELS",
    "MESH_ONLY_KERNELS",
    "PIN_KERNELS",
    "Boundary",
    "CacheWarning",
    "ClosedBSpline",
    "ConvergenceWarning",
    "InjectivityCertificate",
    "Mesh",
    "PinDeformation",
    "SolveReport",
    "basis_functions",
    "basis_gradients",
    "certify_injective",
    "compile_solver",
    "deform",
    "fold_free_deform",
    "folded_triangles",
    "harmonic_basis",
    "kernel",
    "kernel_gradients",
    "mesh_basis_functions",
    "pgw_basis",
    "pin_deform",
    "triangulate",
]

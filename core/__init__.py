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
from core.injectivity.drag_step import DragMesh, DragStep, drag_mesh, drag_step
from core.injectivity.mesh_bijection import MeshBijection, prove_mesh_bijection
from core.kernel_table import BOUNDARY_INTEGRAL_KERNELS, COMPLEX_KERNELS, DEFAULT_KERNEL, MESH_ONLY_KERNELS
from core.kernels import KERNELS, ConvergenceWarning, SolveReport, kernel
from core.meshes.mesh import Mesh, folded_triangles
from core.mesh_basis import CacheWarning, mesh_basis_functions
from core.meshes.pgw import pgw_basis
from core.meshes.triangulation import triangulate

# What the app needs beyond the mathematics above: file and cache helpers, input checks, the
# kernel table, compile messages, example shapes and the mesh measures of the studies and the bench.
# `app` imports only from here (tests/house/test_house_app.py).
from core.boundary_integrals.poisson import load_compiled as load_compiled_integrals, solved_densities
from core.curves import examples
from core.curves.arc_length import DEFAULT_PARAMETERIZATION, PARAMETERIZATIONS, checked_parameterization
from core.curves.bspline import basis_weights
from core.curves.closest_point import distance_to_curve
from core.curves.examples import wave_heights
from core.curves.interpolating_spline import interpolating_control_points
from core.kernel_table import COMPILED_KERNELS, BY_NAME as KERNEL_TABLE, PARAMETERIZED_KERNELS
from core.kernels import SHIFTS, kernel_parameters
from core.mesh_basis import DEFAULT_SAMPLES_PER_SEGMENT
from core.meshes import distortion
from core.meshes.distortion import (
    signed_singular_values,
    triangle_jacobians,
    vertex_jacobians,
    worst_distortion,
)
from core.injectivity.mesh_fold_free import PLAIN_HARMONIC_MAP
from core.meshes.mesh import unique_edges
from core.meshes.mesh_transfer import transfer_basis
from core.meshes.refinement import RADIUS_EDGE_RATIO
from core.newton.compilation import (
    MESSAGE as COMPILE_MESSAGE,
    GRADIENTS_MESSAGE as GRADIENTS_COMPILE_MESSAGE,
    GRADIENT_MESSAGE as GRADIENT_COMPILE_MESSAGE,
)
from core.newton.reference import reference_kernel
from core.storage.atomic_write import NAME_MAX, abandoned_temporaries, temporary_path, write_atomically
from core.storage.cache import cache_directory
from core.storage.state_directory import state_directory
from core.validation import (
    MAX_BOUNDARY_SAMPLES,
    MAX_CONTROL_POINTS,
    as_points,
    checked_samples_per_segment,
    positive_int,
    too_many_control_points,
)

__all__ = [
    "BOUNDARY_INTEGRAL_KERNELS",
    "COMPILED_KERNELS",
    "COMPILE_MESSAGE",
    "COMPLEX_KERNELS",
    "DEFAULT_KERNEL",
    "DEFAULT_PARAMETERIZATION",
    "DEFAULT_SAMPLES_PER_SEGMENT",
    "GRADIENTS_COMPILE_MESSAGE",
    "GRADIENT_COMPILE_MESSAGE",
    "KERNELS",
    "KERNEL_TABLE",
    "MAX_BOUNDARY_SAMPLES",
    "MAX_CONTROL_POINTS",
    "MESH_ONLY_KERNELS",
    "NAME_MAX",
    "PARAMETERIZATIONS",
    "PARAMETERIZED_KERNELS",
    "PIN_KERNELS",
    "PLAIN_HARMONIC_MAP",
    "RADIUS_EDGE_RATIO",
    "SHIFTS",
    "Boundary",
    "CacheWarning",
    "ClosedBSpline",
    "ConvergenceWarning",
    "DragMesh",
    "DragStep",
    "InjectivityCertificate",
    "Mesh",
    "MeshBijection",
    "PinDeformation",
    "SolveReport",
    "abandoned_temporaries",
    "as_points",
    "basis_functions",
    "basis_gradients",
    "basis_weights",
    "cache_directory",
    "certify_injective",
    "checked_parameterization",
    "checked_samples_per_segment",
    "compile_solver",
    "deform",
    "distance_to_curve",
    "distortion",
    "drag_mesh",
    "drag_step",
    "examples",
    "fold_free_deform",
    "folded_triangles",
    "harmonic_basis",
    "interpolating_control_points",
    "kernel",
    "kernel_gradients",
    "kernel_parameters",
    "load_compiled_integrals",
    "mesh_basis_functions",
    "pgw_basis",
    "pin_deform",
    "positive_int",
    "prove_mesh_bijection",
    "reference_kernel",
    "signed_singular_values",
    "solved_densities",
    "state_directory",
    "temporary_path",
    "too_many_control_points",
    "transfer_basis",
    "triangle_jacobians",
    "triangulate",
    "unique_edges",
    "vertex_jacobians",
    "wave_heights",
    "worst_distortion",
    "write_atomically",
]

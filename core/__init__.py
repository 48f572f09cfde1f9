"""Transfinite barycentric coordinates on closed quadratic B-spline domains.

Pure numerics (numpy, scipy, numba): never imports `app`, moderngl, glfw or imgui.
See .docs/architecture.md in the repository for the data flow and the paper's equation numbers.
"""

import importlib  # noqa: I001

# First, before numpy loads OpenBLAS and before numba starts its OpenMP pool: their idle threads
# spin briefly or not at all (`core.library_threads`).
import core.library_threads  # noqa: F401, I001

# Then: the compiled functions of the package compile uncached where numba cannot cache.
import core.jit_cache  # noqa: F401, I001

#: Where each name of `__all__` is defined: "module" (the name there, or the module of that name in
#: that package: `examples`, `distortion`) or "module:attribute" (named otherwise here).  A name
#: is imported at its first use (`__getattr__`, PEP 562): a command loads only the modules it uses
#: (``warp`` neither the injectivity proofs nor the finite-element solvers).
_WHERE = {
    "basis_functions": "core.basis",
    "Boundary": "core.curves.boundary",
    "ClosedBSpline": "core.curves.bspline",
    "compile_solver": "core.newton.compilation",
    "deform": "core.deformation",
    "basis_gradients": "core.gradients",
    "kernel_gradients": "core.gradients",
    "harmonic_basis": "core.meshes.harmonic",
    "InjectivityCertificate": "core.injectivity.certificate",
    "certify_injective": "core.injectivity.certificate",
    "fold_free_deform": "core.injectivity.composite",
    "PIN_KERNELS": "core.pins.pin_deform",
    "PinDeformation": "core.pins.pin_deform",
    "pin_deform": "core.pins.pin_deform",
    "DragMesh": "core.injectivity.drag_step",
    "DragStep": "core.injectivity.drag_step",
    "drag_mesh": "core.injectivity.drag_step",
    "drag_step": "core.injectivity.drag_step",
    "MeshBijection": "core.injectivity.mesh_bijection",
    "prove_mesh_bijection": "core.injectivity.mesh_bijection",
    "BOUNDARY_INTEGRAL_KERNELS": "core.kernel_table",
    "COMPLEX_KERNELS": "core.kernel_table",
    "DEFAULT_KERNEL": "core.kernel_table",
    "MESH_ONLY_KERNELS": "core.kernel_table",
    "KERNELS": "core.kernel_table:POINT_KERNELS",  # core.kernels.KERNELS, without the solver
    "ConvergenceWarning": "core.kernels",
    "SolveReport": "core.kernels",
    "kernel": "core.kernels",
    "Mesh": "core.meshes.mesh",
    "folded_triangles": "core.meshes.mesh",
    "CacheWarning": "core.mesh_basis",
    "mesh_basis_functions": "core.mesh_basis",
    "pgw_basis": "core.meshes.pgw",
    "triangulate": "core.meshes.triangulation",
    # What the app needs beyond the mathematics above: file and cache helpers, input checks, the
    # kernel table, compile messages, example shapes and the mesh measures of the studies and the
    # bench. `app` imports only from here (tests/house/test_house_app.py).
    "load_compiled_integrals": "core.boundary_integrals.poisson:load_compiled",
    "solved_densities": "core.boundary_integrals.poisson",
    "examples": "core.curves",
    "DEFAULT_PARAMETERIZATION": "core.curves.arc_length",
    "PARAMETERIZATIONS": "core.curves.arc_length",
    "checked_parameterization": "core.curves.arc_length",
    "basis_weights": "core.curves.bspline",
    "distance_to_curve": "core.curves.closest_point",
    "wave_heights": "core.curves.examples",
    "interpolating_control_points": "core.curves.interpolating_spline",
    "COMPILED_KERNELS": "core.kernel_table",
    "KERNEL_TABLE": "core.kernel_table:BY_NAME",
    "PARAMETERIZED_KERNELS": "core.kernel_table",
    "SHIFTS": "core.kernels",
    "kernel_parameters": "core.kernels",
    "DEFAULT_SAMPLES_PER_SEGMENT": "core.mesh_basis",
    "distortion": "core.meshes",
    "signed_singular_values": "core.meshes.distortion",
    "triangle_jacobians": "core.meshes.distortion",
    "vertex_jacobians": "core.meshes.distortion",
    "worst_distortion": "core.meshes.distortion",
    "PLAIN_HARMONIC_MAP": "core.injectivity.mesh_fold_free",
    "unique_edges": "core.meshes.mesh",
    "transfer_basis": "core.meshes.mesh_transfer",
    "RADIUS_EDGE_RATIO": "core.meshes.refinement",
    "COMPILE_MESSAGE": "core.newton.compilation:MESSAGE",
    "GRADIENTS_COMPILE_MESSAGE": "core.newton.compilation:GRADIENTS_MESSAGE",
    "GRADIENT_COMPILE_MESSAGE": "core.newton.compilation:GRADIENT_MESSAGE",
    "reference_kernel": "core.newton.reference",
    "NAME_MAX": "core.storage.atomic_write",
    "abandoned_temporaries": "core.storage.atomic_write",
    "temporary_path": "core.storage.atomic_write",
    "write_atomically": "core.storage.atomic_write",
    "cache_directory": "core.storage.cache",
    "state_directory": "core.storage.state_directory",
    "MAX_BOUNDARY_SAMPLES": "core.validation",
    "MAX_CONTROL_POINTS": "core.validation",
    "as_points": "core.validation",
    "checked_samples_per_segment": "core.validation",
    "positive_int": "core.validation",
    "too_many_control_points": "core.validation",
}

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


def __getattr__(name: str):
    """The name `name` of `__all__`, imported from its module at its first use and kept; or a module
    of the package (`core.kernels`), imported."""
    where = _WHERE.get(name)
    if where is None:
        try:
            return importlib.import_module(f"core.{name}")
        except ModuleNotFoundError as error:
            if error.name != f"core.{name}":
                raise
            raise AttributeError(f"module 'core' has no attribute {name!r}") from None
    module, _, attribute = where.partition(":")
    attribute = attribute or name
    value = importlib.import_module(module)
    if hasattr(value, attribute):
        value = getattr(value, attribute)
    else:  # a module of the package
        value = importlib.import_module(f"{module}.{attribute}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))

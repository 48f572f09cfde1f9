"""Every kernel of the project in one table: what it is, and what each part of the code reads.

Adding a kernel is one `Kernel` row here and its computation: a weight function in
`core.newton.solver` (and its derivative in `core.gradients`) for the Newton family, a module
like `core.boundary_integrals.poisson` for a boundary-integral kernel.  The tuples below (`POINT_KERNELS`,
`CONVEX_ONLY`, ...) are derived from the table; nothing else lists kernels.
"""

from __future__ import annotations

from dataclasses import dataclass

#: Families: how a kernel is computed.
BOUNDARY_INTEGRAL = "boundary integral"  # boundary_integrals.poisson, .cauchy_green: one solve per cage
NEWTON = "weighted maximum likelihood"  # core.newton.solver: a 2-variable convex problem per point (Eq. 16)
EXPLICIT = "explicit"  # core.newton.solver, closed-form weights (mean value, three-point family)
MESH = "mesh"  # defined through the mesh or by line intersections (core.meshes.harmonic, core.meshes.pgw)


@dataclass(frozen=True)
class Kernel:
    """One kernel.

    Attributes
    ----------
    name : str
        Its name in the API, the CLI, the viewer and session files (a public contract).
    family : str
        `BOUNDARY_INTEGRAL`, `NEWTON`, `EXPLICIT` or `MESH`.
    equation : str
        Where the paper (or the literature) defines it.
    convex_only : bool
        Defined for convex domains only.
    complex_valued : bool
        Its coordinates are complex numbers (`core.deform`).
    gradients : bool
        Pointwise gradients grad G (`core.basis_gradients`).
    parameters : tuple of str
        Keyword parameters it takes.
    compiled : bool
        Needs the numba-compiled solver (its first use compiles it).
    parameterized : bool
        Depends on the boundary's parameterization (natural or arc length): the kernels
        integrated against dt.  Harmonic (FEM or Poisson) and Cauchy-Green coordinates
        are geometric and do not.
    """

    name: str
    family: str
    equation: str
    convex_only: bool = False
    complex_valued: bool = False
    gradients: bool = True
    parameters: tuple[str, ...] = ()

    @property
    def compiled(self) -> bool:
        return self.family in (NEWTON, EXPLICIT)

    @property
    def parameterized(self) -> bool:
        return self.family in (NEWTON, EXPLICIT)


#: The kernel of `core.basis_functions`, `core.mesh_basis_functions`, `warp` and the viewer.
DEFAULT_KERNEL = "poisson"

TABLE = (
    Kernel(
        "poisson",
        BOUNDARY_INTEGRAL,
        "Poisson kernel, Eq. 2 and 7; double layer (core.boundary_integrals.poisson)",
    ),
    Kernel("harmonic-like", NEWTON, "Eq. 20"),
    Kernel("mean-value", EXPLICIT, "Eq. 5"),
    Kernel("modified-mean-value", NEWTON, "Eq. 22-23"),
    Kernel("modified-mean-value-squared", NEWTON, "Sec. 3.4"),
    Kernel("maximum-likelihood", NEWTON, "Sec. 3.1"),
    Kernel("pseudo-harmonic", NEWTON, "Eq. 18"),
    Kernel("power", NEWTON, "Eq. 19", parameters=("power", "shift")),
    Kernel("inverse-cube-mean", NEWTON, "Eq. 19, k = 3, shifted by the mean"),
    Kernel("wachspress", EXPLICIT, "Sec. 1.1, three-point family", convex_only=True),
    Kernel("laplace", EXPLICIT, "Sec. 1.1, three-point family", convex_only=True),
    Kernel(
        "cauchy-green",
        BOUNDARY_INTEGRAL,
        "Cauchy-Green coordinates (core.boundary_integrals.cauchy_green)",
        complex_valued=True,
    ),
    Kernel("pgw", MESH, "positive Gordon-Wixom, Sec. 1.1", gradients=False, parameters=("angles",)),
    Kernel("harmonic", MESH, "finite-element harmonic, Sec. 4.2", gradients=False),
)
BY_NAME = {kernel.name: kernel for kernel in TABLE}

#: The real point kernels, evaluated anywhere (`core.basis_functions`): G @ P == x.
POINT_KERNELS = tuple(k.name for k in TABLE if k.family != MESH and not k.complex_valued)
#: Point kernels with complex coordinates.
COMPLEX_KERNELS = tuple(k.name for k in TABLE if k.complex_valued)
#: Kernels defined through the mesh (`core.mesh_basis_functions` only).
MESH_ONLY_KERNELS = tuple(k.name for k in TABLE if k.family == MESH)
BOUNDARY_INTEGRAL_KERNELS = tuple(k.name for k in TABLE if k.family == BOUNDARY_INTEGRAL)
#: Linear precision holds to the Newton tolerance.
NEWTON_KERNELS = tuple(k.name for k in TABLE if k.family == NEWTON)
COMPILED_KERNELS = tuple(k.name for k in TABLE if k.compiled)
CONVEX_ONLY = tuple(k.name for k in TABLE if k.convex_only)
#: Kernels whose coordinates change with the boundary's parameterization.
PARAMETERIZED_KERNELS = tuple(k.name for k in TABLE if k.parameterized)

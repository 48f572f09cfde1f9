"""Injective (fold-free) harmonic warps: a certificate that a warp never folds, and a fold-free warp.

- `certificate`: `certify_injective`, the proof from samples on a curve just inside the boundary
  (Chen & Weber 2015's argument principle and maximum principle), with its assumptions;
- `simple_curve`: a proof that a closed quadratic B-spline does not cross itself;
- `inner_curve`, `boundary_samples`, `harmonic_parts`: the curve Γ, the samples and bounds on it,
  and the complex derivatives f_z, f_z̄ of the harmonic map;
- `composite`: `fold_free_deform`, composite harmonic maps along a path of cages (Schneider,
  Hormann & Floater 2013), each step certified; given a mesh with its boundary, the mesh's own map:
- `mesh_fold_free`: the plain map where it is a bijection on the mesh, else composites on paths of
  cages (straight; a similarity then straight), an untangling as a last resort;
- `mesh_composite`: discrete harmonic steps, each cut before a triangle turns over;
- `mesh_bijection`: the proof that a mesh's piecewise-linear map is a bijection (every triangle
  positive, the boundary polygon simple);
- `corner_discs`: the radial map a step uses in the corner discs its certificate leaves unproven;
- `mesh_unfolding`: `unfold_triangles`, the repair of the few mesh triangles that a proven
  bijection's straight-edged interpolant still turns over, one vertex at a time;
- `mesh_untangling`: `untangle_triangles`, the global fallback where rows of them turn over
  together (Garanzha et al. 2021's barrier method on a region around them);
- `mesh_bijection`: `prove_mesh_bijection`, the exact proof that a mesh's piecewise-linear map is a
  bijection (every triangle positive, the boundary polygon simple);
- `drag_step`: `drag_step`, one frame of a fold-free drag: the plain map where it is proven, else
  the last frame's positions moved onto the target curve by flip-free substeps (the barrier
  energy's tangent where triangles are squeezed).
"""

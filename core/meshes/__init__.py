"""Triangle meshes of the domain and the kernels defined on them (FEM harmonic, positive Gordon-Wixom)."""

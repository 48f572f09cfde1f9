"""Pins in the picture with a distortion bound (Chen & Weber 2015's bounded-distortion harmonic maps
on curved cages): `pin_deform`.

- `pin_deform`: validation, the certify-and-tighten loop, and the result `PinDeformation`;
- `exact_solve`: without a bound, the pins placed exactly (least departure from a similarity);
- `conic_solve`: with a bound, the second-order cone program over BDHM's active set (clarabel);
- `precompute`: the per-cage samples on the curve Γ inside the boundary and their f_z, f_z̄ rows;
- `linear_rows`: the real rows of every quantity the solver constrains.
"""

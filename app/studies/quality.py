"""``python -m app quality``: which kernel deforms best? Folds, spill-out and distortion on a suite.

For every domain of the standard suite (`app.studies.quality_suite`) one mesh is made
(`core.triangulate` with its default edge length) and each kernel's basis G on it
(`core.mesh_basis_functions`, Sec. 4.3); every deformation is then x' = G P' for its
target control points P'.  Per kernel the table reports, over the deformations whose
target curve is simple (a self-crossing target folds every map, so those are
counted apart):

- folded area: the mean share of the source area whose triangles fold over or
  collapse, and how many deformations fold anywhere;
- outside: the mean share of interior vertices mapped outside the target curve
  (the "spill-out" of the paper's Fig. 11);
- sigma_1 / sigma_2: conformal distortion per triangle (`core.meshes.distortion`), folded
  triangles counted as `core.meshes.distortion.DISTORTION_CAP`; the mean over the source
  area and the area-weighted 99th percentile, averaged over the deformations;
- map RMS: distance of the deformed vertices to the FEM harmonic deformation, in %
  of the target's diameter (area-weighted RMS over the vertices);
- height RMS: distance of the height interpolant of `core.curves.examples.wave_heights` to
  the FEM harmonic one (what ``compare`` shows), averaged over the domains (the real
  part, for the complex Cauchy–Green coordinates);
- boundary gap: the largest distance from a deformed boundary vertex to the target
  curve at its parameter, in % of the target's diameter: 0 for every interpolating
  kernel, the price of conformality for ``cauchy-green``;
- vertex s1/s2: the largest sigma_1 / sigma_2 - 1 at the interior vertices from the
  exact Jacobians J = sum_i P'_i grad G_i^T, for the boundary-integral kernels (whose
  gradients cost little): 0 to rounding for the conformal ``cauchy-green``;
- proven: how many maps `core.certify_injective` proves fold-free (harmonic maps only: the
  default ``poisson`` and its fold-free composite; n/a for the others);
- time: the basis functions of every domain, in this process, without the disk cache (and, for
  the fold-free row, its composite maps).

The fold-free row is ``poisson`` made fold-free by `core.fold_free_deform` (certified composite
harmonic maps on the straight path of cages; the few triangles that the proven map's straight edges
still turn over are unfolded by moving interior vertices, the moves reported by the certificate);
where that path crosses itself, or no step near a very thin part can be proven, it keeps the plain
map (not proven; its folds count).

`weight_family` is the search over the weights of Eq. 19 (``--search``).
"""

from __future__ import annotations

import argparse
import time
import warnings
from dataclasses import dataclass, field

import numpy as np

import core
from app.console import EXIT_OK, ProgressBar, note
from app.io.files import InputError, kernel_names, reported_as_input
from core import COMPILE_MESSAGE as COMPILING
from core import (
    COMPILED_KERNELS,
    checked_parameterization,
    deform,
    distortion,
    kernel_parameters,
    positive_int,
)
from core import KERNEL_TABLE as BY_NAME

#: The reference of the distances: the finite-element harmonic basis (Sec. 4.2).
REFERENCE = "harmonic"
#: Kernels that only take convex domains; the suite has none.
SKIPPED = ("wachspress", "laplace")
#: Powers k and shifts of the weight family searched by ``--search`` (Eq. 19-20).
SEARCH_POWERS = (1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0)
SEARCH_SHIFTS = ("none", "mean", "integral")
UNSHIFTED_UP_TO = 4.0


@dataclass(frozen=True)
class KernelChoice:
    """A kernel with its parameters, as `core.mesh_basis_functions` takes them."""

    label: str
    kernel: str
    params: dict = field(default_factory=dict)
    fold_free: bool = False


@dataclass
class KernelResult:
    """One kernel's measures over the suite; per-deformation arrays are in suite order,
    without the self-crossing targets."""

    choice: KernelChoice
    folded: list[float] = field(default_factory=list)
    outside: list[float] = field(default_factory=list)
    distortion_mean: list[float] = field(default_factory=list)
    distortion_99: list[float] = field(default_factory=list)
    map_rms: list[float] = field(default_factory=list)
    height_rms: list[float] = field(default_factory=list)
    boundary_gap: list[float] = field(default_factory=list)
    vertex_distortion: list[float] = field(default_factory=list)
    proven: list[bool] = field(default_factory=list)
    seconds: float = 0.0
    unconverged_domains: list[str] = field(default_factory=list)
    skipped: str | None = None

    def summary(self) -> dict[str, float]:
        """The table's numbers: means over the deformations (and domains, for height RMS)."""
        folded = np.array(self.folded)
        return {
            "folded": float(folded.mean()),
            "with folds": int(np.count_nonzero(folded > 0)),
            "deformations": int(folded.size),
            "outside": float(np.mean(self.outside)),
            "distortion mean": float(np.mean(self.distortion_mean)),
            "distortion 99": float(np.mean(self.distortion_99)),
            "map rms": float(np.mean(self.map_rms)),
            "height rms": float(np.mean(self.height_rms)),
            "boundary gap": float(np.mean(self.boundary_gap)),
            "vertex distortion": float(np.max(self.vertex_distortion)) if self.vertex_distortion else None,
            "proven": int(np.count_nonzero(self.proven)) if self.proven else None,
            "seconds": self.seconds,
        }


@dataclass
class StudyResult:
    """What `run_study` measured: per kernel, and the deformations that were set aside."""

    kernels: list[KernelResult]
    deformations: list[tuple[str, str]]  # (domain, label) of the measured ones, in order
    self_crossing: list[tuple[str, str]]  # (domain, label) of the targets that cross themselves
    vertices: int  # mesh vertices over all domains
    meshes: dict = field(default_factory=dict)  # domain name -> core.Mesh, if kept
    bases: dict = field(default_factory=dict)  # (domain name, kernel label) -> G (V, n), if kept
    positions: dict = field(
        default_factory=dict
    )  # (domain, kernel label, deformation label) -> (V, 2), fold-free


def default_kernels() -> list[KernelChoice]:
    """Every kernel usable on non-convex domains, the harmonic reference first."""
    names = [name for name in kernel_names() if name not in SKIPPED and name != REFERENCE]
    choices = [KernelChoice(REFERENCE, REFERENCE)]
    for name in names:
        if name == "power":
            # The power kernel's defaults, 1 / r^2: the family's best fold count (see --search).
            choices.append(KernelChoice("power 2, shift none", "power", {"power": 2.0, "shift": "none"}))
        else:
            choices.append(KernelChoice(name, name))
        if name == core.DEFAULT_KERNEL:
            choices.append(KernelChoice(f"{name}, fold-free", name, fold_free=True))
    return choices


def weight_family() -> list[KernelChoice]:
    """The searched weights omega = 1 / r^k with shift none, mean or integral (Eq. 19), with
    Eq. 20 as power 4, shift integral and its mean-shifted variant as power 4, shift mean.

    Unshifted powers stop at `UNSHIFTED_UP_TO`: from k = 2.5 on Newton leaves points
    unresolved near the boundary (Sec. 3.3), they are solved again on finer quadratures,
    and each takes minutes on the suite while folding more with every step of k.
    """
    return [
        KernelChoice(f"power {power:g}, shift {shift}", "power", {"power": power, "shift": shift})
        for shift in SEARCH_SHIFTS
        for power in SEARCH_POWERS
        if shift != "none" or power <= UNSHIFTED_UP_TO
    ]


def parse_kernel(text: str) -> KernelChoice:
    """``NAME[:param=value,...]`` as a KernelChoice; integers stay integers, other numbers become
    floats.  The parameters are checked here (`InputError`): those of the point kernels and their
    ``parameterization`` (natural or arc-length), and ``pgw``'s ``angles``.

    >>> parse_kernel("power:power=2.5,shift=mean").params
    {'power': 2.5, 'shift': 'mean'}
    """
    name, _, rest = text.partition(":")
    if name not in kernel_names():
        raise InputError(
            f"--kernel {text}: unknown kernel {name!r}; choose one of {', '.join(kernel_names())}"
        )
    params: dict = {}
    for item in filter(None, rest.split(",")):
        key, equals, value = item.partition("=")
        if not equals or not key:
            raise InputError(f"--kernel {text}: expected NAME:param=value,... but got {item!r}")
        params[key] = _parameter_value(value)
    if name in core.BOUNDARY_INTEGRAL_KERNELS:
        unknown = sorted(set(params) - {"parameterization"})
        if unknown:
            raise InputError(
                f"--kernel {text}: kernel {name!r} takes no parameters, got {', '.join(unknown)}"
            )
    elif name in core.KERNELS:
        with reported_as_input(f"--kernel {text}"):
            checked_parameterization(params.get("parameterization", "natural"))
            kernel_parameters(
                name, {key: value for key, value in params.items() if key != "parameterization"}
            )
    elif name in core.MESH_ONLY_KERNELS:
        takes = BY_NAME[name].parameters
        unknown = sorted(set(params) - set(takes))
        if unknown:
            raise InputError(
                f"--kernel {text}: kernel {name!r} does not take {', '.join(unknown)} "
                f"(it takes: {', '.join(takes) or 'nothing'})"
            )
        if "angles" in params:
            with reported_as_input(f"--kernel {text}"):
                positive_int(params["angles"], "angles")
    return KernelChoice(text if params else name, name, params)


def _parameter_value(text: str):
    """A ``--kernel`` parameter: an int (``angles=8``), else a float (``power=2.5``), else the text."""
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def run_study(domains, choices: list[KernelChoice], progress=None, keep: bool = False) -> StudyResult:
    """Measure every kernel of `choices` on every domain of the suite.

    Parameters
    ----------
    domains : list of app.studies.quality_suite.Domain
        The suite.
    choices : list of KernelChoice
        Kernels to measure; the harmonic reference is added first if missing.
    progress : callable, optional
        Called with the fraction done in [0, 1].
    keep : bool
        Keep every mesh and basis in the result (for the figure).

    Returns
    -------
    StudyResult
        A kernel that rejects a domain (ValueError) is marked `skipped` with the reason.
    """
    from app.studies.compare import vertex_areas
    from app.warp.pipeline import WarpSettings, prepare
    from core import wave_heights

    if not choices or choices[0].kernel != REFERENCE:
        choices = [KernelChoice(REFERENCE, REFERENCE)] + [c for c in choices if c.kernel != REFERENCE]
    results = [KernelResult(choice) for choice in choices]
    study = StudyResult(results, [], [], 0)
    steps = len(domains) * len(choices)
    for d, domain in enumerate(domains):
        curve = core.ClosedBSpline(domain.control_points)
        mesh = core.triangulate(curve)
        study.vertices += len(mesh.vertices)
        if keep:
            study.meshes[domain.name] = mesh
        areas = np.abs(mesh.signed_areas())
        weights = vertex_areas(mesh.vertices, mesh.triangles)
        heights = wave_heights(curve.n)
        targets = []
        for deformation in domain.deformations:
            try:
                targets.append((deformation, core.ClosedBSpline(deformation.target)))
            except ValueError:
                study.self_crossing.append((domain.name, deformation.label))
        study.deformations += [(domain.name, deformation.label) for deformation, _ in targets]
        reference = None
        for k, result in enumerate(results):
            if result.skipped is not None:
                continue
            choice = result.choice
            started = time.perf_counter()
            done = d * len(choices) + k

            def report(fraction, done=done):
                if progress is not None:
                    progress((done + fraction) / steps)

            try:
                with warnings.catch_warnings(record=True) as caught:
                    warnings.simplefilter("always", core.ConvergenceWarning)
                    settings = WarpSettings(choice.kernel, choice.params, cache=False)
                    warped = prepare(curve, settings, mesh, progress=report)
            except ValueError as error:
                result.skipped = f"{domain.name}: {error}"
                continue
            result.seconds += time.perf_counter() - started
            basis = warped.basis
            if any(issubclass(w.category, core.ConvergenceWarning) for w in caught):
                result.unconverged_domains.append(domain.name)
            if reference is None:
                reference = basis
            if keep:
                study.bases[domain.name, choice.label] = basis
            height_difference = ((basis - reference) @ heights).real
            result.height_rms.append(float(np.sqrt(np.sum(weights * height_difference**2) / np.sum(weights))))
            gradients = None
            if choice.kernel in core.BOUNDARY_INTEGRAL_KERNELS:
                gradients = core.basis_gradients(curve, mesh.vertices[mesh.interior], choice.kernel)
            for deformation, target_curve in targets:
                started = time.perf_counter()
                deformed, proven = _positions(choice, curve, mesh, warped, deformation.target)
                if choice.fold_free:
                    result.seconds += time.perf_counter() - started
                    if keep:
                        study.positions[domain.name, choice.label, deformation.label] = deformed
                if proven is not None:
                    result.proven.append(proven)
                _measure(result, mesh, areas, weights, deformed, reference, deformation.target, target_curve)
                if gradients is not None:
                    sigma = np.linalg.svd(
                        distortion.vertex_jacobians(gradients, deformation.target), compute_uv=False
                    )
                    result.vertex_distortion.append(float((sigma[:, 0] / sigma[:, 1]).max() - 1.0))
    return study


def _positions(choice: KernelChoice, curve, mesh, warped, target) -> tuple[np.ndarray, bool | None]:
    """The deformed vertices (V, 2) of a choice (`warped`: an `app.warp.pipeline.Deformation`) and whether the
    map is proven fold-free (None where no proof applies: maps that are not harmonic)."""
    if choice.fold_free:
        boundary = (mesh.boundary, mesh.boundary_parameters)
        try:
            deformed, certificate = core.fold_free_deform(
                curve, target, mesh.vertices, boundary=boundary, triangles=mesh.triangles
            )
        except ValueError:  # the straight path of cages crosses itself: the plain map
            return warped.positions(target), False
        return deformed, certificate.injective
    if choice.kernel == core.DEFAULT_KERNEL:
        return warped.positions(target), core.certify_injective(curve, target).injective
    return warped.positions(target), None


def _measure(result, mesh, areas, weights, deformed, reference, target, target_curve) -> None:
    """Append the measures of one deformation, vertices `deformed` (V, 2), to `result`."""
    sigma = distortion.signed_singular_values(
        distortion.triangle_jacobians(mesh.vertices, deformed, mesh.triangles)
    )
    ratio = distortion.conformal_distortion(sigma)
    result.folded.append(distortion.folded_area_fraction(areas, sigma))
    result.distortion_mean.append(float(np.sum(areas * ratio) / np.sum(areas)))
    result.distortion_99.append(distortion.weighted_quantile(ratio, areas, 0.99))
    interior = mesh.interior
    result.outside.append(float(np.mean(~target_curve.contains(deformed[interior]))))
    gap = np.linalg.norm(deformed - deform(reference, target), axis=1)
    result.map_rms.append(float(np.sqrt(np.sum(weights * gap**2) / np.sum(weights)) / target_curve.diameter))
    on_target = target_curve(mesh.boundary_parameters)
    boundary = np.linalg.norm(deformed[mesh.boundary] - on_target, axis=1).max(initial=0.0)
    result.boundary_gap.append(float(boundary / target_curve.diameter))


def format_table(study: StudyResult, sort: bool = False) -> str:
    """Plain-text table, one row per kernel (sorted by folded area, then outside, if `sort`)."""
    rows = [result for result in study.kernels if result.skipped is None]
    if sort:
        rows.sort(key=lambda r: (r.summary()["folded"], r.summary()["outside"]))
    width = max(len(r.choice.label) for r in rows)
    header = (
        f"{'kernel':<{width}}  {'folded':>7}  {'folds':>5}  {'outside':>7}  "
        f"{'s1/s2':>5}  {'p99':>5}  {'map RMS':>7}  {'height RMS':>10}  {'bdry gap':>8}  "
        f"{'vertex s1/s2-1':>14}  {'proven':>6}  {'time':>6}"
    )
    lines = [header]
    for result in rows:
        s = result.summary()
        flag = "  (not converged everywhere)" if result.unconverged_domains else ""
        proven = "n/a" if s["proven"] is None else f"{s['proven']:>2}/{s['deformations']:<2}"
        lines.append(
            f"{result.choice.label:<{width}}  {100 * s['folded']:6.2f}%  "
            f"{s['with folds']:>2}/{s['deformations']:<2}  {100 * s['outside']:6.2f}%  "
            f"{s['distortion mean']:5.2f}  {s['distortion 99']:5.2f}  {100 * s['map rms']:6.2f}%  "
            f"{s['height rms']:10.5f}  {100 * s['boundary gap']:7.3f}%  "
            f"{'n/a' if s['vertex distortion'] is None else format(s['vertex distortion'], '.1e'):>14}  "
            f"{proven:>6}  "
            f"{s['seconds']:5.1f}s{flag}"
        )
    return "\n".join(lines)


def run_quality(args: argparse.Namespace) -> int:
    """The ``quality`` command: the table on stdout, the figure to ``args.output``; the exit code."""
    from app.io.files import check_writable, write_png
    from app.studies.quality_suite import standard_suite

    if args.output is not None:
        check_writable(args.output, suffix=".png")
    extra = [parse_kernel(text) for text in args.kernel or []]
    if args.search:
        choices = [KernelChoice(REFERENCE, REFERENCE), *weight_family(), *extra]
    else:
        choices = [*default_kernels(), *extra]
    domains = standard_suite(args.seed)
    if args.domain:
        names = [domain.name for domain in domains]
        unknown = [name for name in args.domain if name not in names]
        if unknown:
            raise InputError(f"--domain: unknown {', '.join(unknown)}; the suite has {', '.join(names)}")
        domains = [domain for domain in domains if domain.name in args.domain]
    started = time.perf_counter()
    if any(choice.kernel in COMPILED_KERNELS for choice in choices):
        # Up front, in one line: inside the study it would hold the quality bar at its first kernel.
        with ProgressBar(COMPILING, announce=True) as compiling:
            core.compile_solver(compiling)
        if compiling.seconds is not None:
            note(f"compiled the solver in {compiling.seconds:.1f} s (first run only; numba caches it)")
    with ProgressBar("quality") as bar:
        study = run_study(domains, choices, progress=bar, keep=args.output is not None)
    print(
        f"{len(domains)} domains ({', '.join(d.name for d in domains)}; {study.vertices:,} mesh vertices), "
        f"{len(study.deformations)} deformations with simple targets, seed {args.seed}; "
        f"{len(study.self_crossing)} self-crossing targets set aside (every map folds there)"
        + "".join(f"\n  {domain}: {label}" for domain, label in study.self_crossing)
    )
    print(format_table(study, sort=args.search))
    for result in study.kernels:
        if result.skipped is not None:
            note(f"note: {result.choice.label} skipped: {result.skipped}")
        elif result.unconverged_domains:
            note(
                f"note: {result.choice.label} did not converge cleanly at some points of "
                f"{', '.join(result.unconverged_domains)}"
            )
    if args.output is not None:
        from app.studies.quality_figure import figure

        write_png(args.output, figure(domains, study))
        note(f"wrote {args.output}")
    note(f"quality study in {time.perf_counter() - started:.1f} s")
    return EXIT_OK

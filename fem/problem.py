"""The coupled-consolidation problem: mesh, material, initial state, boundary conditions, loading history.

Every boundary value is ``scale * A(t)``, with one piecewise-linear loading amplitude A(t) given by the phases of
the history (A(0) = 0). For the pressuremeter A is the cavity strain eps_c = u_a/a0 (tension-positive displacement,
outward) and the cavity wall has u_r = a0 A(t): equal displacement increments within a phase.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from constitutive import MaterialModel

from .mesh import Mesh, MeshError

__all__ = ["Geostatic", "Dirichlet", "BoundaryPressure", "Phase", "Problem", "ProblemError", "pressuremeter",
           "GAMMA_W"]

GAMMA_W = 9.81  # unit weight of water, kN/m3
DOFS = {"ur": 0, "uz": 1, "p": 2}


class ProblemError(ValueError):
    """Invalid problem data (names the field and the value)."""


@dataclass(frozen=True)
class Geostatic:
    """Uniform in-situ state: vertical effective stress sigma_v0 (kPa, compression positive), earth-pressure
    coefficient K0 (sigma'_r0 = sigma'_theta0 = K0 sigma'_v0) and hydrostatic pore pressure u0 (kPa). The strip is
    thin (a few cm) so the variation with depth is neglected (no body force)."""

    sigma_v0: float = 0.0
    K0: float = 1.0
    u0: float = 0.0

    def __post_init__(self):
        for name in ("sigma_v0", "K0", "u0"):
            if not np.isfinite(getattr(self, name)):
                raise ProblemError(f"initial state {name} = {getattr(self, name)} is not finite")
        if self.sigma_v0 < 0:
            raise ProblemError(f"initial state sigma_v0 = {self.sigma_v0} kPa must be >= 0 (compression positive)")
        if self.K0 < 0:
            raise ProblemError(f"initial state K0 = {self.K0} must be >= 0")

    def effective_stress(self, n):
        """Soil-convention Voigt effective stresses (n, 6): r -> 1, z -> 2 (vertical), theta -> 3."""
        s = np.zeros((n, 6))
        s[:, 0] = s[:, 2] = self.K0 * self.sigma_v0
        s[:, 1] = self.sigma_v0
        return s


@dataclass(frozen=True)
class Dirichlet:
    """Prescribed value ``scale * A(t)`` of dof ``dof`` ('ur', 'uz' in m, tension/outward positive; 'p' the excess
    pore pressure in kPa) on node set ``node_set``. scale = 0 fixes the dof (or drains the boundary for 'p')."""

    node_set: str
    dof: str
    scale: float = 0.0

    def __post_init__(self):
        if self.dof not in DOFS:
            raise ProblemError(f"Dirichlet dof = {self.dof!r} must be one of {list(DOFS)}")


@dataclass(frozen=True)
class BoundaryPressure:
    """Normal pressure ``scale * A(t)`` (kPa, positive pushing into the body) on the boundary edges of node set
    ``node_set`` (edges of cells whose two nodes are both in the set)."""

    node_set: str
    scale: float


@dataclass(frozen=True)
class Phase:
    """A loading phase: over ``duration`` seconds the amplitude goes linearly to ``amplitude`` in ``n_increments``
    time increments; with growth > 1 the increments grow geometrically (dt_(i+1) = growth dt_i, for dissipation)."""

    duration: float
    amplitude: float
    n_increments: int = 10
    growth: float = 1.0
    name: str = ""

    def __post_init__(self):
        if not (np.isfinite(self.duration) and self.duration > 0):
            raise ProblemError(f"phase {self.name!r}: duration = {self.duration} s must be positive (time step > 0)")
        if int(self.n_increments) < 1:
            raise ProblemError(f"phase {self.name!r}: n_increments = {self.n_increments} must be >= 1")
        if not (np.isfinite(self.growth) and self.growth > 0):
            raise ProblemError(f"phase {self.name!r}: growth = {self.growth} must be positive")
        if not np.isfinite(self.amplitude):
            raise ProblemError(f"phase {self.name!r}: amplitude = {self.amplitude} is not finite")

    def time_fractions(self):
        w = self.growth ** np.arange(int(self.n_increments))
        return np.concatenate([[0.0], np.cumsum(w) / w.sum()])


@dataclass
class Problem:
    """Biot coupled consolidation on an axisymmetric mesh (see fem.solver for the equations).

    mesh, material (a constitutive.MaterialModel, one point per element), initial (Geostatic), void_ratio0,
    permeability k (m/s, scalar or per cell), gamma_w (kN/m3), dirichlet and pressures (boundary conditions), history
    (phases), stabilization (polynomial pressure projection, tau = 1/(2 G_hg)), hourglass_scale c_hg (fixed input,
    default 0.05) and hourglass_modulus G_hg (kPa; None: the elastic shear modulus of the initial material tangent,
    per cell, computed once), monitor_radii (m; pore pressure histories at these radii at mid-height, like SBP
    pore-pressure cells), save_fields ('phases': end of each phase, 'all', 'none'), Newton controls: rtol,
    max_iterations, refresh_ratio (0, the default: full Newton with the material tangent; > 0: modified Newton, the
    factorization refreshed when an iteration reduces the residual by less than this factor; fem.Solver._newton),
    predictor ('extrapolate': the start of Newton in a step is extrapolated from the last steps' solutions (rate and
    its change, fem.Solver._increment), within a phase; 'tangent': the constrained dofs moved with the last
    factorized Jacobian; fem.Solver._newton), max_cuts (step halvings before ConvergenceError). Convergence: at
    every free dof |R_i| <= rtol * (sum of the absolute element contributions to dof i, floored at 1e-6 of the
    largest such sum of that field: the round-off level, fem.solver.SCALE_FLOOR).
    """

    mesh: Mesh
    material: MaterialModel
    initial: Geostatic = field(default_factory=Geostatic)
    void_ratio0: float | None = None
    permeability: float | np.ndarray = 1e-9
    gamma_w: float = GAMMA_W
    dirichlet: list = field(default_factory=list)
    pressures: list = field(default_factory=list)
    history: list = field(default_factory=list)
    stabilization: bool = True
    hourglass_scale: float = 0.05
    hourglass_modulus: float | None = None
    monitor_radii: tuple = ()
    save_fields: str = "phases"
    rtol: float = 1e-6
    max_iterations: int = 25
    refresh_ratio: float = 0.0
    predictor: str = "extrapolate"
    max_cuts: int = 10

    def __post_init__(self):
        self.validate()

    def validate(self):
        """Clear errors for bad input, before any solve."""
        if not isinstance(self.mesh, Mesh):
            raise ProblemError(f"mesh must be a fem.Mesh, got {type(self.mesh).__name__}")
        if not isinstance(self.material, MaterialModel):
            raise ProblemError(f"material must be a constitutive.MaterialModel, got {type(self.material).__name__}")
        k = np.asarray(self.permeability, dtype=float)
        if k.ndim not in (0, 1) or (k.ndim == 1 and k.shape[0] != self.mesh.n_cells):
            raise ProblemError(f"permeability must be a scalar or have one value per cell ({self.mesh.n_cells})")
        if not np.all(np.isfinite(k)) or np.any(k <= 0):
            raise ProblemError(f"permeability k = {k.ravel()[np.argmin(np.nan_to_num(k.ravel(), nan=-1))]} m/s must "
                               "be positive and finite")
        if not (self.gamma_w > 0):
            raise ProblemError(f"gamma_w = {self.gamma_w} kN/m3 must be positive")
        if not self.history:
            raise ProblemError("history has no phases")
        for ph in self.history:
            if not isinstance(ph, Phase):
                raise ProblemError(f"history entries must be fem.Phase, got {type(ph).__name__}")
        for bc in list(self.dirichlet) + list(self.pressures):
            try:
                self.mesh.node_set(bc.node_set)
            except MeshError as err:
                raise ProblemError(f"{type(bc).__name__}({bc.node_set!r}): {err}") from None
        for bc in self.pressures:
            if edges_of_set(self.mesh, bc.node_set).size == 0:
                raise ProblemError(f"BoundaryPressure({bc.node_set!r}): the set holds no boundary edge")
        if self.hourglass_scale < 0:
            raise ProblemError(f"hourglass_scale = {self.hourglass_scale} must be >= 0")
        if self.hourglass_modulus is not None and not self.hourglass_modulus > 0:
            raise ProblemError(f"hourglass_modulus = {self.hourglass_modulus} kPa must be positive")
        if not 0.0 <= self.refresh_ratio < 1.0:
            raise ProblemError(f"refresh_ratio = {self.refresh_ratio} must lie in [0, 1) (0: full Newton)")
        if self.predictor not in ("extrapolate", "tangent"):
            raise ProblemError(f"predictor = {self.predictor!r} must be 'extrapolate' or 'tangent'")
        if self.save_fields not in ("phases", "all", "none"):
            raise ProblemError(f"save_fields = {self.save_fields!r} must be 'phases', 'all' or 'none'")
        rmin, rmax = self.mesh.nodes[:, 0].min(), self.mesh.nodes[:, 0].max()
        for r in self.monitor_radii:
            if not rmin <= r <= rmax:
                raise ProblemError(f"monitor radius {r} m lies outside the mesh [{rmin:g}, {rmax:g}] m")

    def amplitude_table(self):
        """(times, amplitudes) of the increment ends, with phase index per increment."""
        t, a, phase = [0.0], [0.0], []
        for i, ph in enumerate(self.history):
            f = ph.time_fractions()[1:]
            t.extend((t[-1] + ph.duration * f).tolist())
            a0 = a[-1]
            a.extend((a0 + (ph.amplitude - a0) * f).tolist())
            phase.extend([i] * len(f))
        return np.array(t), np.array(a), np.array(phase)


def edges_of_set(mesh, name):
    """Boundary edges (n, 2) [node a, node b] in the counter-clockwise cell order whose nodes are all in the set."""
    ids = mesh.node_set(name)
    c = mesh.cells
    edges = np.stack([c, np.roll(c, -1, axis=1)], axis=-1).reshape(-1, 2)
    key = np.sort(edges, axis=1)
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    boundary = counts[inv.ravel()] == 1
    inset = np.isin(edges, ids).all(axis=1)
    return edges[boundary & inset]


def pressuremeter(material, *, mesh=None, a0=0.0415, sigma_v0=31.0, K0=0.9, u0=38.8, permeability=3.3e-9,
                  void_ratio0=2.0, strain_rate=0.00167, max_strain=0.10, n_increments=100, hold_time=0.0,
                  hold_increments=20, hold_growth=1.15, unload_strain=None, unload_increments=20, outer="fixed",
                  monitor_radii=(),
                  stabilization=False, **options):
    """A self-boring pressuremeter test (docs/reference.md section 5, Burswood defaults) as a Problem.

    Expansion at cavity strain rate ``strain_rate`` (1/s; 0.00167 = 0.167 %/s, 0.000185 = 0.0185 %/s) to
    ``max_strain`` in ``n_increments`` equal displacement increments; an optional holding phase (cavity wall held,
    pore pressure dissipates, steps growing geometrically by ``hold_growth``) of ``hold_time`` s in
    ``hold_increments`` increments and an unloading phase to
    ``unload_strain`` at the same rate. Top and bottom fixed vertically, cavity wall impermeable, outer boundary
    drained (u = u0) and either fixed radially (outer='fixed', the paper) or moved as the infinite-medium elastic
    field u_r(R) = u_a a0/R (outer='field'). Default mesh: 60 x 4 elements graded in ln r, R = 3200 a0 for 'fixed'
    (the cavity curve then changes < 0.5 % when R is doubled; a fixed boundary closer in adds a spurious far-field
    pore pressure ~ 1/R) and R = 200 a0 for 'field' (insensitive to R). Pressure stabilization is off by default
    here, as in ABAQUS CAX4RP: on this graded mesh the projection term of the large outer elements acts as a
    spurious drain (notes/fem.md); the checkerboard it would remove stays in the outer elements.
    """
    if outer not in ("fixed", "field"):
        raise ProblemError(f"outer = {outer!r} must be 'fixed' or 'field'")
    if mesh is None:
        mesh = Mesh.cavity_strip(a0=a0, outer_radius=(3200.0 if outer == "fixed" else 200.0) * a0)
    if not strain_rate > 0:
        raise ProblemError(f"strain_rate = {strain_rate} 1/s must be positive")
    R = mesh.nodes[mesh.node_set("outer"), 0].max()
    a = mesh.nodes[mesh.node_set("cavity"), 0].min()
    history = [Phase(max_strain / strain_rate, max_strain, n_increments, name="expansion")]
    if hold_time > 0:
        history.append(Phase(hold_time, max_strain, hold_increments, growth=hold_growth, name="holding"))
    if unload_strain is not None:
        history.append(Phase(abs(max_strain - unload_strain) / strain_rate, unload_strain, unload_increments,
                             name="unloading"))
    dirichlet = [Dirichlet("cavity", "ur", a), Dirichlet("outer", "ur", a * a / R if outer == "field" else 0.0),
                 Dirichlet("top", "uz"), Dirichlet("bottom", "uz"), Dirichlet("outer", "p")]
    return Problem(mesh, material, Geostatic(sigma_v0, K0, u0), void_ratio0=void_ratio0, permeability=permeability,
                   dirichlet=dirichlet, history=history, monitor_radii=tuple(monitor_radii),
                   stabilization=stabilization, **options)

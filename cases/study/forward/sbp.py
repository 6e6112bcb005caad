"""The self-boring pressuremeter forward model: one model class in the coupled FE cavity expansion of every SBP test
(``fem.pressuremeter``: CAX4RP-like elements, cavity wall displacement control, partial drainage) for one particle.

Signs and units: pressures are total radial stresses on the cavity wall, compression positive, kPa; the wall pore
pressure is the total pore pressure; cavity strain is u_a/a0 in % (small strain, as the FE). The site (in situ
state), the cavity strain rate of each test, the fixed parameter values and the FE discretization are arguments:
nothing is read from a case.

A test is either the flat ``sbp`` type (one expansion at its rate to :data:`MAX_CAVITY_STRAIN`) or a stage programme
(``cases.study.programme``, apparatus ``sbp``; its stage kinds: :mod:`cases.study.stages.pressuremeter`). Each stage
is one loading phase of the FE (:func:`stage_phases`), as its kind's ``fe_phase`` gives it. A stage's curves start at
the stage's first point (the previous stage's last): cavity pressure and pore pressure against cavity strain (%) or
against time since the stage start (s), as the stage's ``abscissa`` says; a record at zero cavity strain reads the in
situ total stress and pore pressure.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.optimize import brentq

import constitutive
import fem
from cases.study.programme import curve_key, split_key
from cases.study.stages.pressuremeter import MAX_CAVITY_STRAIN, SBP_QUANTITIES
from constitutive import physics_catalog
from constitutive.registry import build_model
from inference import ForwardModel

__all__ = ["SBPForward", "pressuremeter_problem", "stage_phases", "hold_growth", "FE_ARGUMENTS"]

#: parameters and switches of a model class that go to the FE rather than the material (the catalog's partial
#: drainage: ``coupled`` and the free ``permeability`` in m/s)
FE_ARGUMENTS = physics_catalog.COUPLED_FE_ARGUMENTS

def pressuremeter_problem(rate: float, preset, site: dict, void_ratio0: float, save_fields="none", history=None):
    """The fem.Problem of one SBP expansion at cavity strain rate ``rate`` (1/s) to :data:`MAX_CAVITY_STRAIN`, or of the
    loading ``history`` (fem.Phase list, amplitude = cavity strain: :func:`stage_phases`) when given.

    preset: the FE discretization (``radial_cells``, ``layers``, ``increments``, ``outer``, ``outer_radius_a0``);
    site: ``sigma_v0`` (kPa), ``K0``, ``u0`` (kPa), ``permeability`` (m/s), ``a0`` (probe radius, m); the material
    is a placeholder set per particle (``fem.Solver.solve(material=...)``)."""
    mesh = fem.Mesh.cavity_strip(a0=site["a0"], outer_radius=preset.outer_radius_a0 * site["a0"],
                                 n_radial=preset.radial_cells, n_vertical=preset.layers)
    placeholder = constitutive.LinearElastic(E=5000.0, nu=0.3)
    problem = fem.pressuremeter(placeholder, mesh=mesh, a0=site["a0"], sigma_v0=site["sigma_v0"], K0=site["K0"],
                                u0=site["u0"], permeability=site["permeability"], void_ratio0=void_ratio0,
                                strain_rate=rate, max_strain=MAX_CAVITY_STRAIN, n_increments=preset.increments,
                                outer=preset.outer, save_fields=save_fields)
    return problem if history is None else replace(problem, history=list(history))


def hold_growth(n: int, ratio: float) -> float:
    """Growth factor g of ``n`` time steps whose sum is ``ratio`` times the first: (g^n - 1)/(g - 1) = ratio (1:
    equal steps, when ``ratio`` <= n)."""
    if n < 2 or ratio <= n:
        return 1.0
    return brentq(lambda g: np.expm1(n * np.log(g)) / (g - 1.0) - ratio, 1.0 + 1e-12, ratio ** (1.0 / (n - 1)),
                  xtol=1e-14, rtol=1e-14)


def stage_phases(stages, increments: int, abscissae=None) -> list:
    """The FE loading history of an SBP programme: one fem.Phase per stage (named after it; amplitude = cavity
    strain u_a/a0), from zero strain at t = 0.

    Each stage's phase is its kind's ``fe_phase`` (:mod:`cases.study.stages.pressuremeter`: strain phases in equal
    increments, at most ``increments`` per :data:`MAX_CAVITY_STRAIN`; a hold in ``increments`` time steps growing
    geometrically, :func:`hold_growth`; an unloading to a pressure without records left out).
    abscissae: {curve key: recorded abscissae (cavity strain %, or s since the stage start)} of the test."""
    recorded = {}
    for key, x in (abscissae or {}).items():
        recorded.setdefault(split_key(key)[1], []).append(np.asarray(x, dtype=float))
    one_stage = len(stages) == 1
    phases, strain = [], 0.0
    for stage in stages:
        x = np.concatenate(recorded.get(None if one_stage else stage.name, [np.zeros(0)]))
        phase = stage.procedure.fe_phase(stage, strain, increments, x)
        if phase is None:
            continue
        phases.append(fem.Phase(phase.duration, phase.cavity_strain, phase.increments,
                                growth=hold_growth(phase.increments, phase.growth_ratio), name=stage.name))
        strain = phase.cavity_strain
    return phases


class SBPForward(ForwardModel):
    """params -> {test: {curve: (abscissae, values kPa)}} from one FE solve per test; an
    ``inference.ForwardModel`` that takes one particle at a time (``batched = False``).

    preset: FE discretization; site: the in situ state of the tests (:func:`pressuremeter_problem`); rates: {test:
    cavity strain rate (1/s)} of the flat tests (one expansion to :data:`MAX_CAVITY_STRAIN`, curves against cavity
    strain %); programmes: {test: a stage programme (cases.study.programme.TestSpec, apparatus ``sbp``)}, its stages
    checked by :func:`cases.study.stages.sequence.check_sbp_stages`, curves :data:`SBP_QUANTITIES` of every stage under
    the keys of ``cases.study.programme.curve_key`` (``pore_pressure@hold2``) against the stage's abscissa (cavity
    strain %, or s since the stage start); abscissae: {test: {curve key: recorded abscissae}} of the programmes (they
    set a hold's first time step and an unloading to a pressure's end: :func:`stage_phases`); fixed: the model's
    parameter values not identified (merged under each particle's); model, switches: the model class
    (``constitutive.registry``); a switch or parameter of :data:`FE_ARGUMENTS` goes to the FE (``permeability``: k in
    m/s, replacing the site's); void_ratio0: the initial void ratio of the FE (default ``fixed["e0"]``); curves: of the
    flat tests, "cavity_pressure" (total, kPa) and optionally "pore_pressure" (total pore pressure at the wall, kPa).

    ``forward(params)`` and :meth:`simulate_batch` solve one particle (they raise fem.ConvergenceError /
    IntegrationError on failure). Picklable: the FE solvers
    are built lazily in each process (or MPI rank) on first use and reused after.
    """

    batched = False

    def __init__(self, preset, site: dict, rates: dict, fixed: dict, model="ANICREEP", switches=None,
                 void_ratio0=None, curves=("cavity_pressure",), programmes=None, abscissae=None):
        self.preset = preset
        self.rates = dict(rates)
        self.site = dict(site)
        self.fixed = dict(fixed)
        self.model = model
        self.switches = dict(switches or {})
        self.void_ratio0 = self.fixed["e0"] if void_ratio0 is None else float(void_ratio0)
        self.curves = tuple(curves)
        self.programmes = dict(programmes or {})
        abscissae = abscissae or {}
        #: {test: fem.Phase list} of the programmes (:func:`stage_phases`)
        self.histories = {name: stage_phases(spec.stages, preset.increments, abscissae.get(name))
                          for name, spec in self.programmes.items()}
        self._solvers = None

    def __getstate__(self):
        return {**self.__dict__, "_solvers": None}

    def material(self, params):
        """The material of one particle; the FE's vertical axis is z (Voigt 2)."""
        values = {k: v for k, v in {**self.fixed, **params}.items() if k not in FE_ARGUMENTS}
        switches = {k: v for k, v in self.switches.items() if k not in FE_ARGUMENTS}
        return build_model(self.model, values, switches, vertical_axis=2)

    def compile_material(self, params):
        """Run one material update at ``params`` so the compiled kernel exists in this process before a process pool
        forks (workers inherit it instead of each compiling it again)."""
        model = self.material(params)
        stress = fem.Geostatic(self.site["sigma_v0"], self.site["K0"], self.site["u0"]).effective_stress(1)
        model.update(stress, model.initial_state(stress), np.zeros((1, 6)), 1.0)

    def problems(self, save_fields="none") -> dict:
        """{test: fem.Problem}: the flat tests' expansions, then the programmes' stage histories."""
        flat = {name: pressuremeter_problem(rate, self.preset, self.site, self.void_ratio0, save_fields)
                for name, rate in self.rates.items()}
        staged = {name: pressuremeter_problem(self.programmes[name].stages[0].strain_rate, self.preset, self.site,
                                              self.void_ratio0, save_fields, history)
                  for name, history in self.histories.items()}
        return {**flat, **staged}

    def solvers(self, save_fields="none"):
        """{test: fem.Solver}; the ones without saved fields are built once per process and reused."""
        if save_fields == "none" and self._solvers is not None:
            return self._solvers
        built = {name: fem.Solver(problem) for name, problem in self.problems(save_fields).items()}
        if save_fields == "none":
            self._solvers = built
        return built

    def results(self, params, save_fields="none") -> dict:
        """{test: fem.Result} for one particle (raises fem.ConvergenceError / IntegrationError on failure)."""
        material = self.material(params)
        if "permeability" in params:
            k = params["permeability"]
            return {name: s.solve(material=material, permeability=k)
                    for name, s in self.solvers(save_fields).items()}
        return {name: s.solve(material=material) for name, s in self.solvers(save_fields).items()}

    def curves_of(self, results) -> dict:
        """{test: {curve: (abscissae, values)}} of the FE results (see the class docstring)."""
        out = {}
        for name, res in results.items():
            if name in self.programmes:
                out[name] = self.stage_curves(name, res)
                continue
            strain = 100.0 * res.cavity_strain
            sim = {"cavity_pressure": (strain, res.cavity_pressure),
                   "pore_pressure": (strain, res.cavity_pore_pressure)}
            out[name] = {c: sim[c] for c in self.curves}
        return out

    def stage_curves(self, name, res) -> dict:
        """The curves of each stage of programme ``name`` from its FE result: the stage's rows, from its first point
        (the previous stage's last) to its end, against the stage's abscissa."""
        spec = self.programmes[name]
        values = {"cavity_pressure": res.cavity_pressure, "pore_pressure": res.cavity_pore_pressure}
        out, first = {}, 0
        for phase in self.histories[name]:
            rows = slice(first, first + phase.n_increments + 1)
            first += phase.n_increments
            stage = spec.stage(phase.name)
            x = (res.time[rows] - res.time[rows.start] if stage.abscissa == "time"
                 else 100.0 * res.cavity_strain[rows])
            for q in SBP_QUANTITIES:
                out[curve_key(spec, q, stage)] = (x, values[q][rows])
        return out

    def __call__(self, params) -> dict:
        return self.curves_of(self.results(params))

    def simulate_batch(self, names, values) -> tuple:
        """The protocol of :class:`inference.ForwardModel` for one particle: ``values`` (1, k)."""
        (row,) = np.atleast_2d(values)
        return [self({n: float(v) for n, v in zip(names, row)})], [None]

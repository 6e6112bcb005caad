"""The self-boring pressuremeter forward model: one model class in the coupled FE cavity expansion of every SBP test
(``fem.pressuremeter``: CAX4RP-like elements, cavity wall displacement control, partial drainage) for one particle.

Signs and units: pressures are total radial stresses on the cavity wall, compression positive, kPa; the wall pore
pressure is the total pore pressure; cavity strain is u_a/a0 in % (small strain, as the FE). The site (in situ
state), the cavity strain rate of each test, the fixed parameter values and the FE discretization are arguments:
nothing is read from a case.
"""
from __future__ import annotations

import numpy as np

import constitutive
import fem
from constitutive import physics_catalog
from constitutive.registry import build_model, class_name
from inference import ForwardModelError

__all__ = ["SBPForward", "pressuremeter_problem", "MAX_STRAIN", "FE_ARGUMENTS"]

#: largest cavity strain of the expansion (u_a/a0, -)
MAX_STRAIN = 0.10
#: parameters and switches of a model class that go to the FE rather than the material (the catalog's partial
#: drainage: ``coupled`` and the free ``permeability`` in m/s)
FE_ARGUMENTS = tuple(physics_catalog.candidate("partial drainage").enrichment.forward_arguments)


def pressuremeter_problem(rate: float, preset, site: dict, void_ratio0: float, save_fields="none"):
    """The fem.Problem of one SBP expansion at cavity strain rate ``rate`` (1/s) to :data:`MAX_STRAIN`.

    preset: the FE discretization (``radial_cells``, ``layers``, ``increments``, ``outer``, ``outer_radius_a0``);
    site: ``sigma_v0`` (kPa), ``K0``, ``u0`` (kPa), ``permeability`` (m/s), ``a0`` (probe radius, m); the material
    is a placeholder set per particle (``fem.Solver.solve(material=...)``)."""
    mesh = fem.Mesh.cavity_strip(a0=site["a0"], outer_radius=preset.outer_radius_a0 * site["a0"],
                                 n_radial=preset.radial_cells, n_vertical=preset.layers)
    placeholder = constitutive.LinearElastic(E=5000.0, nu=0.3)
    return fem.pressuremeter(placeholder, mesh=mesh, a0=site["a0"], sigma_v0=site["sigma_v0"], K0=site["K0"],
                             u0=site["u0"], permeability=site["permeability"], void_ratio0=void_ratio0,
                             strain_rate=rate, max_strain=MAX_STRAIN, n_increments=preset.increments,
                             outer=preset.outer, save_fields=save_fields)


class SBPForward:
    """params -> {test: {curve: (cavity strain %, values kPa)}} from one FE solve per test.

    preset: FE discretization; site: the in situ state of the tests (:func:`pressuremeter_problem`); rates:
    {test: cavity strain rate (1/s)}; fixed: the model's parameter values not
    identified (merged under each particle's); model, switches: the model class (``constitutive.registry``); a
    switch or parameter of :data:`FE_ARGUMENTS` goes to the FE (``permeability``: k in m/s, replacing the site's);
    void_ratio0: the initial void ratio of the FE (default ``fixed["e0"]``); curves: "cavity_pressure" (total, kPa)
    and optionally "pore_pressure" (total pore pressure at the wall, kPa).

    ``forward(params)`` is one particle (raises fem.ConvergenceError / IntegrationError on failure);
    :meth:`batch` is the batched form (a ForwardModelError in place of a failed particle). Picklable: the FE solvers
    are built lazily in each process (or MPI rank) on first use and reused after.
    """

    def __init__(self, preset, site: dict, rates: dict, fixed: dict, model="ANICREEP", switches=None,
                 void_ratio0=None, curves=("cavity_pressure",)):
        self.preset = preset
        self.rates = dict(rates)
        self.site = dict(site)
        self.fixed = dict(fixed)
        self.model = model
        self.switches = dict(switches or {})
        self.void_ratio0 = self.fixed["e0"] if void_ratio0 is None else float(void_ratio0)
        self.curves = tuple(curves)
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

    def solvers(self, save_fields="none"):
        """{test: fem.Solver}; the ones without saved fields are built once per process and reused."""
        if save_fields == "none" and self._solvers is not None:
            return self._solvers
        built = {name: fem.Solver(pressuremeter_problem(rate, self.preset, self.site, self.void_ratio0, save_fields))
                 for name, rate in self.rates.items()}
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
        out = {}
        for name, res in results.items():
            strain = 100.0 * res.cavity_strain
            sim = {"cavity_pressure": (strain, res.cavity_pressure),
                   "pore_pressure": (strain, res.cavity_pore_pressure)}
            out[name] = {c: sim[c] for c in self.curves}
        return out

    def __call__(self, params) -> dict:
        return self.curves_of(self.results(params))

    def batch(self, batch) -> list:
        """A list of parameter dicts -> a list of curves, a ForwardModelError for a failed particle."""
        out = []
        for params in batch:
            try:
                out.append(self(params))
            except Exception as exc:  # noqa: BLE001 - an FE failure is this particle's zero likelihood
                out.append(ForwardModelError(f"{class_name(self.switches, self.model)}: {type(exc).__name__}: {exc}"))
        return out

"""The batched laboratory forward model: a model class and a programme of laboratory tests -> the curves of every
test for a batch of parameter sets, vectorized over particles x tests through ``constitutive.labtests``.

Tests that one driver call can serve together (same type, drainage, recorded abscissae, substeps, K0 and, for a
rate-dependent model, strain rate) run as ONE call over (tests x particles) material points with the parameters
repeated per test; each point is integrated on its own, so a test's curves are the same bits whatever it is batched
with. Laboratory test types: ``triaxial`` (``labtests.drained_triaxial`` / ``undrained_triaxial``; SIMSAND through
its own triaxial integrator when the start is isotropic), ``oedometer_crs`` (``labtests.oedometer_crs``) and
``oedometer_creep`` (``labtests.oedometer_loading``, interpolated to the recorded times). The tests written as stage
programmes (``TestSpec.staged``: apparatus triaxial or oedometer) run through
:func:`cases.study.forward.lab_staged.simulate_programmes` (one driver call per round of stages of the same kind over
the programmes of an apparatus, each point taking the steps it takes alone), their curves keyed
``<quantity>@<stage name>`` (the quantity alone for a one-stage programme) at the records of each stage.

Simulated quantities (units kPa, %, -): q, p (mean effective stress), excess_pore_pressure, volumetric_strain (%),
void_ratio, axial_stress, radial_stress (effective), axial_strain (%), and for the covariates stress_ratio (q/p'),
mean_stress (p') and, for a model with a critical state line e_c(p') (SIMSAND), initial_state_parameter
psi_0 = e_0 - e_c(p'_0) (constant along the curve). A study's curve names ``e`` and ``u`` are the void ratio and the
excess pore pressure (:data:`ALIASES`).
"""
from __future__ import annotations

import math

import numpy as np

from cases.study.forward.lab_stage_steps import FALLBACK_STRAIN_STEP
from cases.study.forward.lab_staged import simulate_programmes
from cases.study.programme import split_key
from constitutive import ParameterError, labtests
from constitutive.registry import build_model, class_name
from inference import ForwardModel, ForwardModelError

__all__ = ["LabForward", "ALIASES", "COVARIATE_CURVES", "LAB_TYPES", "programme_abscissae"]

LAB_TYPES = ("triaxial", "oedometer_crs", "oedometer_creep")
#: curve names of a study's records that are not the simulated quantity's name
ALIASES = {"e": "void_ratio", "u": "excess_pore_pressure"}
#: the simulated quantities besides the calibrated curves that the covariates use
COVARIATE_CURVES = ("stress_ratio", "mean_stress", "initial_state_parameter")


def substeps(spec, strains, max_step):
    """Driver steps per recorded interval: the test's ``substeps``, else enough for strain steps <= ``max_step``
    (None: one step per record, the model's own integrator controls its substeps)."""
    if spec.substeps is not None:
        return spec.substeps
    if max_step is None:
        return 1
    step = np.max(np.abs(np.diff(np.concatenate([[0.0], strains]))))
    return max(1, int(math.ceil(step / max_step - 1e-9)))


def creep_weights(spec, times):
    """Indices and weights that interpolate an ``oedometer_loading`` record (n_stages * n_times log-spaced hold
    times) to the recorded ``times``, linearly in the logarithm of the time since the stage start (exact at the
    driver's times)."""
    stage, local = spec.hold_stage(times)
    hold = np.log(np.geomspace(spec.load_time, spec.stage_duration, spec.n_times))
    pos = np.clip(np.searchsorted(hold, np.log(local)) - 1, 0, spec.n_times - 2)
    w = np.clip((np.log(local) - hold[pos]) / (hold[pos + 1] - hold[pos]), 0.0, 1.0)
    i0 = stage * spec.n_times + pos
    return i0, i0 + 1, w


def programme_abscissae(spec, recorded: dict) -> dict:
    """{curve key: abscissae in simulate_programme's units} of a programme's records {curve key: x as recorded}:
    axial strains from % to fractions, times (s) and stresses (kPa) as they are."""
    stages = {s.name: s for s in spec.stages}
    out = {}
    for key, x in recorded.items():
        stage = split_key(key)[1] or spec.stages[0].name
        x = np.asarray(x, dtype=float)
        out[key] = x / 100.0 if stages[stage].abscissa == "axial_strain" else x
    return out


def _driver(specs, model, e0, x, n_sub, m):
    """Raw driver curves over (len(specs) x m) points, test-major, for tests that share one call."""
    spec = specs[0]
    rate = {} if spec.strain_rate is None else {"strain_rate": spec.strain_rate}
    if spec.type == "triaxial":
        driver = labtests.drained_triaxial if spec.drainage == "drained" else labtests.undrained_triaxial
        p0 = np.repeat([s.start_p for s in specs], m)
        return driver(model, e0, p0, x, k0=spec.k0, substeps=n_sub, on_failure="nan", **rate)
    if spec.type == "oedometer_crs":
        sigma_v0 = np.repeat([s.sigma_v0 for s in specs], m)
        return labtests.oedometer_crs(model, e0, sigma_v0, x, spec.strain_rate, k0=spec.K0,
                                      substeps=n_sub, on_failure="nan")
    raw = labtests.oedometer_loading(model, e0, spec.sigma_v0, list(spec.stage_stress), spec.stage_duration,
                                     n_times=spec.n_times, load_time=spec.load_time, k0=spec.K0, on_failure="nan")
    i0, i1, w = creep_weights(spec, x)
    return {k: (v if k == "failed" else v[:, i0] * (1.0 - w) + v[:, i1] * w) for k, v in raw.items()}


def _quantities(c, rows):
    """The reported quantities of one test (rows of a driver result)."""
    q, p = c["q"][rows], c["p"][rows]
    return {"q": q, "p": p, "excess_pore_pressure": c["excess_pore_pressure"][rows],
            "volumetric_strain": 100.0 * c["volumetric_strain"][rows], "void_ratio": c["e"][rows],
            "axial_stress": c["axial_stress"][rows], "radial_stress": c["radial_stress"][rows],
            "axial_strain": 100.0 * c["axial_strain"][rows], "stress_ratio": q / p, "mean_stress": p}


class LabForward(ForwardModel):
    """Batched forward model (``inference.ForwardModel``) of laboratory tests for one model class.

    model: a name of ``cases.study.models.MODELS``; switches: its switches; fixed: parameter values not identified
    (merged under each particle's); tests: TestSpec list (laboratory types and programmes); abscissae: {test: the
    recorded axial strains (-, signed) or times (s)}, in the drivers' units, and for a programme {curve key: the stage's
    recorded abscissae as recorded (axial strain in %, time since the stage start in s, p' or sigma'_v in kPa)} with
    each stage's ``abscissa`` set (``cases.study.reading.stage_records.recorded_programme``); curves: {test: the
    recorded curve names}; max_strain_step: see :func:`substeps`; refinement: the strain steps are this many times finer
    (1: the calibration's; the diagnosis measures the discretisation error with 2); e0_parameter: the void ratio is the
    model parameter ``e0`` (else each test's ``e0``); grid: None (simulate at the recorded abscissae; results at the
    records) or axial strains in % shared by every (triaxial) test, simulated from 0 and returned as (grid %, values)
    with the initial state first for the likelihood to interpolate to the records (the grid must reach the largest
    recorded strain); not for programmes.

    Call: a list of parameter dicts -> a list of {test: {curve: values}} (the recorded curves and the covariate
    quantities), a ForwardModelError naming the failed tests in place of a failed particle. :meth:`simulate_batch`
    is the likelihood's protocol (the whole batch as arrays). Both raise a ForwardModelError (the class and the
    model's message) when the model refuses the values of the batch.
    """

    def __init__(self, model, tests, abscissae, curves, fixed, switches=None, *, max_strain_step=None,
                 e0_parameter=False, grid=None, refinement=1):
        self.model = model
        self.switches = dict(switches or {})
        self.fixed = dict(fixed)
        self.tests = list(tests)
        self.curves = {t.name: tuple(curves[t.name]) for t in self.tests}
        self.max_strain_step = None if max_strain_step is None else max_strain_step / refinement
        #: the programmes' largest strain increment: the model's own unless refined
        self.staged_strain_step = None if refinement == 1 else (max_strain_step or FALLBACK_STRAIN_STEP) / refinement
        self.e0_parameter = e0_parameter
        self.label = class_name(self.switches, model)
        if grid is None:
            self.x = {t.name: programme_abscissae(t, abscissae[t.name]) if t.staged
                      else np.asarray(abscissae[t.name], dtype=float) for t in self.tests}
            self.start = None
        else:
            grid = np.unique(np.asarray(grid, dtype=float))
            for t in self.tests:
                if t.staged:
                    raise ValueError(f"a simulation grid serves flat triaxial tests only, not the programme {t.name}")
                top = 100.0 * np.max(np.abs(abscissae[t.name]))
                if t.type != "triaxial" or grid.max() < top:
                    raise ValueError(f"simulation grid ends at {grid.max():g} % before the largest recorded strain "
                                     f"{top:g} % of {t.name}" if t.type == "triaxial" else
                                     f"a simulation grid serves triaxial tests only, not {t.name} ({t.type})")
            self.x = {t.name: grid[grid > 0] / 100.0 for t in self.tests}
            self.start = np.concatenate([[0.0], grid[grid > 0]])
        self.groups = {}
        for t in self.tests:
            self.groups.setdefault(self._group_key(t), []).append(t)

    def _group_key(self, t):
        x = self.x[t.name]
        if t.staged:
            return (None,)  # every programme in one call (no test name is None)
        if t.type == "oedometer_creep":
            return (t.name,)
        n_sub = substeps(t, x, self.max_strain_step)
        return (t.type, t.drainage, tuple(x), n_sub, t.k0 if t.type == "triaxial" else t.K0, t.strain_rate)

    def particle_values(self, params: dict) -> tuple:
        """({parameter: (m,) array} of the fixed values and ``params``, m)."""
        m = int(np.size(next(iter(params.values())))) if params else 1
        values = {k: np.broadcast_to(np.asarray(v, dtype=float), (m,)).copy()
                  for k, v in {**self.fixed, **params}.items() if k != "sigma_eps"}
        return values, m

    def simulate(self, params: dict) -> tuple:
        """params {name: (m,) array} -> ({test: {quantity: (m, n)}} at the simulated abscissae, {test: failed (m,)}).
        Raises ParameterError/ValueError when the model refuses the values."""
        return self._simulate(params)[:2]

    def _refused(self, params: dict) -> tuple:
        """:meth:`_simulate`, a ForwardModelError (the class and the model's message) when the model refuses the
        values."""
        try:
            return self._simulate(params)
        except (ParameterError, ValueError) as exc:
            raise ForwardModelError(f"{self.label}: {exc}") from exc

    def _simulate(self, params: dict) -> tuple:
        """:meth:`simulate` and {test: the reason each particle failed ("" where it did not or none is known)}."""
        values, m = self.particle_values(params)
        rate_dependent = getattr(build_model(self.model, {k: v[:1] for k, v in values.items()}, self.switches),
                                 "rate_dependent", True)
        calls = {}
        for key, group in self.groups.items():
            if not rate_dependent and len(key) > 1:
                key = key[:-1]  # the strain rate only sets the time of a rate-independent model
            calls.setdefault(key, []).extend(group)
        curves, failed, why = {}, {}, {}
        for specs in calls.values():
            if specs[0].staged:  # the programmes share their driver calls (simulate_programmes)
                model = build_model(self.model, values, self.switches)
                results = simulate_programmes(model, specs, [self.x[s.name] for s in specs], m,
                                              e0=values["e0"] if self.e0_parameter else None,
                                              strain_step=self.staged_strain_step)
                for spec, (curve, bad, reason) in zip(specs, results):
                    curves[spec.name], failed[spec.name], why[spec.name] = curve, bad, reason
                continue
            k = len(specs)
            model = build_model(self.model, {n: np.tile(v, k) for n, v in values.items()}, self.switches)
            e0 = (np.tile(values["e0"], k) if self.e0_parameter else np.repeat([s.e0 for s in specs], m))
            x = self.x[specs[0].name]
            c = _driver(specs, model, e0, x, substeps(specs[0], x, self.max_strain_step), m)
            for j, spec in enumerate(specs):
                rows = slice(j * m, (j + 1) * m)
                out = _quantities(c, rows)
                if hasattr(model, "critical_void_ratio"):
                    psi0 = e0[rows] - model.critical_void_ratio(spec.start_p)[rows]
                    out["initial_state_parameter"] = np.broadcast_to(psi0[:, None], out["q"].shape)
                curves[spec.name] = out
                failed[spec.name] = c["failed"][rows] | ~np.all(np.isfinite(out["q"]), axis=1)
                why[spec.name] = [""] * m
        return curves, failed, why

    def _start_values(self, spec, e0, quantity):
        """The initial state of a triaxial test (the grid's first point)."""
        q0, p0 = spec.start_q, spec.start_p
        return {"q": q0, "p": p0, "mean_stress": p0, "stress_ratio": q0 / p0, "void_ratio": e0,
                "excess_pore_pressure": 0.0, "volumetric_strain": 0.0, "axial_strain": 0.0,
                "axial_stress": p0 + 2.0 * q0 / 3.0, "radial_stress": p0 - q0 / 3.0}.get(quantity)

    def _on_grid(self, spec, name, values, e0):
        """(grid from 0, values with the initial state first) of one quantity (m, n) of a test."""
        if name == "initial_state_parameter":
            start = values[:, :1]
        else:
            start = np.broadcast_to(np.reshape(self._start_values(spec, e0, ALIASES.get(name, name)), (-1, 1)),
                                    (len(values), 1))
        return self.start, np.concatenate([start, values], axis=1)

    def arrays(self, curves, values, names=None) -> dict:
        """{test: {curve: (m, n) at the records, or (grid, (m, n + 1))}} of the curves ``names`` (default: the
        recorded ones plus the covariate quantities) from :meth:`simulate`'s ``curves`` at the parameter
        ``values``."""
        out = {}
        for t in self.tests:
            if t.staged:  # the recorded curves, by curve key
                out[t.name] = {c: curves[t.name][c] for c in self.curves[t.name]}
                continue
            wanted = self.curves[t.name] + COVARIATE_CURVES if names is None else names(t)
            e0 = values["e0"] if self.e0_parameter else t.e0
            sim = {c: curves[t.name][ALIASES.get(c, c)] for c in wanted if ALIASES.get(c, c) in curves[t.name]}
            out[t.name] = sim if self.start is None else {c: self._on_grid(t, c, v, e0) for c, v in sim.items()}
        return out

    def failure(self, failed, why, i):
        """The reason particle i failed (the tests, with the first reason known), or None."""
        bad = [t.name for t in self.tests if failed[t.name][i]]
        reasons = [why[t][i] for t in bad if why[t][i]]
        return (f"{self.label}: integration failed in test(s) {bad}" + (f" ({reasons[0]})" if reasons else "")
                if bad else None)

    def __call__(self, batch):
        names = list(batch[0])
        params = {n: np.array([p[n] for p in batch], dtype=float) for n in names}
        curves, failed, why = self._refused(params)
        values, _ = self.particle_values(params)
        table = self.arrays(curves, values)
        out = []
        for i in range(len(batch)):
            reason = self.failure(failed, why, i)
            out.append(ForwardModelError(reason) if reason else
                       {t: {c: ((v[0], v[1][i]) if isinstance(v, tuple) else v[i]) for c, v in cs.items()}
                        for t, cs in table.items()})
        return out

    def simulate_batch(self, names, values):
        """The protocol of :class:`inference.ForwardModel`: free parameter ``names`` and their ``values`` (m, k) ->
        ({test: {curve: (m, n) or (grid, (m, n + 1))}}, [None or a ForwardModelError naming the failed tests per
        particle])."""
        values = np.asarray(values, dtype=float)
        params = {n: values[:, k] for k, n in enumerate(names) if n != "sigma_eps"}
        curves, failed, why = self._refused(params)
        full, m = self.particle_values(params)
        table = self.arrays(curves, full, names=lambda t: self.curves[t.name])
        reasons = [self.failure(failed, why, i) for i in range(m)]
        return table, [None if r is None else ForwardModelError(r) for r in reasons]

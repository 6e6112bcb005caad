"""The soil side of the calibrate -> diagnose loop (``inference.diagnosis.run_loop``): a problem that calibrates a
model class on request, gives the base class's per-point covariates and the candidate physics of
``constitutive.physics_catalog``, and writes the run directory.

:class:`LoopProblem` holds what every soil study shares (class names, priors, one class's calibration and its
record, the enriched classes of ``physics_catalog.enriched_settings``); a study supplies its forward model per class,
its covariates and its figures (``cases.study.loop.study_problem.StudyProblem`` for a study file). :func:`run_loop`
runs the loop in memory, then writes DIR/summary.json etc. of each class (the base class in DIR/<base_dir>, enriched
ones in DIR/enriched_<candidate>/), DIR/diagnosis_input.json/.npz, DIR/diagnosis.json/.md, DIR/diagnosis.png and
DIR/loop.json. After a confirmed enrichment the loop steps on (``inference.diagnosis.run_loop``, step 6): the
confirmed class becomes the base (:meth:`LoopProblem.adopt`), and step k's classes and diagnosis files are written in
DIR/step_<k>/; DIR/chain.md and DIR/chain.png show the chain, the final class's fit beside the first base's.
"""
from __future__ import annotations

import json
import pickle
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

import inference
from cases.study import runner
from cases.study.loop.evidence import refined_evidence
from cases.study.outputs.calibration_warnings import calibration_warnings
from cases.study.outputs.figures.canvas import FigureQueue, draw
from cases.study.programme import split_key
from cases.study.reading.schema import Settings
from constitutive import physics_catalog
from constitutive.registry import class_name, conventions, enrichment_family, model_spec
from inference import diagnosis
from inference.diagnosis import ModelClass
from inference.discrepancy import where_it_lies
from inference.priors import Bound

__all__ = ["LoopProblem", "run_loop", "CASE", "LOG_BAYES_THRESHOLD", "DECISION_RULE"]

CASE = "calibrate"
#: ln B that confirms an enrichment in a soil study's loop (and the margin by which it must lead the others),
#: calibrated on the negative controls of the independent generator's programmes (notes/independent-diagnosis.md):
#: set above +11.4, the largest control value of the first seed, and below the smallest confirmed effect (+24.2, a
#: CRS destructuration). A later CIU control's swelling class reached +26.7 (the generator's model and the drivers'
#: discretization differ from the calibrated one): the located-misfit check (rank.MISFIT_REDUCTION) refused it
LOG_BAYES_THRESHOLD = 20.0
#: ln B by which another convention of the base model (``constitutive.registry.conventions``) must beat the base's
#: own to replace it (Kass & Raftery's "strong": the same physics, so no Occam penalty separates them)
CONVENTION_LOG_BAYES = 3.0
#: ln B by which a confirmed enrichment must beat the model-form class (the base plus a smooth discrepancy per curve):
#: 0, it must explain the records at least as well. Set on the independent generator's first seed (notes/precision.md):
#: a per-curve discrepancy absorbs much of some effects (IL destructuration: the enriched class only +0.6 above it at
#: +58.9 over the base; CRS viscosity +14.7), while no control's enriched class reached the base threshold, so a margin
#: above 0 bought no precision there and cost effects
MODEL_FORM_LOG_BAYES = 0.0
#: the decision rule of a soil study's loop (threshold and margin LOG_BAYES_THRESHOLD, MODEL_FORM_LOG_BAYES over the
#: model-form class), recorded in its directory's diagnosis_input.json so that ``python -m inference.diagnosis DIR``
#: reaches the loop's conclusion
DECISION_RULE = diagnosis.DecisionRule(threshold=LOG_BAYES_THRESHOLD, model_form_margin=MODEL_FORM_LOG_BAYES)


class LoopProblem:
    """A soil study as an ``inference.diagnosis.LoopProblem``.

    A subclass sets the base class (``model``, ``base_switches``, ``base_bounds``, ``base_log_uniform``, the error
    parameter's ``sigma_bounds`` and ``sigma_kind``, the forward model's ``forward_arguments``) and supplies
    :meth:`forward`, :meth:`map_curves`, :meth:`curve_covariates` and optionally :meth:`catalog_switches`,
    :meth:`also_enrich`, :meth:`executor`, :meth:`summary_extra`, :meth:`describe`, :meth:`outputs` and :meth:`plot`.
    :meth:`start` binds the loop's data and run (observations, run settings, directory, seed, class size, label); the
    loop then calls :meth:`candidates`, :meth:`calibrate` and :meth:`covariates`.
    """

    case = "case"
    model = "ANICREEP"
    base_switches: dict = {}
    base_bounds: dict = {}
    base_log_uniform: tuple = ()
    #: the arguments the forward model takes beyond the constitutive model's (physics_catalog.Enrichment.
    #: forward_arguments); none for laboratory specimens, the coupled FE's for a pressuremeter problem
    forward_arguments: tuple = ()
    sigma_bounds = {"sigma_eps": (0.002, 0.3)}
    sigma_kind = "uniform"
    #: inference.Constraint (or expressions) restricting the prior of the free parameters
    constraints: tuple = ()
    #: {group: [(test, curve), ...]} of the likelihood's error groups (Eq. (6g)); None: one sigma_eps
    error_groups = None
    #: {test: weight} of Eq. (6) (tests not named: 1)
    weights: dict = {}
    #: whether the programme shears a specimen (a triaxial shear stage, a pressuremeter expansion): where it does
    #: not, an enrichment's parameters that only shearing shows stay out of the prior
    #: (``physics_catalog.Enrichment.seen_in_shear``)
    shears = True
    #: {candidate: {parameter: (lower, upper, kind)}}: the study's priors of an enrichment's added parameters,
    #: replacing the catalog's (``cases.study.reading.enrichment_priors``)
    enrichment_priors: dict = {}
    #: where the base class is calibrated, relative to the loop's directory
    base_dir = "base"
    #: the candidates the stepwise discovery confirmed (:meth:`adopt`), their switches and the priors of their added
    #: parameters (none before it steps)
    adopted: tuple = ()
    adopted_switches: dict = {}
    adopted_bounds: dict = {}
    adopted_log_uniform: tuple = ()
    #: the fraction of a sampler stage's solves that may fail before a class's calibration stops (every class: base,
    #: model-form, enriched): a prior holds regions where the model cannot follow the programme's controls (M below
    #: the stress ratio of a K0 consolidation path; structure collapsing faster than it hardens under
    #: stress-controlled compression); those draws are zero-likelihood with their reason recorded
    #: (failed_solves.jsonl, and a warning of the class, :mod:`cases.study.outputs.calibration_warnings`). Only a
    #: stage where nearly every solve fails stops, with the last reasons: too few particles are left to stand for
    #: the posterior.
    failure_fraction = 0.9
    #: how a class's figures are drawn (:meth:`outputs`, :meth:`plot`): now, outside the loop; in the loop
    #: (:meth:`start`) kept in a ``FigureQueue`` that :func:`run_loop` draws at its end, side by side on the pool,
    #: with each class's posterior.nc (:meth:`finish_class`)
    figures = staticmethod(draw)

    # ---------------------------------------------------------------------------------------- what a study supplies
    def forward(self, switches):
        """Batched forward model (``inference.Likelihood(batch=True)``) of the class with ``switches``."""
        raise NotImplementedError

    def map_curves(self, params: dict, switches: dict) -> dict:
        """{test: {curve: values at the records or (x, y)}} of one parameter set, with the extra curves the
        covariates use (``stress_ratio``, ``mean_stress``)."""
        raise NotImplementedError

    def refined_curves(self, params: dict, switches: dict) -> dict | None:
        """:meth:`map_curves` with a discretisation twice as fine (None: the study has no finer one; the diagnosis
        then does not measure the discretisation error)."""
        return None

    def numerical_error(self, like, cls: ModelClass, switches: dict) -> list:
        """The discretisation error of the class ``cls`` at its mode: per curve, the RMS and the largest relative
        difference |U_fine - U| / |U_obs| between :meth:`refined_curves` and the calibrated discretisation at the
        records ([{test, curve, rms, max}]; [] when not measured or when the refined solve fails)."""
        params, _ = like.split(cls.extra["map_theta"])
        try:
            fine = self.refined_curves(params, switches)
            fine = None if fine is None else like.simulated_at_observations(fine)
        except Exception:  # noqa: BLE001 - no measurement: the diagnosis goes on without it
            fine = None
        if fine is None:
            return []
        out = []
        for t in like.observations:
            for c, curve in t.curves.items():
                used = like.masks[t.name, c]
                d = np.abs(fine[t.name, c] - cls.map_simulated[t.name, c])[used] / np.abs(curve.y[used])
                out.append({"test": t.name, "curve": c, "rms": float(np.sqrt(np.mean(d**2))), "max": float(d.max())})
        return out

    def curve_covariates(self, like, map_curves) -> dict:
        """Per-point covariates (``inference.diagnosis.screen``'s form) from the base class's MAP curves."""
        raise NotImplementedError

    def catalog_switches(self, switches: dict) -> dict:
        """The switches the catalog's ``present_when`` is compared with."""
        return switches

    def also_enrich(self, first_diagnosis: diagnosis.Diagnosis) -> list:
        """Further candidates (names, in this order) whose enriched class the loop calibrates after the best-ranked
        named one, from the first diagnosis; none by default."""
        return []

    def executor(self):
        return inference.SerialExecutor()

    def kernels(self, switches) -> list:
        """The compiled-kernel source files of the class with ``switches``, announced when cold; none by default."""
        return []

    def summary_extra(self, switches: dict) -> dict:
        return {}

    def describe(self, label: str, base_name: str) -> str:
        """The diagnosis report's line on the data and the base class."""
        return f"Base class {base_name}; catalog: constitutive.physics_catalog ({label})."

    def prior(self, bounds: dict, log_uniform) -> inference.Prior:
        """Uniform free parameters, then the error parameters (sigma_eps or sigma_eps_<group>), then the log-uniform
        ones (their order in theta); restricted by ``constraints``."""
        entries = [Bound(k, *map(float, v)) for k, v in bounds.items() if k not in log_uniform]
        entries += [Bound(k, *map(float, v), self.sigma_kind) for k, v in self.sigma_bounds.items()]
        entries += [Bound(k, *map(float, bounds[k]), "log-uniform") for k in log_uniform]
        return inference.Prior(entries, self.constraints)

    def make_likelihood(self, observations, switches, discrepancy=None) -> inference.Likelihood:
        """The likelihood of the class with ``switches``: Eqs. (3)-(6) with the study's weights and error groups
        (and a model-form ``discrepancy``, ``inference.Discrepancy``, when given)."""
        return inference.Likelihood(observations, self.forward(switches), weights=self.weights or None, batch=True,
                                    groups=self.error_groups, discrepancy=discrepancy)

    def discrepancy(self, observations) -> inference.Discrepancy:
        """The model-form discrepancy of the loop's model-form class: one amplitude per recorded quantity (q, p',
        the pore pressure, the void ratio, ...; a staged test's curves of one quantity share it), the defaults of
        ``inference.Discrepancy`` otherwise."""
        groups = {}
        for t in observations:
            for curve in t.curves:
                groups.setdefault(split_key(curve)[0], []).append((t.name, curve))
        return inference.Discrepancy(groups=groups)

    def outputs(self, run, seed, out, post, like, cls: dict, map_curves, summary: dict, switches: dict):
        """Figures and reports of one calibrated class with ``switches`` (after summary.json, whose content is
        ``summary``)."""

    def plot(self, path, like, classes: list, diag: diagnosis.Diagnosis, label: str):
        """The loop's figure (diagnosis.png); ``classes`` the [ModelClass], the base class first."""

    # ---------------------------------------------------------------------------------------- one class
    def calibrate_class(self, observations, name, switches, bounds, log_uniform, run, out, seed,
                        settings: Settings, discrepancy=None, **sampler) -> tuple:
        """Calibrate one model class in ``out`` (``discrepancy``: an ``inference.Discrepancy`` whose parameters join
        the prior, log-uniform; ``sampler``: further inference.tmcmc settings); returns (ModelClass, Posterior,
        Likelihood). A class whose ln Z cannot be refined at its mode (:meth:`refined_evidence` None) keeps the
        sampler's ln Z and is marked ``inference.diagnosis.NOT_REFINED``: it cannot confirm."""
        t0 = time.perf_counter()
        like = self.make_likelihood(observations, switches, discrepancy)
        if discrepancy is not None:
            bounds = {**bounds, **discrepancy.bounds(like.discrepancy_names)}
            log_uniform = tuple(log_uniform) + like.discrepancy_names
        prior = self.prior(bounds, log_uniform)
        self.calibrated[name] = (like, switches)
        runner.announce_compilation(self.kernels(switches), lambda: runner.evaluate_once(like, prior))
        post = runner.calibrate(like, prior, run, out, seed, settings.n_samples, executor=self.executor(),
                                max_steps=settings.max_steps, progress=False,
                                **{"max_failure_fraction": self.failure_fraction, **sampler})
        t1 = time.perf_counter()
        evidence = self.refined_evidence(like, prior, post, seed)
        t2 = time.perf_counter()
        cls, _ = self.finish_class(post, like, name, switches, run, out, seed, settings.predictive_draws,
                                   t2 - t0, evidence, prior)
        if evidence is None:   # the refinement was asked for and gave nothing: the sampler's ln Z alone, unchecked
            cls = replace(cls, evidence={"method": diagnosis.NOT_REFINED})
        # where the class's time went (s): the sampler, the refined evidence, the record and outputs (in the loop its
        # figures are kept and drawn at the end, :func:`run_loop`)
        cls.extra["phases_s"] = {"sampler": t1 - t0, "evidence": t2 - t1, "record_and_outputs":
                                 time.perf_counter() - t2}
        return cls, post, like

    def refined_evidence(self, like, prior, post, seed):
        """ln Z and MAP from the refined posterior mode (:func:`cases.study.loop.evidence.refined_evidence`), climbed
        also from the step's base mode (``base_mode``) where there is one, on the study's process pool."""
        return refined_evidence(like, prior, post, seed, getattr(self, "base_mode", None), self.executor)

    def finish_class(self, post, like, name, switches, run, out, seed, draws, wall_s, evidence=None,
                     prior=None, extra=None) -> tuple:
        """After one class's calibration: summary.json (with the class, its switches, ``wall_s``, the refined
        evidence, :meth:`refined_evidence`, and ``extra``), the class record (:meth:`class_record`, with the
        ``prior``'s ranges) and the study's outputs (in the loop its posterior.nc and figures are kept,
        :attr:`figures`). Returns (ModelClass, summary)."""
        summary = runner.write_summary(out, self.case, run, seed, post, like, extra={
            "model_class": name, "switches": switches, **self.summary_extra(switches), "calibration_wall_s": wall_s,
            **({"evidence": evidence.to_dict()} if evidence is not None else {}), **(extra or {})},
            later=getattr(self.figures, "keep", None))
        cls = self.class_record(post, like, name, switches, seed, draws, summary, evidence, prior)
        self.outputs(run, seed, out, post, like, cls.to_dict(), cls.extra["map_curves"], summary, switches)
        return cls, summary

    def class_record(self, post, like, name, switches, seed, draws, summary, evidence=None,
                     prior=None) -> ModelClass:
        """The class as the diagnosis reads it: MAP curves, ``draws`` posterior-sample curves for the predictive
        band (rows drawn with ``seed``); the MAP's raw curves in ``extra["map_curves"]``; the calibration's warnings
        (:mod:`cases.study.outputs.calibration_warnings`). With error groups, sigma_eps is each curve's sigma at the MAP
        (a list in the likelihood's curve order). With a refined ``evidence`` (``inference.mode_evidence``) its ln Z and
        mode are the class's log-evidence and MAP (TMCMC's ln Z is its ``sampler_log_evidence``, also in
        ``extra["log_evidence_tmcmc"]``), and J_g is taken there too, so that every column of the class's row is of
        one point; ``prior`` gives the ranges the diagnosis checks the mode against; a
        model-form class (a likelihood with a discrepancy) records where its discrepancy lies."""
        map_theta = post.map_theta if evidence is None else np.array(evidence.mode)
        params, sigma = like.split(map_theta)
        if isinstance(sigma, dict):
            sigma = [float(s) for s in like.curve_sigmas(map_theta)[0]]
        map_raw = self.map_curves(params, switches)
        rng = np.random.default_rng(seed)
        rows = rng.choice(len(post.samples), size=min(draws, len(post.samples)), replace=False)
        sample_sims, sample_sigma = diagnosis.simulate_samples(like, post.samples[rows])
        map_simulated = like.simulated_at_observations(map_raw)
        q = post.quantiles()
        return ModelClass(
            name=name, role="base", candidate=None,
            log_evidence=float(post.log_evidence if evidence is None else evidence.log_evidence),
            J_g=summary["J_g_at_map"] if evidence is None else like.goodness_of_fit(map_simulated),
            parameters={n: {"map": float(m), "mean": post.mean[n], "std": post.std[n], "q2.5": q[n][0],
                            "q97.5": q[n][2]} for n, m in zip(post.names, map_theta)},
            sigma_eps=sigma if isinstance(sigma, list) else float(sigma), map_simulated=map_simulated,
            sample_simulated=sample_sims, sample_sigma=sample_sigma, wall_s=summary["calibration_wall_s"],
            n_forward_solves=summary["n_forward_solves"] + (0 if evidence is None else evidence.n_solves),
            extra={"map_curves": map_raw, "map_theta": [float(v) for v in map_theta],
                   "log_evidence_tmcmc": float(post.log_evidence)},
            warnings=calibration_warnings(post, like, map_simulated, map_theta),
            sampler_log_evidence=None if evidence is None else float(post.log_evidence),
            evidence=None if evidence is None else evidence.to_dict(),
            priors={} if prior is None else {b.name: [b.lower, b.upper, b.kind] for b in prior.bounds},
            discrepancy=[] if like.discrepancy is None else where_it_lies(like, map_theta, simulated=map_simulated))

    # ---------------------------------------------------------------------------------------- the loop's protocol
    def start(self, observations, run, out, seed: int, settings: Settings, label: str):
        """Bind the loop's data and run: the classes are calibrated in ``out`` with ``seed`` and ``settings``."""
        self.observations, self.run, self.out = observations, run, Path(out)
        self.seed, self.settings, self.label = seed, settings, label
        self.likelihood, self.description, self.base_mode = None, "", None
        self.convention, self.conventions_compared, self.own_base = {}, [], None
        # the stepwise discovery: the confirmed candidates, their switches and the priors of their added parameters
        # (apart from the problem's own base, which a loop run again on this problem starts from), where the step's
        # classes go
        self.adopted, self.adopted_switches, self.class_root, self.calibrated = (), {}, self.out, {}
        self.adopted_bounds, self.adopted_log_uniform = {}, ()
        self.base_name = None
        self.figures = FigureQueue()
        if isinstance(self.executor(), inference.PoolExecutor):   # a background drawer takes what the loop leaves idle
            self.figures.start_drawing()

    def candidates(self) -> list:
        """The catalog for the base class (with the candidates :meth:`adopt` confirmed in it), an enrichment's added
        parameters with the priors its class is calibrated under (:meth:`enriched_priors`). An enrichment that needs
        forward-model arguments this problem's forward model does not take (:attr:`forward_arguments`: the coupled
        FE's permeability, where the specimens are material points) is unavailable, with the catalog's reason."""
        out = physics_catalog.signatures(self.catalog_switches({**self.base_switches, **self.adopted_switches}),
                                         self.model)
        out = [{**c, "enrichment": None, "unavailable": physics_catalog.candidate(c["name"]).unavailable}
               if c["enrichment"] is not None and not set(c["enrichment"]["forward_arguments"]) <= set(
                   self.forward_arguments) else c for c in out]
        for c in out:
            if c["enrichment"] is not None and c["name"] in self.enrichment_priors:
                bounds, log_uniform = self.enriched_priors(c["name"], c["enrichment"]["parameters"],
                                                           c["enrichment"]["log_uniform"])
                c["enrichment"].update(parameters={k: list(v) for k, v in bounds.items()},
                                       log_uniform=list(log_uniform))
        return out

    def enriched_priors(self, candidate: str, bounds: dict, log_uniform) -> tuple:
        """(bounds, log-uniform names) with the study's priors of ``candidate``'s added parameters
        (:attr:`enrichment_priors`) in place of the catalog's."""
        own = self.enrichment_priors.get(candidate, {})
        bounds = {**bounds, **{k: (lo, hi) for k, (lo, hi, _) in own.items()}}
        log_uniform = tuple(k for k in log_uniform if k not in own) + tuple(
            k for k, (_, _, kind) in own.items() if kind == "log-uniform")
        return bounds, log_uniform

    def calibrate(self, candidate: str | None) -> ModelClass:
        """The base class (candidate None, in DIR/<base_dir>: :meth:`calibrate_base`) or the base class enriched
        with ``candidate`` (:meth:`enriched_class`: ``physics_catalog.enriched_settings`` with the study's priors of
        its added parameters, in DIR/enriched_<candidate>; on top of the candidates :meth:`adopt` confirmed, in
        DIR/step_<k>/enriched_<candidate>), written in the convention the base class adopted."""
        if candidate is None:
            return self.calibrate_base()
        name, switches, bounds, log_uniform, out = self.enriched_class(candidate)
        cls, _, _ = self.calibrate_class(self.observations, name, switches, bounds, log_uniform, self.run, out,
                                         self.seed, self.settings)
        return cls

    def enriched_class(self, candidate: str) -> tuple:
        """(name, switches, prior bounds, log-uniform names, directory) of the base class enriched with
        ``candidate``, on top of the candidates :meth:`adopt` confirmed (a combined class), in the base's
        convention."""
        base_bounds, base_log_uniform = self.free_priors()
        switches, bounds, extra_log = physics_catalog.enriched_settings(
            candidate, {**self.base_switches, **self.adopted_switches}, base_bounds, self.model, self.shears)
        bounds, extra_log = self.enriched_priors(candidate, bounds, extra_log)
        switches = {**switches, **self.adopted_switches, **self.convention}
        return (class_name(switches, enrichment_family(self.model).model), switches, bounds,
                base_log_uniform + tuple(extra_log),
                self.class_root / f"enriched_{candidate.replace(' ', '_')}")

    def free_priors(self) -> tuple:
        """(bounds, log-uniform names) of the current base's free parameters: the problem's own, then the added
        parameters of the candidates :meth:`adopt` confirmed, with the priors their classes were calibrated with."""
        return {**self.base_bounds, **self.adopted_bounds}, tuple(self.base_log_uniform) + self.adopted_log_uniform

    def calibrate_base(self) -> ModelClass:
        """The base class in its own convention, in DIR/<base_dir> (:meth:`compare_conventions` writes it the other
        ways when its residual is structured)."""
        cls, post, like = self.calibrate_class(self.observations, class_name(self.base_switches, self.model),
                                               dict(self.base_switches), self.base_bounds,
                                               tuple(self.base_log_uniform), self.run, self.out / self.base_dir,
                                               self.seed, self.settings)
        self.own_base = (cls, post, like)
        return self.take_base({}, cls, post, like)

    def take_base(self, convention: dict, cls: ModelClass, post, like) -> ModelClass:
        """Make ``cls`` (the base written with ``convention``) the base class: its likelihood, description, mode and
        the convention every later class is written in; returns its record with the discretisation error measured
        at its mode."""
        self.convention = convention
        self.likelihood, self.base_mode = like, dict(zip(post.names, cls.extra["map_theta"]))
        self.describe_base(cls.name)
        return replace(cls, numerical_error=self.numerical_error(like, cls, {**self.base_switches, **convention}))

    def describe_base(self, name: str):
        """The description of the base class ``name`` and of its conventions: which the data prefer once they were
        compared, else that they are compared only on a structured residual."""
        writings = conventions(self.model, self.base_switches) or []
        self.description = self.describe(self.label, name)
        if self.conventions_compared:
            compared = "; ".join(f"{c['convention']}: ln Z = {c['log_evidence']:.1f}"
                                 for c in self.conventions_compared)
            chosen = next(c["convention"] for c in self.conventions_compared if c["switches"] == self.convention)
            self.description += (f" Conventions compared (the same model written another way): {compared}; "
                                 f"the base is written with {chosen}.")
        elif len(writings) > 1:
            self.description += (" The same model written another way (" + "; ".join(w for _, _, w in writings[1:])
                                 + ") is compared only when the base's residual is structured.")

    def compare_conventions(self, base: ModelClass) -> ModelClass | None:
        """The base class in each of its other conventions (``constitutive.registry.conventions``: the same model
        written another way, e.g. specific volume 1 + e or 1 + e0), in DIR/convention_<option>_<value>; the one with
        the highest ln Z becomes the base class when it beats the base's own by :data:`CONVENTION_LOG_BAYES` (its
        convention is then kept by the enriched and model-form classes; returned), else None. The description says
        which the data prefer."""
        writings = conventions(self.model, self.base_switches) or []
        if len(writings) < 2:
            return None
        tried = [(writings[0][2], {}, *self.own_base)]
        for option, value, words in writings[1:]:
            switches = {**self.base_switches, option: value}
            if option in model_spec(self.model).cls.option_names:
                name = class_name(switches, self.model)
            else:  # written through the enrichment family (Modified Cam Clay as ANICREEP with every physics off)
                family = enrichment_family(self.model)
                name = class_name({**family.switches, **switches}, family.model)
            cls, post, like = self.calibrate_class(self.observations, name, switches,
                                                   self.base_bounds, tuple(self.base_log_uniform), self.run,
                                                   self.out / f"convention_{option}_{value}", self.seed,
                                                   self.settings)
            tried.append((words, {option: value}, cls, post, like))
        self.conventions_compared = [{"convention": w, "switches": s, "class": c.name, "log_evidence": c.log_evidence,
                                      "wall_s": c.wall_s} for w, s, c, _, _ in tried]
        # another convention replaces the base's own only when the data prefer it clearly (ln B >= 3, "strong"): in
        # an undrained test 1 + e and 1 + e0 are the same and their ln Z differ by rounding
        best = max(tried, key=lambda c: c[2].log_evidence)
        if best[2].log_evidence - tried[0][2].log_evidence < CONVENTION_LOG_BAYES:
            self.describe_base(base.name)
            return None
        return self.take_base(*best[1:])

    def calibrate_model_form(self) -> ModelClass:
        """The base class (after :meth:`adopt`, the confirmed class) with a model-form discrepancy
        (:meth:`discrepancy`), in DIR/model_form (DIR/step_<k>/model_form): the alternative without physics that an
        enrichment must beat (``inference.diagnosis.rank.conclude``)."""
        if self.adopted:
            _, switches = self.calibrated[self.base_name]
            name = self.base_name
        else:
            switches = {**self.base_switches, **self.convention}
            name = class_name(switches, self.model)
        cls, _, _ = self.calibrate_class(self.observations, name + " + model-form discrepancy", switches,
                                         *self.free_priors(), self.run,
                                         self.class_root / "model_form", self.seed, self.settings,
                                         discrepancy=self.discrepancy(self.observations))
        return cls

    def calibrate_side_by_side(self, requests: list) -> list:
        """The classes ``requests`` of one step (``inference.diagnosis.MODEL_FORM``: :meth:`calibrate_model_form`;
        a candidate: :meth:`calibrate`) side by side on the study's processes when its executor is a local pool
        (``inference.side_by_side``): each class whole in a child of this process, its evaluations there
        (``inference.executors.SharedCoresExecutor``: in the child, and on the cores of the classes that have ended
        once no class waits to start), so that no class waits at a sweep for the other worker's chunk. Returns
        [(ModelClass, None) or (None, the error)] in their order, the classes one after the other would give (the
        model-form class starts last). A child sends back, with its class, the figures and files it kept (those that
        cannot travel it writes itself) and the switches of what it calibrated (:attr:`calibrated`, whose likelihood
        is made again here)."""
        executor = self.executor()
        processes = executor.processes if isinstance(executor, inference.PoolExecutor) else 1

        def task(request):
            if request == diagnosis.MODEL_FORM:
                return self.calibrate_model_form
            return lambda: self.calibrate(request)

        def in_child(run):
            # this child's evaluations stay in it, on the cores the ended classes leave once none waits to start
            self.executor = inference.executors.SharedCoresExecutor
            self.figures, known = FigureQueue(), set(self.calibrated)
            cls = run()
            kept = []   # each job pickled once, here: what cannot travel is written here
            for write, args in self.figures.jobs:
                try:
                    kept.append(pickle.dumps((write, args)))
                except Exception:  # noqa: BLE001 - a job that does not pickle
                    write(*args)
            made = {name: (switches, like.discrepancy is not None, like.names)
                    for name, (like, switches) in self.calibrated.items() if name not in known}
            return cls, kept, made

        def back(answer):
            cls, kept, made = answer
            for job in kept:
                write, args = pickle.loads(job)
                self.figures.keep(write, *args)
            for name, (switches, model_form, names) in made.items():
                like = self.make_likelihood(self.observations, switches,
                                            self.discrepancy(self.observations) if model_form else None)
                self.calibrated[name] = (like.bind(names), switches)
            return cls

        # the model-form class, mostly the shortest (the base's solves; its discrepancy marginalized exactly), starts
        # last and fills in beside the longer ones
        order = sorted(range(len(requests)), key=lambda k: requests[k] == diagnosis.MODEL_FORM)
        names = [f"the calibration of the {'model-form class' if r == diagnosis.MODEL_FORM else 'class of ' + r}"
                 for r in requests]
        done = inference.side_by_side([task(requests[k]) for k in order], processes, in_child, back,
                                      names=[names[k] for k in order])
        return [done[order.index(k)] for k in range(len(requests))]

    def adopt(self, confirmed: ModelClass) -> ModelClass:
        """The stepwise discovery (``inference.diagnosis.run_loop``, step 6): the confirmed enriched class becomes
        the base of the next step. Its switches join every later class, its added parameters join the free ones
        with the prior it was calibrated with, its mode is where the next classes' refined modes are climbed from,
        and the next step's classes are written in DIR/step_<k>/. Returns its record with the discretisation error
        measured at its mode."""
        enrichment = physics_catalog.candidate(confirmed.candidate).enrichment
        like, switches = self.calibrated[confirmed.name]
        self.adopted += (confirmed.candidate,)
        self.adopted_switches = {**self.adopted_switches, **enrichment.switches}
        added = {n: confirmed.priors[n] for n in enrichment.parameters if n in confirmed.priors}
        self.adopted_bounds = {**self.adopted_bounds, **{n: (lo, hi) for n, (lo, hi, _) in added.items()}}
        self.adopted_log_uniform += tuple(n for n, (_, _, kind) in added.items() if kind == "log-uniform")
        self.base_mode = dict(zip(confirmed.parameters, confirmed.extra["map_theta"]))
        self.base_name = confirmed.name
        self.class_root = self.out / f"step_{len(self.adopted) + 1}"
        self.description += (f" Step {len(self.adopted) + 1}: the base is the class confirmed at step "
                             f"{len(self.adopted)}, {confirmed.name}.")
        return replace(confirmed, numerical_error=self.numerical_error(like, confirmed, switches))

    def covariates(self, base: ModelClass) -> dict:
        return self.curve_covariates(self.likelihood, base.extra["map_curves"])


def run_loop(problem: LoopProblem, observations, run, out, seed: int, settings: Settings,
             label: str) -> diagnosis.LoopResult:
    """Calibrate, locate, explain, enrich, recalibrate, compare (``inference.diagnosis.run_loop`` under
    DECISION_RULE), then write the loop's files into ``out`` (the rule and settings in diagnosis_input.json).
    Returns the loop's records (the final `Diagnosis` in ``.final``, the ``timing``)."""
    out = Path(out)
    problem.start(observations, run, out, seed, settings, label)
    try:
        result = diagnosis.run_loop(problem, rule=DECISION_RULE)
    except BaseException:   # a loop stopped early leaves no drawer behind
        problem.figures.close()
        raise
    like, final = problem.likelihood, result.final
    for k, step in enumerate([result, *result.steps], start=1):
        where = out if k == 1 else out / f"step_{k}"
        diagnosis.write_input(where, like, step.classes, step.covariates, step.candidates,
                              description=step.final.description, **step.settings)
        diagnosis.write_diagnosis(where, step.final)
        problem.plot(where / "diagnosis.png", like, step.classes, step.final,
                     label if k == 1 else f"{label}, step {k}")
    chain = diagnosis.chain_steps(like, result)
    if result.steps:
        (out / "chain.md").write_text(diagnosis.chain_markdown(chain))
        step = result.steps[-1]
        last = next((c for c in step.classes if c.name == chain[-1]["class"]), step.classes[0])
        problem.plot(out / "chain.png", like, [result.classes[0], replace(
            last, role="enriched", candidate=" + ".join(result.chain))], final,
            f"{label}: the chain {' -> '.join(result.chain)}")
    with problem.executor() as executor:
        figures_s = problem.figures.draw_all(executor)
    (out / "loop.json").write_text(json.dumps({
        "label": label, "seed": seed, "verdict": final.verdict, "omitted_physics": final.omitted_physics,
        "confirmed_chain": result.chain, "chain": chain,
        "named": result.named, "named_without_enrichment": result.named_without_enrichment,
        "not_calibrated": result.not_calibrated, "log_bayes": final.log_bayes,
        "conventions": problem.conventions_compared, "timing": {**result.timing, "figures_s": figures_s},
        "phases_s": {c.name: c.extra.get("phases_s") for step in [result, *result.steps] for c in step.classes},
        "steps_timing": [s.timing for s in result.steps], "settings": vars(settings)},
        indent=1, default=float))
    return result

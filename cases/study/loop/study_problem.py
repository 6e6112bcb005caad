"""A study file as the soil loop's problem (:class:`StudyProblem`): its base model and forward model, the MAP curves
and covariates of its tests, the figures and report of each calibrated class (``cases.study.loop.problem`` holds
what every soil study shares)."""
from __future__ import annotations

import numpy as np

import inference
from cases.study import runner
from cases.study.forward.family import FamilyForward
from cases.study.forward.study import StudyForward
from cases.study.loop.covariates import programme_covariates
from cases.study.loop.problem import CASE, LoopProblem
from cases.study.outputs.figures.dense import dense_curves, with_mean_stress
from cases.study.outputs.figures.panels import curve_panels, stage_axes
from cases.study.outputs.report import plot_loop, write_outputs
from cases.study.programme import programme_of
from cases.study.reading.presets import FE_FIELDS
from cases.study.reading.records import generating_values
from cases.study.reading.schema import Study
from constitutive import physics_catalog
from constitutive.registry import enrichment_family, model_spec
from constitutive.swelling import SWELLING_SWITCH, DelayedSwelling

__all__ = ["StudyProblem"]


class StudyProblem(LoopProblem):
    """A study file's base model as a :class:`LoopProblem`; its classes are calibrated in the loop's directory
    itself (base) and DIR/enriched_<candidate>/."""

    case = CASE

    def __init__(self, study: Study, observations, times: dict, quick: bool, processes=None, dispatch="dynamic"):
        self.study = study
        self.observations = observations
        self.times = times
        self.model = study.model
        self.base_switches = dict(study.switches)
        self.base_bounds = dict(study.free)
        self.base_log_uniform = tuple(study.log_uniform)
        # a laboratory specimen is a material point, drained or undrained; pressuremeter tests are solved by the FE
        if any("sbp" in (t.type, t.apparatus) for t in study.tests):
            self.forward_arguments = physics_catalog.COUPLED_FE_ARGUMENTS
        self.sigma_bounds = ({"sigma_eps": study.sigma_bounds} if study.error_model is None
                             else study.error_model.parameter_bounds())
        self.sigma_kind = study.sigma_kind
        self.constraints = study.constraints
        self.error_groups = None if study.error_model is None else study.error_model.curve_groups(observations)
        self.weights = {t.name: t.weight for t in study.tests if t.weight != 1.0}
        self.enrichment_priors = study.enrichment_priors
        self.base_dir = "."
        self.preset = study.preset(quick)
        self.processes, self.dispatch = processes, dispatch
        self.shears = any(t.apparatus == "sbp" or any(s.procedure.shearing for s in t.stages)
                          for t in map(programme_of, study.tests))
        self.synthetic = any("synthetic" in t.conditions for t in observations)
        self.generating = generating_values(observations)

    def forward(self, switches, refinement=1, observations=None):
        """The study's forward model of the class with ``switches``: the base model's own (switches it has), or its
        enrichment family's with the parameters translated (``cases.study.forward.family``: an MCC study enriched as
        ANICREEP); ``refinement``: a discretisation this many times finer (``StudyForward``); ``observations``: the
        abscissae asked for (default the records)."""
        observations = self.observations if observations is None else observations
        if self.solved_model(switches) != self.model:
            return FamilyForward(self.study, observations, switches, self.preset, refinement)
        return StudyForward(self.study, observations, switches, self.preset, refinement)

    def solved_model(self, switches) -> str:
        """The model the class with ``switches`` is solved as: the base model where it has every switch, else its
        enrichment family's."""
        family, own = enrichment_family(self.model).model, self.study.spec.switches
        return family if family != self.model and any(k not in own for k in switches) else self.model

    def kernels(self, switches) -> list:
        """The compiled-kernel source files the class with ``switches`` needs (``runner.kernel_files``)."""
        swelling = runner.kernel_files(DelayedSwelling) if switches.get(SWELLING_SWITCH) else []
        sbp = any("sbp" in (t.type, t.apparatus) for t in self.study.tests)
        return runner.kernel_files(model_spec(self.solved_model(switches)).cls, fe=sbp) + swelling

    def map_curves(self, params, switches):
        return self.forward(switches)([params])[0]

    def refined_curves(self, params, switches):
        result = self.forward(switches, refinement=2)([params])[0]
        if isinstance(result, Exception):
            raise result
        return result

    def catalog_switches(self, switches):
        return {**self.study.spec.catalog, **switches}

    def executor(self):
        return inference.default_executor(self.dispatch, self.processes)

    def summary_extra(self, switches):
        s = self.study
        return {"study": s.name, "study_file": str(s.path), "model": s.model, "fixed": s.fixed,
                "priors": {n: {"bounds": list(b), "prior": "log-uniform" if n in s.log_uniform else "uniform"}
                           for n, b in s.free.items()},
                "tests": {t.name: {"file": str(t.file), **t.conditions()} for t in s.tests},
                "fe": ({k: getattr(self.preset, k) for k in FE_FIELDS} if any(t.type == "sbp" for t in s.tests)
                       else None),
                "synthetic_recordings": self.synthetic, "generating": self.generating,
                **({"constraints": [c.text for c in s.constraints]} if s.constraints else {}),
                **({"sigma_eps_groups": {g: [f"{t}/{c}" for t, c in keys] for g, keys in self.error_groups.items()}}
                   if self.error_groups else {})}

    def describe(self, label, base_name):
        free = ", ".join(self.study.free)
        return ((f"**SYNTHETIC data** ({label}). " if self.synthetic else f"Recordings ({label}). ")
                + f"Study {self.study.name} ({self.study.path}); base class {base_name} with {free}, "
                f"{', '.join(self.sigma_bounds)} free; "
                "catalog: constitutive.physics_catalog.")

    def curve_covariates(self, like, map_curves) -> dict:
        """Per-point covariates (names from physics_catalog.COVARIATES) of the study's tests, the within-test ones
        included (``cases.study.loop.covariates.programme_covariates``)."""
        return programme_covariates(self.study.tests, like.observations, map_curves, times=self.times,
                                    within_test=True)

    def outputs(self, run, seed, out, post, like, cls, map_curves, summary, switches):
        """The study's figures and report.md (:func:`cases.study.outputs.report.write_outputs`), the MAP drawn between
        the records where the forward model is laboratory tests alone (a study with pressuremeter tests would solve
        its FE again: its laboratory curves are drawn at the records, its FE curves as solved)."""
        params, _ = like.split(np.array([cls["parameters"][n]["map"] for n in like.names]))
        dense = {} if any("sbp" in (t.type, t.apparatus) for t in self.study.tests) else dense_curves(
            lambda observations: self.forward(switches, observations=observations)([params])[0],
            with_mean_stress(like.observations))
        dense.update({(t, k): v for t, curves in map_curves.items() for k, v in curves.items() if isinstance(v, tuple)})
        write_outputs(out, run.method, post, like, cls, self.study, self.synthetic, self.generating, summary,
                      map_curves, dense, self.figures)

    def plot(self, path, like, classes, diag, label):
        plot_loop(path, like, classes, diag, label, self.synthetic, self.figures,
                  curve_panels(like.observations, stage_axes(self.study.tests)))

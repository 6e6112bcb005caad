"""The forward model of a study's whole programme for one model class: its laboratory tests through
:class:`cases.study.forward.lab.LabForward` (vectorized over the batch), each SBP test through
:class:`cases.study.forward.sbp.SBPForward` (one coupled FE solve per particle, at the test's site and rate)."""
from __future__ import annotations

from dataclasses import replace

from cases.study.forward.lab import LabForward
from cases.study.forward.sbp import SBPForward
from cases.study.reading.stage_records import recorded_programme
from constitutive.registry import class_name
from inference import ForwardModelError, ListForward

__all__ = ["StudyForward"]


class StudyForward(ListForward):
    """Batched forward model (``inference.ListForward``) of a study (``cases.study.reading.schema.Study``: model,
    fixed values, tests) for the model class with ``switches``: a list of parameter dicts (the free ones) -> a list of
    {test: {curve: values at the records, or (cavity strain %, values) for an SBP test}} with the covariate
    quantities of the laboratory tests, a ForwardModelError naming the failed tests in place of a failed particle
    (raising when the model refuses the values of the batch).
    ``observations`` give the recorded abscissae and curves; ``preset`` the FE discretization of the SBP tests
    (default: the study's full one); ``refinement``: a discretisation this many times finer (the laboratory
    drivers' strain steps; the FE's radial cells and increments), with which the diagnosis measures the calibrated
    one's error. A particle that fails in a laboratory test gets no FE solve."""

    def __init__(self, study, observations, switches: dict, preset=None, refinement=1):
        spec = study.spec
        self.model = study.model
        self.switches = dict(switches)
        self.fixed = {**spec.defaults, **study.fixed}
        self.label = class_name(self.switches, self.model)
        lab = [recorded_programme(t, observations[t.name]) for t in study.tests
               if t.type != "sbp" and t.apparatus != "sbp"]
        x = {t.name: next(iter(t.curves.values())).x for t in observations}
        curves = {t.name: tuple(t.curves) for t in observations}
        self.lab = None
        if lab:
            driver_x = {t.name: {k: c.x for k, c in observations[t.name].curves.items()} if t.staged else
                        x[t.name] if t.type == "oedometer_creep" else x[t.name] / 100.0 for t in lab}
            self.lab = LabForward(self.model, lab, driver_x, curves, self.fixed, self.switches,
                                  max_strain_step=spec.max_strain_step, e0_parameter=spec.e0_parameter,
                                  refinement=refinement)
        preset = preset or study.preset(False)
        if refinement != 1:
            preset = replace(preset, radial_cells=refinement * preset.radial_cells,
                             increments=refinement * preset.increments)
        self.sbp = {t.name: self.sbp_forward(t, observations[t.name], preset, spec.e0_parameter)
                    for t in study.tests if t.type == "sbp" or t.apparatus == "sbp"}

    def sbp_forward(self, t, recorded, preset, e0_parameter) -> SBPForward:
        """The FE forward model of the SBP test ``t`` recorded as ``recorded`` (inference.Test): its flat expansion,
        or its stage programme with each stage's abscissa as recorded
        (``cases.study.reading.stage_records.recorded_programme``)."""
        staged = {}
        if t.staged:
            staged = {"programmes": {t.name: recorded_programme(t, recorded)},
                      "abscissae": {t.name: {k: c.x for k, c in recorded.curves.items()}}}
        return SBPForward(preset, t.site, {} if t.staged else {t.name: t.strain_rate}, self.fixed, self.model,
                          self.switches, void_ratio0=self.fixed.get("e0", t.e0) if e0_parameter else t.e0,
                          curves=tuple(recorded.curves), **staged)

    def __call__(self, batch):
        lab = self.lab(batch) if self.lab is not None else [{} for _ in batch]
        out = []
        for params, result in zip(batch, lab):
            if isinstance(result, Exception):
                out.append(result)
                continue
            result = dict(result)
            for name, sbp in self.sbp.items():
                try:
                    result.update(sbp(params))
                except Exception as exc:  # noqa: BLE001 - an FE failure is this particle's zero likelihood
                    result = ForwardModelError(f"{self.label}: integration failed in test(s) "
                                               f"[{name} ({type(exc).__name__}: {exc})]")
                    break
            out.append(result)
        return out

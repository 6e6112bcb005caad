"""The forward model of a study whose base model is enriched through another model of its family
(``constitutive.registry.enrichment_family``: a Modified Cam Clay study enriched as ANICREEP with the catalog's
switch on).

The calibrated parameters keep the base model's names (M, lambda_, kappa, nu or G, ocr or pc0) plus the enrichment's
extra parameters (C_alpha_e, chi0, xi, ...); for every test and particle they are translated once by the family's
``translate`` at the test's initial effective stress and void ratio (MCC -> ANICREEP: ``mcc_as_anicreep``), and the
family's own switches and options (MCC -> ANICREEP: every physics off, ``specific_volume="current"``) stand where the
class's switches do not say otherwise, so the family class with every switch off reproduces the base class and its
log-evidence is comparable with the base's. A
test's own ``ocr`` / ``preconsolidation`` is read as the base model reads it (MCC: ocr = preconsolidation /
sigma'_v0 applied to the surface through the initial stress) before the translation, then removed from the test.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from cases.study.forward.study import StudyForward
from constitutive.registry import class_name, enrichment_family
from inference import ListForward

__all__ = ["FamilyForward", "initial_stress"]


def initial_stress(spec) -> np.ndarray:
    """The specimen's initial effective stress (6,) (kPa, Voigt, axis 1 vertical) from ``spec.initial``: p0
    isotropic, else sigma'_v0 with sigma'_h0 = K0 sigma'_v0."""
    init = spec.initial
    if init.p0 is not None:
        return np.array([init.p0] * 3 + [0.0] * 3)
    return np.array([init.sigma_v0, init.K0 * init.sigma_v0, init.K0 * init.sigma_v0, 0.0, 0.0, 0.0])


class FamilyForward(ListForward):
    """Batched forward model (``inference.ListForward``) of ``study`` (base model ``study.model``) as the
    class of its enrichment family with ``switches`` (the family's switches; those not given keep the family's
    values that reproduce the base model). One :class:`StudyForward` per test (the translated values depend on the
    test's initial state); results merged per particle, a ForwardModelError in place of a particle that fails in any
    test."""

    def __init__(self, study, observations, switches: dict, preset=None, refinement=1):
        self.family = enrichment_family(study.model)
        switches = {**self.family.switches, **switches}
        self.base_values = dict(study.fixed)
        self.label = class_name(switches, self.family.model)
        self.tests = []
        for t in study.tests:
            pre = t.initial.preconsolidation
            if pre is None and t.initial.ocr is not None:
                pre = t.initial.ocr * t.initial.vertical
            overrides = {} if pre is None else {"ocr": pre / t.initial.vertical}
            e0 = t.initial.e0 if t.initial.e0 is not None else t.e0
            clean = replace(t, initial=replace(t.initial, ocr=None, preconsolidation=None))
            inner = replace(study, model=self.family.model, switches=dict(switches), fixed={}, tests=(clean,))
            self.tests.append((t.name, overrides, initial_stress(t), e0,
                               StudyForward(inner, observations, switches, preset, refinement)))

    def translated(self, batch, overrides, stress0, e0) -> list:
        """The family's values of every particle of ``batch`` for one test."""
        names = [k for k in batch[0] if not k.startswith("sigma_eps")]
        values = {**self.base_values, **{k: np.array([p[k] for p in batch], dtype=float) for k in names}}
        if overrides:
            values = {k: v for k, v in values.items() if k != "pc0"} | overrides
        family = self.family.translate(values, stress0, e0)
        m = len(batch)
        arrays = {k: np.broadcast_to(np.asarray(v, dtype=float), (m,)) for k, v in family.items()}
        return [{k: float(v[i]) for k, v in arrays.items()} for i in range(m)]

    def __call__(self, batch):
        out = [{} for _ in batch]
        for name, overrides, stress0, e0, forward in self.tests:
            results = forward(self.translated(batch, overrides, stress0, e0))
            for i, result in enumerate(results):
                if not isinstance(out[i], Exception):
                    out[i] = result if isinstance(result, Exception) else {**out[i], **result}
        return out

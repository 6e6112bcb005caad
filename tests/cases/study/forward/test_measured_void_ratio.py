"""A programme whose void ratio was measured at the end of a stage (``Stage.e_end``, cases.study.forward.lab_staged):
the specimen starts from the void ratio that reaches it, per particle, and then runs as the programme given that e0
(found here by bisection). The study file's ``e_end``: tests/cases/study/reading/test_stage_choices.py."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from test_lab_programme import mcc, programme

from cases.study.forward.lab_staged import VOID_RATIO_TOLERANCE, simulate_programme
from cases.study.programme import InitialState, Stage
from constitutive.anicreep import ANICREEP

STAGES = (Stage("consolidation", "c1", p=200.0, duration=3600.0, abscissa="p", e_end=0.9),
          Stage("shear", "s2", drainage="undrained", strain_rate=1e-5, to_strain=0.05, abscissa="axial_strain"))
RECORDS = {"void_ratio@c1": np.array([100.0, 200.0]), "q@s2": np.array([0.01, 0.03, 0.05])}


@pytest.mark.parametrize("model", [
    mcc(lambda_=np.array([0.15, 0.25]), kappa=np.array([0.03, 0.05])),
    ANICREEP(M=1.2, lambda_=np.array([0.3, 0.4]), kappa=0.03, nu=0.25, e0=1.5, sigma_p0=30.0, C_alpha_e=0.01,
             anisotropy=False)], ids=["MCC", "ANICREEP viscous"])
def test_the_start_reaches_the_void_ratio_measured_at_the_end_of_consolidation(model):
    spec = programme("triaxial", InitialState(p0=25.0), *STAGES)
    curves, failed = simulate_programme(model, spec, RECORDS, 2)
    assert not failed.any() and set(curves) == set(RECORDS)
    np.testing.assert_allclose(curves["void_ratio@c1"][:, -1], 0.9, rtol=0, atol=10 * VOID_RATIO_TOLERANCE)
    # each particle: the programme given the e0 found by bisection (with the end record the forward adds, e@c1, so
    # that the steps are the same) gives the same curves; the starts differ with the particles' compressibility
    plain = tuple(replace(s, e_end=None) for s in STAGES)
    records = {**RECORDS, "e@c1": np.array([200.0])}
    starts = []
    for i in range(2):
        one = model.replaced({k: (np.asarray(v)[i] if np.ndim(v) else v) for k, v in model.parameters().items()
                              if v is not None})
        lo, hi = 0.9, 1.9
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            e = simulate_programme(one, programme("triaxial", InitialState(p0=25.0, e0=mid), *plain), records,
                                   1)[0]["e@c1"][0, 0]
            lo, hi = (mid, hi) if e < 0.9 else (lo, mid)
        starts.append(lo)
        ref, _ = simulate_programme(one, programme("triaxial", InitialState(p0=25.0, e0=lo), *plain), records, 1)
        for key in RECORDS:
            np.testing.assert_allclose(curves[key][i], ref[key][0], rtol=1e-8)
    assert starts[0] > 0.9 and starts[1] > starts[0]

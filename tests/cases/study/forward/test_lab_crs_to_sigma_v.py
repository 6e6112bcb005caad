"""Staged oedometer programmes (cases.study.forward.lab_staged) around a crs stage ended by to_sigma_v, and the holds of
a rate-independent model, against closed forms of Modified Cam Clay's own equations (docs/reference.md section 4).

Oracles and tolerances:
- MCC elasticity K = (1 + e) p'/kappa integrates exactly whatever the step (p' exponential in the elastic volumetric
  strain, e updated with the same v): an elastic unloading from p'_1 to p'_2 changes e by -kappa ln(p'_2/p'_1) to
  round-off (checked to 1e-9), whatever the strain step;
- on the oedometer NCL at a constant stress ratio p'_c is proportional to p' and sigma'_v, so e - ln sigma'_v has
  slope lambda: after 15 % axial strain q/p' still drifts by 2e-5 per 5 %; the slope over the continuation to
  2000 kPa is measured 2.3e-9 from lambda (checked to 1e-6);
- the end of the stage is located to the crossing tolerance (1e-9 in ln sigma'_v, checked to 1e-8 with the Newton
  tolerance of the stage that follows);
- a rate-independent model's hold changes nothing (every strain held; checked to the Newton tolerance).
"""
from __future__ import annotations

import numpy as np
import pytest

from cases.study.forward import lab_staged
from cases.study.forward.lab_stage_steps import StageSteps
from cases.study.forward.lab_staged import simulate_programme, simulate_programmes
from cases.study.programme import InitialState, Stage, TestSpec
from constitutive.mcc import ModifiedCamClay


def programme(*stages, initial=InitialState(e0=1.2, sigma_v0=50.0, K0=0.6)):
    return TestSpec(name="t", type="programme", apparatus="oedometer", initial=initial, stages=tuple(stages))


def mcc(**kw):
    return ModifiedCamClay(**{"M": 1.2, "lambda_": 0.2, "kappa": 0.04, "nu": 0.3, "ocr": 1.0, **kw})


@pytest.mark.parametrize("strain_step", [0.0025, 0.0005])
def test_unloading_to_sigma_v_past_the_records_is_elastic_and_exact(monkeypatch, strain_step):
    """Load to 250 kPa on the NCL, then crs unloading with no record until sigma'_v = 100 kPa (the whole stage is the
    continuation): the next stage starts at 100 kPa and e - ln p' has slope kappa over the unloading, for either
    strain step."""
    monkeypatch.setattr(ModifiedCamClay, "max_strain_step", strain_step)
    spec = programme(Stage("load", "load1", sigma_v=250.0, ramp_time=1000.0, duration=5000.0),
                     Stage("crs", "crs2", strain_rate=-1e-6, to_sigma_v=100.0),
                     Stage("relaxation", "relax3", duration=100.0))
    x = {"e@load1": np.array([5000.0]), "p@load1": np.array([5000.0]), "e@relax3": np.array([0.0, 100.0]),
         "p@relax3": np.array([0.0, 100.0]), "axial_stress@relax3": np.array([0.0, 100.0])}
    out, failed = simulate_programme(mcc(), spec, x, 1)
    assert not failed[0]
    np.testing.assert_allclose(out["axial_stress@relax3"][0], 100.0, rtol=1e-8)
    slope = -(out["e@relax3"][0] - out["e@load1"][0]) / np.log(out["p@relax3"][0] / out["p@load1"][0])
    np.testing.assert_allclose(slope, 0.04, rtol=1e-9)


def test_loading_to_sigma_v_on_the_ncl_has_slope_lambda():
    """CRS loading recorded to 15 % axial strain, continued to sigma'_v = 2000 kPa (about 150 strain steps, chunks
    sized from the strain still needed): e - ln sigma'_v has slope lambda between the last record and the end."""
    spec = programme(Stage("crs", "crs1", strain_rate=1e-6, to_strain=0.15, abscissa="axial_strain"),
                     Stage("crs", "crs2", strain_rate=1e-6, to_sigma_v=2000.0),
                     Stage("relaxation", "relax3", duration=100.0),
                     initial=InitialState(e0=1.2, sigma_v0=20.0, K0=0.55))
    x = {"e@crs1": np.array([0.15]), "axial_stress@crs1": np.array([0.15]), "stress_ratio@crs1": np.array([0.1, 0.15]),
         "e@relax3": np.array([0.0]), "axial_stress@relax3": np.array([0.0])}
    out, failed = simulate_programme(mcc(), spec, x, 1)
    assert not failed[0]
    assert abs(out["stress_ratio@crs1"][0, 1] / out["stress_ratio@crs1"][0, 0] - 1.0) < 1e-4
    assert out["axial_stress@relax3"][0, 0] == pytest.approx(2000.0, rel=1e-8)
    slope = -(out["e@relax3"][0, 0] - out["e@crs1"][0, 0]) / np.log(2000.0 / out["axial_stress@crs1"][0, 0])
    assert slope == pytest.approx(0.2, rel=1e-6)


def test_target_passed_by_the_last_record_ends_the_stage_there():
    """Unloading recorded down to 0.5 % axial strain with to_sigma_v = 150 kPa, which sigma'_v passes before the
    last record: the stage ends at its last record (no continuation away from the target) and the relaxation that
    follows starts there, sigma'_v held."""
    spec = programme(Stage("crs", "crs1", strain_rate=1e-6, to_strain=0.08, abscissa="axial_strain"),
                     Stage("crs", "crs2", strain_rate=-1e-6, to_sigma_v=150.0, abscissa="axial_strain"),
                     Stage("relaxation", "relax3", duration=86400.0))
    x = {"axial_stress@crs2": np.array([0.07, 0.06, 0.005]), "axial_strain@relax3": np.array([0.0, 86400.0]),
         "axial_stress@relax3": np.array([0.0, 10.0, 86400.0])}
    out, failed = simulate_programme(mcc(), spec, x, 1)
    assert not failed[0]
    last = out["axial_stress@crs2"][0, -1]
    assert last < 150.0
    np.testing.assert_allclose(out["axial_stress@relax3"][0], last, rtol=1e-9)
    np.testing.assert_allclose(out["axial_strain@relax3"][0], 0.5, rtol=1e-12)


def test_unreachable_target_fails_fast_with_its_reason(monkeypatch):
    """Loading to a sigma'_v that lambda = 0.5 reaches only past a zero void ratio: the particle fails (MCC refuses
    e <= 0) within two chunks, its reason given; the batch's other particle (lambda = 0.2) is unaffected and equals
    its own run."""
    spec = programme(Stage("crs", "crs1", strain_rate=1e-6, to_strain=0.15, abscissa="axial_strain"),
                     Stage("crs", "crs2", strain_rate=1e-6, to_sigma_v=2000.0),
                     Stage("relaxation", "relax3", duration=100.0),
                     initial=InitialState(e0=1.2, sigma_v0=20.0, K0=0.55))
    x = {"e@relax3": np.array([0.0])}
    chunks = []  # the steps each chunk gives the particle that fails
    real = lab_staged._strain_steps

    def counted(model, carried, rate, steps, size, active, stage, stop=None):
        if stop is not None and active[0]:
            chunks.append(int(steps[0]))
        return real(model, carried, rate, steps, size, active, stage, stop)
    monkeypatch.setattr(lab_staged, "_strain_steps", counted)
    (out, failed, why), = simulate_programmes(mcc(lambda_=np.array([0.5, 0.2]), kappa=0.01), [spec], [x], 2)
    assert list(failed) == [True, False]
    assert "void ratio" in why[0] and "crs2" in why[0] and why[1] == ""
    assert len(chunks) == 2
    one, _ = simulate_programme(mcc(lambda_=0.2, kappa=0.01), spec, x, 1)
    assert out["e@relax3"][1, 0] == one["e@relax3"][0, 0]


def test_a_particle_failed_in_a_stage_takes_no_further_step():
    """A heavily overconsolidated particle with lambda - kappa = 0.01 and M = 0.8 yields on the dry side in the
    first crs stage, where MCC is unstable (softening faster than its elasticity): it fails there with that reason,
    and the later stages (crs to sigma'_v, relaxation) run for the other particle only, as in its own call."""
    spec = programme(Stage("crs", "crs1", strain_rate=1e-6, to_strain=0.2, abscissa="axial_strain"),
                     Stage("crs", "crs2", strain_rate=-1e-6, to_sigma_v=50.0),
                     Stage("relaxation", "relax3", duration=100.0),
                     initial=InitialState(e0=1.26, sigma_v0=20.0, K0=0.55))
    x = {"axial_stress@crs1": np.array([0.1, 0.2]), "axial_stress@relax3": np.array([100.0])}
    model = mcc(M=np.array([0.8, 1.2]), lambda_=np.array([0.1, 0.25]), kappa=np.array([0.09, 0.05]), nu=0.25,
                pc0=400.0, ocr=None)
    (out, failed, why), = simulate_programmes(model, [spec], [x], 2)
    assert list(failed) == [True, False]
    assert why[0].startswith("stage crs1:") and "unstable material point" in why[0]
    one, _ = simulate_programme(mcc(M=1.2, lambda_=0.25, kappa=0.05, nu=0.25, pc0=400.0, ocr=None), spec, x, 1)
    for k in x:
        assert np.all(out[k][1] == one[k][0])
    assert out["axial_stress@relax3"][1, 0] == pytest.approx(50.0, rel=1e-8)


def test_holds_of_a_rate_independent_model_take_their_records_only():
    """A hold's knots: the records and the end for a rate-independent model (timed=False), a geometric grid besides
    them for a rate-dependent one."""
    start = {"stress": np.array([[100.0, 60.0, 60.0, 0, 0, 0]]), "strain": np.zeros((1, 6)), "u": np.zeros(1)}
    stage = Stage("relaxation", "relax", duration=86400.0)
    records = np.array([10.0, 1000.0])
    plain = StageSteps("oedometer", stage, start, records, 0.0025, timed=False)
    np.testing.assert_array_equal(plain.knots[:, 0], [10.0, 1000.0, 86400.0])
    np.testing.assert_array_equal(plain.record_index, [0, 1])
    timed = StageSteps("oedometer", stage, start, records, 0.0025, timed=True)
    assert timed.knots.shape[0] > 100 and set(records) <= set(timed.knots[:, 0])

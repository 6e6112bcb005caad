"""The compiled step loop of ``mixed_control`` (``MaterialModel.compiled_steps``: Modified Cam Clay, ANICREEP, and
delayed swelling on either) against the per-step Python driver that calls the model's ``update``
(``compiled=False``), itself checked against closed forms in test_labtests.py, test_mcc.py, test_anicreep.py and
test_swelling.py: the same histories, end states, failures, reasons and stops on batches that mix drained and
undrained steps, stress- and strain-controlled components that change between steps, inactive steps, a stop target,
step cuts, failing points, creep holds, swelling after unloading and the previous step's predictor.

Tolerance: the two drivers run the same arithmetic per point, but a cut step's strain increments are summed in
order by the compiled loop and as halves of halves by the Python one, and the tangent predictor's matrix product may
be summed in another order by numpy; either changes the Newton's iterates by round-off, and the converged values
then differ by at most the Newton tolerance, 1e-10 x (1 kPa + max |sigma'|) on the stresses. The comparison allows
1e-8 of each quantity's scale.
"""
import numpy as np
import pytest

from constitutive import ANICREEP, IntegrationError, ModifiedCamClay
from constitutive import labtests as lt
from constitutive.swelling import DelayedSwelling

KEYS = ("stress", "strain", "pore_pressure", "void_ratio", "time")


def both(model, *args, **kwargs):
    """The compiled and the Python driver's results of the same call."""
    assert model.compiled_steps(len(args[0])) is not None
    return (lt.mixed_control(model, *args, **kwargs),
            lt.mixed_control(model, *args, compiled=False, **kwargs))


def assert_same_history(a, b):
    """Histories, end states and failures equal within 1e-8 of each quantity's scale (NaN in the same places)."""
    for key in KEYS:
        scale = 1.0 + np.nanmax(np.abs(b[key]), initial=0.0)
        np.testing.assert_allclose(a[key], b[key], rtol=0.0, atol=1e-8 * scale, err_msg=key)
    np.testing.assert_allclose(a["final_stress"], b["final_stress"], rtol=0.0,
                               atol=1e-8 * (1.0 + np.abs(b["final_stress"]).max()))
    assert a["state"].keys() == b["state"].keys()
    for key in a["state"]:
        scale = 1.0 + np.abs(b["state"][key]).max()
        np.testing.assert_allclose(a["state"][key], b["state"][key], rtol=0.0, atol=1e-8 * scale, err_msg=key)
    np.testing.assert_array_equal(a["failed"], b["failed"])
    assert a["reasons"].keys() == b["reasons"].keys()


def batch(n=6, seed=0, **fixed):
    """MCC over n points with parameters spread over their usual ranges, isotropic starts at 50-200 kPa."""
    rng = np.random.default_rng(seed)
    params = dict(M=rng.uniform(0.9, 1.5, n), lambda_=rng.uniform(0.1, 0.3, n), kappa=rng.uniform(0.01, 0.04, n),
                  nu=rng.uniform(0.15, 0.35, n), ocr=rng.uniform(1.0, 6.0, n))
    params.update(fixed)
    model = ModifiedCamClay(**params)
    p0 = rng.uniform(50.0, 200.0, n)
    stress = np.zeros((n, 6))
    stress[:, :3] = p0[:, None]
    return model, stress, model.initial_state(stress, rng.uniform(0.8, 1.6, n))


@pytest.mark.parametrize("undrained", [False, True])
def test_triaxial_shear_drained_and_undrained(undrained):
    model, stress, state = batch(seed=1)
    inc = np.zeros((300, 6))
    inc[:, 0] = 0.0005
    a, b = both(model, stress, state, lt.AXIAL_STRAIN_CONTROL, inc, np.ones(300), undrained=undrained)
    assert_same_history(a, b)
    assert not a["failed"].any() and a["stress"].shape == (6, 301, 6)


def test_changing_controls_drainage_and_records():
    """Isotropic loading under stress control, undrained shear, a drained hold of the axial stress (the axial
    component becomes stress-controlled: it starts from the actual total stress), then oedometer unloading; every
    third step recorded."""
    model, stress, state = batch(seed=2, G=np.linspace(2e3, 9e3, 6), nu=None)
    control = np.vstack([np.repeat(lt.NORMAL_STRESS[None], 40, 0), np.repeat(lt.AXIAL_STRAIN_CONTROL[None], 80, 0),
                         np.repeat(lt.NORMAL_STRESS[None], 20, 0), np.repeat(lt.ALL_STRAIN[None], 60, 0)])
    inc = np.zeros((200, 6))
    inc[:40, :3] = 5.0
    inc[40:120, 0] = 0.001
    inc[140:, 0] = -0.0004
    undrained = np.zeros(200, dtype=bool)
    undrained[40:120] = True
    record = np.arange(200) % 3 == 0
    a, b = both(model, stress, state, control, inc, np.linspace(1.0, 3.0, 200), undrained=undrained, record=record)
    assert_same_history(a, b)
    assert a["stress"].shape[1] == 1 + record.sum()


def test_inactive_steps_and_a_stop_target():
    """Points taking different numbers of oedometer steps (inactive steps padded), stopped before sigma'_v
    passes a target; the stop's step and value are the same."""
    model, stress, state = batch(seed=3)
    n = stress.shape[0]
    inc = np.zeros((120, n, 6))
    inc[:, :, 0] = np.linspace(0.001, 0.003, n)
    active = np.arange(120)[:, None] < np.linspace(40, 120, n).astype(int)[None]
    stop = (0, stress[:, 0] * np.array([1.5, 3.0, 6.0, 1e6, 1e6, 1e6]), np.ones(n))
    a, b = both(model, stress, state, lt.ALL_STRAIN, inc, np.ones((120, n)), active=active, stop=stop,
                record=np.ones(120, dtype=bool))
    assert_same_history(a, b)
    np.testing.assert_array_equal(a["stopped"], b["stopped"])
    np.testing.assert_array_equal(a["stop_step"], b["stop_step"])
    np.testing.assert_allclose(a["stop_value"], b["stop_value"], rtol=1e-8)
    assert a["stopped"].any() and not a["stopped"].all()


def test_step_cuts():
    """Drained, stress-controlled q up to 90 % of the critical state's in ten steps, with four Newton iterations
    per step: no step converges uncut, two levels of cuts carry some points, six carry all; the failures, with
    the driver's reason, are the same."""
    model, stress, state = batch(seed=4, ocr=np.full(6, 1.0))
    q_cs = 3.0 * model.M * stress[:, 0] / (3.0 - model.M)  # drained compression from p'0: q = M (p'0 + q/3)
    inc = np.zeros((10, stress.shape[0], 6))
    inc[:, :, 0] = 0.09 * q_cs
    control = np.zeros(6, dtype=bool)
    control[3:] = True
    failed = []
    for cuts in (0, 2, 6):
        a, b = both(model, stress, state, control, inc, np.ones(10), on_failure="nan", max_cuts=cuts,
                    max_iterations=4)
        assert_same_history(a, b)
        assert a["reasons"] == b["reasons"]
        assert all(f"did not converge after {cuts} step cuts" in why for why in a["reasons"].values())
        failed.append(a["failed"].sum())
    assert failed[0] == 6 and 0 < failed[1] < 6 and failed[2] == 0


def test_a_model_failure_gives_the_models_reason_and_raises_at_the_first_failing_step():
    """MCC's unstable point under oedometer loading (every strain prescribed: no cuts): the same failing step and
    the model's own reason; with on_failure="raise" the error of the point that fails first."""
    m = ModifiedCamClay(M=np.array([0.8, 1.2, 0.8]), lambda_=np.array([0.1, 0.2, 0.1]),
                        kappa=np.array([0.09, 0.04, 0.095]), nu=0.25, pc0=400.0)
    stress = np.array([[20.0, 11.0, 11.0, 0.0, 0.0, 0.0]] * 3)
    state = m.initial_state(stress, 1.26)
    inc = np.zeros((80, 6))
    inc[:, 0] = 0.0025
    a, b = both(m, stress, state, lt.ALL_STRAIN, inc, np.ones(80), on_failure="nan")
    assert_same_history(a, b)
    assert list(a["failed"]) == [True, False, True]
    assert a["reasons"] == b["reasons"] and "unstable material point" in a["reasons"][0]
    with pytest.raises(IntegrationError) as compiled_error:
        lt.mixed_control(m, stress, state, lt.ALL_STRAIN, inc, np.ones(80))
    with pytest.raises(IntegrationError) as python_error:
        lt.mixed_control(m, stress, state, lt.ALL_STRAIN, inc, np.ones(80), compiled=False)
    assert str(compiled_error.value) == str(python_error.value)


def test_a_void_ratio_compressed_beyond_the_solids():
    """A strain step that would take the void ratio to zero or below fails with the model's reason."""
    m = ModifiedCamClay(M=1.2, lambda_=0.2, kappa=0.04, nu=0.3, ocr=1.0)
    stress = np.array([[100.0, 100.0, 100.0, 0.0, 0.0, 0.0]])
    inc = np.zeros((3, 6))
    inc[:, 0] = 0.3
    a, b = both(m, stress, m.initial_state(stress, 0.4), lt.ALL_STRAIN, inc, np.ones(3), on_failure="nan")
    assert_same_history(a, b)
    assert a["reasons"] == b["reasons"] and "compressed beyond the solids" in a["reasons"][0]


def anicreep_batch(n=4, **switches):
    """ANICREEP over n points (preconsolidation 120-300 kPa), isotropic starts at 100 kPa."""
    params = dict(M=1.2, lambda_=0.2, kappa=0.03, nu=0.25, e0=1.2, sigma_p0=np.linspace(120.0, 300.0, n),
                  anisotropy=False, viscous=False)
    params.update(switches)
    model = ANICREEP(**params)
    stress = np.tile([100.0, 100.0, 100.0, 0.0, 0.0, 0.0], (n, 1))
    return model, stress, model.initial_state(stress)


VISCOUS = dict(viscous=True, C_alpha_e=0.004)
ANICREEP_CLASSES = {
    "rate independent": {},
    "viscous, current specific volume": dict(VISCOUS, specific_volume="current"),
    "viscous, anisotropic, destructured": dict(VISCOUS, anisotropy=True, destructuration=True, chi0=2.0, xi=9.0,
                                               xi_d=0.3),
}


@pytest.mark.parametrize("predictor", ["tangent", "previous"])
@pytest.mark.parametrize("switches", ANICREEP_CLASSES.values(), ids=ANICREEP_CLASSES.keys())
def test_anicreep_loading_creep_and_shear(switches, predictor):
    """Isotropic loading from 100 to 200 kPa in 40 minutes, a creep hold of 28 hours in time steps growing from
    1 s (the previous step's predictor scales the last increments by the ratio of the time steps), then undrained
    shear at 0.05 % per minute."""
    model, stress, state = anicreep_batch(**switches)
    control = np.vstack([np.repeat(lt.NORMAL_STRESS[None], 80, 0), np.repeat(lt.AXIAL_STRAIN_CONTROL[None], 80, 0)])
    inc = np.zeros((160, 6))
    inc[:40, :3] = 2.5
    inc[80:, 0] = 0.0005
    dt = np.r_[np.full(40, 60.0), np.geomspace(1.0, 1e4, 40), np.full(80, 60.0)]
    a, b = both(model, stress, state, control, inc, dt, undrained=np.arange(160) >= 80, predictor=predictor)
    assert_same_history(a, b)
    assert not a["failed"].any()


@pytest.mark.parametrize("switches", ANICREEP_CLASSES.values(), ids=ANICREEP_CLASSES.keys())
def test_anicreep_points_with_a_shear_component(switches):
    """Simple shear at constant volume (every strain prescribed, gamma_12 growing at 0.05 % a minute): each point
    carries one shear component (nc = 4), which the laboratory loops (inlined for nc = 3 only) integrate by the
    called local solve for nc at run time, and the Python driver (``ANICREEP.update``, the FE's update) by its copy
    for the literal nc = 4; the same histories."""
    model, stress, state = anicreep_batch(**switches)
    inc = np.zeros((120, 6))
    inc[:, 3] = 0.0005
    a, b = both(model, stress, state, lt.ALL_STRAIN, inc, np.full(120, 60.0))
    assert_same_history(a, b)
    assert not a["failed"].any() and np.all(np.abs(a["stress"][:, -1, 3]) > 10.0)


def test_anicreep_failure_reason():
    """A local Newton allowed one iteration and no sub-steps fails on the first plastic step, with the model's
    reason (the step's strain increment, time step and start stress), the same from both drivers."""
    class Brittle(ANICREEP):
        max_iterations = 1
        max_substep_depth = 0

    model = Brittle(M=1.2, lambda_=0.2, kappa=0.03, nu=0.25, e0=1.2, sigma_p0=np.array([120.0, 300.0]),
                    anisotropy=False, viscous=False)
    stress = np.tile([100.0, 100.0, 100.0, 0.0, 0.0, 0.0], (2, 1))
    inc = np.zeros((40, 6))
    inc[:, 0] = 0.002
    a, b = both(model, stress, model.initial_state(stress), lt.AXIAL_STRAIN_CONTROL, inc, np.ones(40),
                on_failure="nan", max_cuts=1)
    assert_same_history(a, b)
    assert a["failed"].any() and a["reasons"] == b["reasons"]


def adaptive_both(model, *args, **kwargs):
    """The compiled and the Python adaptive driver's results of the same call."""
    assert model.compiled_steps(len(args[0])) is not None
    return (lt.adaptive_control(model, *args, **kwargs),
            lt.adaptive_control(model, *args, compiled=False, **kwargs))


@pytest.mark.parametrize("switches", ANICREEP_CLASSES.values(), ids=ANICREEP_CLASSES.keys())
def test_adaptive_load_ramp_and_hold(switches):
    """An oedometer load stage as the staged programmes step it: sigma'_v ramped from 100 kPa to 150-400 kPa over
    60 s (a capped ramp), then held to one day in adaptive steps; records within both; one point inactive."""
    model, stress, state = anicreep_batch(**switches)
    n = stress.shape[0]
    end = stress.copy()
    end[:, 0] = np.linspace(150.0, 400.0, n)
    path = lt.LinearPath.ramp(np.where(lt.OEDOMETER_STRESS, 0.0, stress), np.where(lt.OEDOMETER_STRESS, 0.0, end),
                              np.full(n, 60.0), capped=True)
    segments = ([60.0, 86400.0], [6.0, 0.1], [6.0, np.inf], [np.inf, 0.1])
    records = np.broadcast_to(np.array([30.0, 60.0, 600.0, 3600.0, 86400.0])[:, None], (5, n))
    a, b = adaptive_both(model, stress, state, lt.OEDOMETER_STRESS, path, segments, records, strain_step=0.0025,
                         active=np.arange(n) != 2)
    assert_same_history(a, b)
    np.testing.assert_array_equal(a["steps"], b["steps"])
    assert not a["failed"].any() and a["steps"][2] == 0 and np.all(a["steps"][[0, 1, 3]] > 10)


def test_adaptive_undrained_relaxation():
    """Undrained shear held (every strain held) after a jump of the lateral total stress: the stress relaxes."""
    model, stress, state = anicreep_batch(**ANICREEP_CLASSES["viscous, current specific volume"])
    n = stress.shape[0]
    held = stress.copy()
    held[:, 1:3] = 90.0  # the lateral total stress, reached at once
    path = lt.LinearPath.constant(np.where(lt.AXIAL_STRAIN_CONTROL, 0.0, held))
    segments = ([1e5], [0.1], [np.inf], [0.1])
    records = np.broadcast_to(np.geomspace(1.0, 1e5, 11)[:, None], (11, n))
    a, b = adaptive_both(model, stress, state, lt.AXIAL_STRAIN_CONTROL, path, segments, records, undrained=True)
    assert_same_history(a, b)
    np.testing.assert_array_equal(a["steps"], b["steps"])


@pytest.mark.slow
def test_adaptive_failure_reason():
    """A local Newton allowed one iteration and no sub-steps: the points fail at the same stage time with the
    same reason from both drivers, NaN records after it. Slow: the Python driver takes about 170,000 adaptive steps
    (55 s) before the second point fails; test_swelling_failure_reason and test_anicreep_failure_reason check the
    failure reasons of the compiled loops in the default run."""
    class Brittle(ANICREEP):
        max_iterations = 1
        max_substep_depth = 0

    model = Brittle(M=1.2, lambda_=0.2, kappa=0.03, nu=0.25, e0=1.2, sigma_p0=np.array([120.0, 300.0]),
                    anisotropy=False, viscous=True, C_alpha_e=0.004)
    stress = np.tile([100.0, 100.0, 100.0, 0.0, 0.0, 0.0], (2, 1))
    end = stress.copy()
    end[:, 0] = 400.0
    path = lt.LinearPath.ramp(np.where(lt.OEDOMETER_STRESS, 0.0, stress), np.where(lt.OEDOMETER_STRESS, 0.0, end),
                              np.full(2, 60.0), capped=True)
    a, b = adaptive_both(model, stress, model.initial_state(stress), lt.OEDOMETER_STRESS, path,
                         ([60.0, 1e4], [6.0, 0.1], [6.0, np.inf], [np.inf, 0.1]),
                         np.broadcast_to(np.array([30.0, 60.0, 1e4])[:, None], (3, 2)), max_cuts=2)
    assert_same_history(a, b)
    assert a["failed"].any() and a["reasons"] == b["reasons"]


SWELLING_BASES = {
    "Modified Cam Clay": lambda n: ModifiedCamClay(M=1.2, lambda_=0.2, kappa=0.03, nu=0.25, ocr=1.0),
    "viscous ANICREEP, current specific volume": lambda n: anicreep_batch(n, **ANICREEP_CLASSES[
        "viscous, current specific volume"])[0],
    "viscous ANICREEP, initial specific volume": lambda n: anicreep_batch(n, **VISCOUS)[0],
}


def swollen(base, n=4, cls=DelayedSwelling):
    """Delayed swelling on ``base`` over n points (kappa_s 0.005-0.03, tau_s 1e3-1e5 s), isotropic starts at
    100 kPa, e0 1.2."""
    model = cls(base, kappa_s=np.linspace(0.005, 0.03, n), tau_s=np.geomspace(1e3, 1e5, n))
    stress = np.tile([100.0, 100.0, 100.0, 0.0, 0.0, 0.0], (n, 1))
    return model, stress, model.initial_state(stress, 1.2)


def load_unload_hold(n_hold=40):
    """Oedometer loading to 300 kPa in 40 minutes, a creep hold, unloading to 140 kPa, a swelling hold, then a
    relaxation hold with every strain held: (control, inc, dt)."""
    control = np.vstack([np.repeat(lt.OEDOMETER_STRESS[None], 120 + n_hold, 0), np.repeat(lt.ALL_STRAIN[None], 40, 0)])
    inc = np.zeros((160 + n_hold, 6))
    inc[:40, 0] = 5.0
    inc[80:120, 0] = -4.0
    dt = np.r_[np.full(40, 60.0), np.geomspace(1.0, 1e4, 40), np.full(40, 60.0), np.geomspace(10.0, 1e4, n_hold),
               np.geomspace(10.0, 1e5, 40)]
    return control, inc, dt


@pytest.mark.parametrize("base", SWELLING_BASES.values(), ids=SWELLING_BASES.keys())
def test_swelling_loading_unloading_and_holds(base):
    """The swelling hold after unloading swells every point, and in the relaxation that follows the vertical
    effective stress rises where the swelling is slowest; both drivers agree."""
    model, stress, state = swollen(base(4))
    a, b = both(model, stress, state, *load_unload_hold())
    assert_same_history(a, b)
    assert not a["failed"].any() and np.all(a["state"]["swelling_strain"] < -5e-4)
    rise = a["stress"][:, -1, 0] - a["stress"][:, -41, 0]
    assert rise[-1] > 10.0                   # the slowest swelling is the least complete at the hold's end


@pytest.mark.parametrize("base", SWELLING_BASES.values(), ids=SWELLING_BASES.keys())
def test_swelling_adaptive_hold_after_unloading(base):
    """After loading and unloading, the unloaded vertical stress held for a day in adaptive steps."""
    model, stress, state = swollen(base(4))
    control, inc, dt = load_unload_hold(n_hold=0)
    start = lt.mixed_control(model, stress, state, control[:120], inc[:120], dt[:120])
    s0 = start["final_stress"]
    path = lt.LinearPath.constant(np.where(lt.OEDOMETER_STRESS, 0.0, s0))
    records = np.broadcast_to(np.geomspace(10.0, 86400.0, 9)[:, None], (9, 4))
    a, b = adaptive_both(model, s0, start["state"], lt.OEDOMETER_STRESS, path, ([86400.0], [6.0], [np.inf], [0.1]),
                         records, strain_step=0.0025)
    assert_same_history(a, b)
    np.testing.assert_array_equal(a["steps"], b["steps"])
    assert not a["failed"].any() and np.all(a["state"]["swelling_strain"] < start["state"]["swelling_strain"])


def test_swelling_failure_reason():
    """The swelling strain allowed one base update cannot converge once the point swells: the same reason from
    both drivers."""
    class Hasty(DelayedSwelling):
        max_iterations = 1

    model, stress, state = swollen(SWELLING_BASES["Modified Cam Clay"](2), n=2, cls=Hasty)
    a, b = both(model, stress, state, *load_unload_hold(), on_failure="nan", max_cuts=1)
    assert_same_history(a, b)
    assert a["failed"].all() and a["reasons"] == b["reasons"]
    assert "did not converge in 1 base updates" in a["reasons"][0]


def test_one_point_and_a_batch_share_one_compiled_loop():
    """The compiled loops are given C-contiguous, writable arrays whatever the batch size: a broadcast view of one
    point is contiguous but read-only, and numba would compile a second specialization of each loop for it (18-28 s
    more of a cold start for ANICREEP's), as the sampler's first evaluation of one prior draw did before its
    batches. A batch, then its first point alone, through both drivers (an oedometer CRS and a load ramp held for an
    hour): no new specialization, and the one point's history is the batch's first row."""

    from constitutive import _mcc_kernel

    values = dict(M=[1.0, 1.2, 1.4], lambda_=[0.15, 0.2, 0.25], kappa=[0.02, 0.03, 0.04], nu=[0.2, 0.25, 0.3],
                  ocr=[1.0, 2.0, 4.0])
    inc = np.zeros((40, 6))
    inc[:, 0] = 0.001
    segments = ([60.0, 3600.0], [6.0, 0.1], [6.0, np.inf], [np.inf, 0.1])

    def run(n):
        model = ModifiedCamClay(**{k: np.array(v[:n]) for k, v in values.items()})
        stress = np.zeros((n, 6))
        stress[:, :3] = 100.0
        state = model.initial_state(stress, np.full(n, 1.2))
        crs = lt.mixed_control(model, stress, state, lt.ALL_STRAIN, inc, np.ones(40))
        path = lt.LinearPath.ramp(np.where(lt.OEDOMETER_STRESS, 0.0, stress),
                                  np.where(lt.OEDOMETER_STRESS, 0.0, 2.0 * stress), np.full(n, 60.0), capped=True)
        records = np.broadcast_to(np.array([60.0, 3600.0])[:, None], (2, n))
        return crs, lt.adaptive_control(model, stress, state, lt.OEDOMETER_STRESS, path, segments, records)

    crs, held = run(3)
    compiled = {name: set(getattr(_mcc_kernel, name).signatures) for name in ("drive", "adapt")}
    one_crs, one_held = run(1)
    assert {name: set(getattr(_mcc_kernel, name).signatures) for name in ("drive", "adapt")} == compiled
    for whole, one in ((crs, one_crs), (held, one_held)):
        for key in KEYS:
            np.testing.assert_allclose(one[key], whole[key][:1], rtol=0.0, atol=1e-8 * 400.0, err_msg=key)

"""cases.study.forward.lab and sbp_forward: the batched laboratory forward model against the constitutive.labtests
drivers called directly, test by test and particle by particle (same process, so the same bits), and the SBP forward
model's material and FE problem against their direct construction."""
import numpy as np
import pytest

import fem
from cases.study.forward.lab import LabForward
from cases.study.forward.sbp import SBPForward, pressuremeter_problem
from cases.study.programme import TestSpec
from cases.study.reading.presets import Preset
from constitutive import ANICREEP, labtests
from inference import Curve, ForwardModelError, Likelihood, Observations, Test

FIXED = {"lambda_": 0.40, "kappa": 0.026, "e0": 2.0, "nu": 0.25, "tau": 86400.0}
TESTS = [
    TestSpec("cku", "triaxial", drainage="undrained", direction="compression", consolidation="K0", sigma_v0=80.0,
             K0=0.5, strain_rate=1e-6),
    TestSpec("ciue", "triaxial", drainage="undrained", direction="extension", consolidation="isotropic", p0=60.0,
             strain_rate=3e-6),
    TestSpec("cid", "triaxial", drainage="drained", direction="compression", consolidation="isotropic", p0=60.0,
             strain_rate=1e-6),
    TestSpec("crs", "oedometer_crs", sigma_v0=80.0, K0=0.5, strain_rate=5e-6),
    TestSpec("creep", "oedometer_creep", sigma_v0=60.0, K0=0.5, stage_stress=(100.0, 200.0), stage_duration=1000.0,
             n_times=5),
]
HOLD = np.geomspace(1.0, 1000.0, 5)
ABSCISSAE = {"cku": np.geomspace(1e-3, 0.05, 6), "ciue": -np.geomspace(1e-3, 0.05, 6),
             "cid": np.geomspace(1e-3, 0.05, 6), "crs": np.geomspace(1e-3, 0.1, 6),
             "creep": np.concatenate([HOLD, 1000.0 + HOLD])}  # the driver's own record times: no interpolation
PARAMS = {"M": np.array([1.2, 1.5, 1.35]), "sigma_p0": np.array([90.0, 120.0, 100.0]),
          "C_alpha_e": np.array([0.01, 0.03, 0.02])}


def _direct(t, model):
    x = ABSCISSAE[t.name]
    if t.type == "triaxial":
        driver = labtests.drained_triaxial if t.drainage == "drained" else labtests.undrained_triaxial
        return driver(model, 2.0, t.start_p, x, k0=t.k0, strain_rate=t.strain_rate, on_failure="nan")
    if t.type == "oedometer_crs":
        return labtests.oedometer_crs(model, 2.0, t.sigma_v0, x, t.strain_rate, k0=t.K0, on_failure="nan")
    return labtests.oedometer_loading(model, 2.0, t.sigma_v0, list(t.stage_stress), t.stage_duration,
                                      n_times=t.n_times, k0=t.K0, on_failure="nan")


@pytest.mark.parametrize("switches", [{"viscous": True, "anisotropy": True},
                                      {"viscous": False, "anisotropy": False}])
def test_batched_programme_equals_each_test_driven_alone(switches):
    """Five tests of four types and three particles in one forward call = each test and particle driven alone."""
    params = PARAMS if switches["viscous"] else {k: v for k, v in PARAMS.items() if k != "C_alpha_e"}
    fw = LabForward("ANICREEP", TESTS, ABSCISSAE, {t.name: ("q", "p") for t in TESTS}, FIXED, switches,
                    e0_parameter=True)
    curves, failed = fw.simulate(params)
    for i in range(3):
        model = ANICREEP(**FIXED, **{k: v[i:i + 1] for k, v in params.items()}, **switches)
        for t in TESTS:
            direct = _direct(t, model)
            assert not failed[t.name][i]
            # the incremental oedometer's records are interpolated in log time since the stage start, which the
            # second stage's times (1000 s + hold) carry to round-off
            rtol = 1e-12 if t.type == "oedometer_creep" else 0.0
            for name, quantity, scale in (("q", "q", 1.0), ("p", "p", 1.0), ("axial_strain", "axial_strain", 100.0),
                                          ("void_ratio", "e", 1.0)):
                np.testing.assert_allclose(curves[t.name][name][i], scale * direct[quantity][0], rtol=rtol, atol=0)
            np.testing.assert_allclose(curves[t.name]["stress_ratio"][i], direct["q"][0] / direct["p"][0], rtol=rtol)


def test_a_refused_parameter_set_is_that_particle_s_failure():
    """The model refusing a batch's values raises a ForwardModelError naming the class (alone or in a batch); the
    likelihood then solves each particle alone and records the refused one's reason."""
    fw = LabForward("ANICREEP", TESTS[:1], ABSCISSAE, {"cku": ("q",)}, FIXED, {"viscous": False}, e0_parameter=True)
    with pytest.raises(ForwardModelError, match=r"ANICREEP\(viscous=False\)"):
        fw([{"M": -1.0, "sigma_p0": 100.0}])
    with pytest.raises(ForwardModelError):
        fw([{"M": -1.0, "sigma_p0": 100.0}, {"M": 1.2, "sigma_p0": 100.0}])
    (good,) = fw([{"M": 1.2, "sigma_p0": 100.0}])
    observations = Observations([Test("cku", {"q": Curve(100.0 * ABSCISSAE["cku"], good["cku"]["q"])})])
    like = Likelihood(observations, fw).bind(("M", "sigma_p0", "sigma_eps"))
    values, reasons = like.evaluate_many(np.array([[-1.0, 100.0, 0.1], [1.2, 100.0, 0.1]]))
    assert values[0] == -np.inf and reasons[0].startswith("ForwardModelError: ANICREEP(viscous=False): ")
    assert np.isfinite(values[1]) and reasons[1] is None


def test_sbp_forward_builds_the_material_and_the_problem_it_is_given():
    site = {"sigma_v0": 31.0, "K0": 0.9, "u0": 38.8, "permeability": 1e-8, "a0": 0.05}
    preset = Preset(radial_cells=12, layers=1, increments=10, outer="field", outer_radius_a0=50.0)
    fixed = {"nu": 0.3, "lambda_": 0.40, "kappa": 0.026, "e0": 2.0, "tau": 86400.0}
    fw = SBPForward(preset, site, {"t": 1e-3}, fixed, "ANICREEP", {"viscous": True, "coupled": True})
    params = {"M": 1.5, "sigma_p0": 60.0, "C_alpha_e": 0.02, "permeability": 2e-9}
    mine, theirs = fw.material(params), ANICREEP(**fixed, M=1.5, sigma_p0=60.0, C_alpha_e=0.02, viscous=True,
                                                 vertical_axis=2)
    stress = fem.Geostatic(31.0, 0.9, 38.8).effective_stress(1)
    deps = np.array([[1e-3, -5e-4, 0.0, 2e-4, 0.0, 0.0]])
    np.testing.assert_array_equal(mine.update(stress, mine.initial_state(stress), deps, 10.0)[0],
                                  theirs.update(stress, theirs.initial_state(stress), deps, 10.0)[0])
    problem = pressuremeter_problem(1e-3, preset, site, 2.0)
    assert problem.mesh.n_cells == 12 and problem.permeability == 1e-8 and problem.void_ratio0 == 2.0

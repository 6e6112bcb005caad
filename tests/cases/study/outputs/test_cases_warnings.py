"""Warnings of a finished calibration (cases.study.outputs.calibration_warnings) on constructed posteriors: parameters
on prior bounds, sigma_eps at its ceiling, poor fits with the range where the residual is largest, one sigma_eps for
quantities of unequal scatter."""
import numpy as np
import pytest

from cases.study.outputs.calibration_warnings import (
    bound_warnings,
    calibration_warnings,
    failure_warnings,
    fit_warnings,
    shared_sigma_warnings,
    sigma_warnings,
)
from inference import Bound, Curve, Likelihood, Observations, Posterior, Prior, Test


def _posterior(prior, samples, map_theta):
    samples = np.asarray(samples, dtype=float)
    return Posterior(names=prior.names, samples=samples, log_like=np.zeros(len(samples)), log_evidence=0.0,
                     map_theta=np.asarray(map_theta, dtype=float), map_log_posterior=0.0, stages=[],
                     stage_samples=[samples], stage_log_like=[np.zeros(len(samples))], failures=[],
                     n_forward_solves=0, wall_s=0.0, ranks=1, executor="serial", prior=prior.describe())


PRIOR = Prior([Bound("K_0", 20.0, 120.0), Bound("n", 0.1, 1.0), Bound("k_p", 1e-4, 1e-2, "log-uniform"),
               Bound("sigma_eps", 0.002, 0.3)])


def test_map_and_quantiles_on_bounds():
    rng = np.random.default_rng(0)
    # K_0: samples well inside, MAP 119.6 (box width 100: 1 % is 1.0 from 120); n: the lower 2.5 % quantile within
    # 0.009 of 0.1; k_p: log-uniform, MAP 1.04e-4 is ln(1.04)/ln(100) = 0.85 % of the log width from the lower bound
    samples = np.column_stack([rng.uniform(60, 100, 400), np.r_[np.full(20, 0.1005), rng.uniform(0.3, 0.6, 380)],
                               rng.uniform(1e-3, 2e-3, 400), rng.uniform(0.02, 0.03, 400)])
    post = _posterior(PRIOR, samples, [119.6, 0.5, 1.04e-4, 0.025])
    assert bound_warnings(post, lower_only=("sigma_eps",)) == [
        "K_0 MAP 119.6 at the upper bound 120 of its prior: widen the bound or fix it",
        "n 2.5 % quantile 0.1005 at the lower bound 0.1 of its prior: widen the bound or fix it",
        "k_p MAP 0.000104 at the lower bound 0.0001 of its prior: widen the bound or fix it"]
    # just outside the tolerances: K_0 118.9 (1.1 %), k_p 1.1e-4 (2.1 % of the log width)
    inside = _posterior(PRIOR, samples[20:], [118.9, 0.5, 1.1e-4, 0.025])
    assert bound_warnings(inside, lower_only=("sigma_eps",)) == []


def test_sigma_at_its_ceiling():
    samples = np.tile([70.0, 0.5, 1e-3, 0.29], (50, 1))
    # width 0.298: 2 % is 0.00596 below 0.3
    assert sigma_warnings(_posterior(PRIOR, samples, [70.0, 0.5, 1e-3, 0.2950]), ("sigma_eps",)) == [
        "sigma_eps MAP 0.295 at the upper bound 0.3 of its prior: the model cannot fit these curves within the noise "
        "the prior allows"]
    assert sigma_warnings(_posterior(PRIOR, samples, [70.0, 0.5, 1e-3, 0.2930]), ("sigma_eps",)) == []


def test_poor_fit_names_the_test_curve_and_range():
    x = np.arange(1.0, 21.0)
    obs = Observations([Test("T1", {"q": Curve(x, 10.0 * x), "e": Curve(x, np.full(20, 0.8))}),
                        Test("T2", {"q": Curve(x, 5.0 * x)})])
    like = Likelihood(obs, lambda p: {})
    sim = {("T1", "q"): 10.0 * x, ("T1", "e"): np.full(20, 0.8) * (1 + 0.01 * (-1) ** np.arange(20)),
           ("T2", "q"): 5.0 * x}
    sim["T2", "q"] = sim["T2", "q"] * np.where((x >= 11) & (x <= 14), 1.25, 1.0)  # 20 % residual on x = 11..14
    sigma = {k: 0.01 for k in sim}
    # T2 q: r = 1 - 1.25 = -0.25 on 4 of 20 points: RMS sqrt(4/20) 0.25 = 0.112 > 3 x 0.01; window of 4 points
    assert fit_warnings(like, sim, sigma) == [
        "poor fit: test T2, curve q: RMS relative residual 11.2 % (11.2 x the median sigma_eps 1 %), worst for x 11 "
        "to 14 (mean residual -25 %)"]
    assert fit_warnings(like, sim, {k: 0.04 for k in sim}) == []


def test_calibration_warnings_with_error_groups():
    x = np.arange(1.0, 11.0)
    obs = Observations([Test("T1", {"q": Curve(x, 10.0 * x), "e": Curve(x, 0.8 - 0.01 * x)})])
    like = Likelihood(obs, lambda p: {}, groups={"stress": ["q"], "volume": ["e"]})
    prior = Prior([Bound("M", 0.5, 2.0), Bound("sigma_eps_stress", 0.001, 0.2), Bound("sigma_eps_volume", 0.001, 0.2)])
    like.bind(prior.names)
    post = _posterior(prior, np.tile([1.2, 0.05, 0.199], (30, 1)), [1.2, 0.05, 0.199])
    sim = {("T1", "q"): 10.0 * x, ("T1", "e"): (0.8 - 0.01 * x) * 1.001}
    assert calibration_warnings(post, like, sim) == [
        "sigma_eps_volume MAP 0.199 at the upper bound 0.2 of its prior: the model cannot fit these curves within "
        "the noise the prior allows"]


def test_one_sigma_for_quantities_of_unequal_scatter():
    """q misses by +-3 % at every point, the void ratio by +-0.5 % (RMS 3 % and 0.5 %, ratio 6): under one sigma_eps
    the e curves weigh 36 times less than under their own, and the line offers a group per quantity; with q off by
    +-1.4 % (ratio 2.8, below 3), with groups, or with one quantity, nothing is said."""
    x = np.arange(1.0, 21.0)
    sign = (-1.0) ** np.arange(20)
    q, e = 10.0 * x, 0.9 - 0.005 * x
    obs = Observations([Test("T1", {"q": Curve(x, q), "e": Curve(x, e)}), Test("T2", {"q@shear2": Curve(x, 2 * q)})])
    sim = {("T1", "q"): q * (1 + 0.03 * sign), ("T1", "e"): e * (1 + 0.005 * sign),
           ("T2", "q@shear2"): 2 * q * (1 - 0.03 * sign)}
    one = Likelihood(obs, lambda p: {})
    assert shared_sigma_warnings(one, sim) == [
        "one sigma_eps serves quantities whose RMS relative residual at the MAP differs 6.0 times (q 3 %, e 0.5 %): "
        'the e curves weigh about 36 times less than under an error parameter of their own; give each quantity its '
        'own (Eq. (6g)): [sigma_eps] groups = { q = ["q"], e = ["e"] }']
    closer = {**sim, ("T1", "q"): q * (1 + 0.014 * sign), ("T2", "q@shear2"): 2 * q * (1 + 0.014 * sign)}
    assert shared_sigma_warnings(one, closer) == []
    grouped = Likelihood(obs, lambda p: {}, groups={"stress": ["q", "q@shear2"], "volume": ["e"]})
    assert shared_sigma_warnings(grouped, sim) == []
    only_q = Likelihood(Observations([Test("T1", {"q": Curve(x, q)})]), lambda p: {})
    assert shared_sigma_warnings(only_q, sim) == []
    # among a calibration's warnings it is said where nothing is a poor fit (sigma_eps 3 %: the q curves at 1 x), not
    # beside poor fits (sigma_eps 0.5 %: q at 6 x), whose misfit an error group would not mend
    prior = Prior([Bound("a", 0.0, 1.0), Bound("sigma_eps", 0.001, 0.3)])
    one.bind(prior.names)
    fitted = calibration_warnings(_posterior(prior, np.tile([0.5, 0.03], (10, 1)), [0.5, 0.03]), one, sim)
    assert fitted == shared_sigma_warnings(one, sim)
    poor = calibration_warnings(_posterior(prior, np.tile([0.5, 0.005], (10, 1)), [0.5, 0.005]), one, sim)
    assert len(poor) == 2 and all(line.startswith("poor fit: test T") for line in poor)


@pytest.mark.parametrize("value, warned", [(0.2 * 0.99 + 0.001 * 0.01 + 1e-9, True), (0.2 * 0.99 - 0.01, False)])
def test_bound_tolerance_is_a_fraction_of_the_width(value, warned):
    prior = Prior([Bound("a", 0.001, 0.2), Bound("sigma_eps", 0.01, 0.1)])
    post = _posterior(prior, np.tile([0.1, 0.05], (10, 1)), [value, 0.05])
    assert bool(bound_warnings(post, lower_only=("sigma_eps",))) is warned


def test_a_calibration_prints_and_reports_its_warnings(tmp_path, capsys):
    """The shipped drained example (SYNTHETIC, phi_mu = 30 generating) with phi_mu's prior cut at 29.5: the MAP and
    the 97.5 % quantile sit on the upper bound."""
    from pathlib import Path

    from cases import calibrate
    example = Path(__file__).resolve().parents[4] / "cases" / "examples" / "triaxial_drained.toml"
    text = example.read_text().replace('file = "data/', f'file = "{example.parent}/data/')
    study = tmp_path / "bound.toml"
    study.write_text(text.replace("phi_mu = [20.0, 50.0]", "phi_mu = [20.0, 29.5]"))
    assert calibrate.main([str(study), "--quick", "--out", str(tmp_path / "out"), "--processes", "1"]) == 0
    lines = [s for s in capsys.readouterr().out.splitlines() if s.startswith("warning:")]
    assert len(lines) == 1 and lines[0].startswith("warning: phi_mu MAP 29.5")
    assert "at the upper bound 29.5 of its prior: widen the bound or fix it" in lines[0]
    report = (tmp_path / "out" / "report.md").read_text()
    assert "## Warnings\n\n- " + lines[0][len("warning: "):] in report


def test_an_error_parameter_on_its_lower_bound_is_a_bound_warning():
    prior = Prior([Bound("a", 0.0, 1.0), Bound("sigma_eps", 0.01, 0.3)])
    post = _posterior(prior, np.tile([0.5, 0.0105], (10, 1)), [0.5, 0.0102])
    assert bound_warnings(post, lower_only=("sigma_eps",)) == [
        "sigma_eps MAP 0.0102, 2.5 % quantile 0.0105, 97.5 % quantile 0.0105 at the lower bound 0.01 of its prior: "
        "widen the bound or fix it"]


def test_a_lower_bound_of_zero_is_reached_only_on_the_posterior_s_own_scale():
    """sigma_eps in a box [0, 1]: 0.0018 +- 0.0001 is 0.18 % of the box from 0 but far from it on its own scale (no
    warning); a posterior reaching down to 1e-5 with its 97.5 % quantile at 0.002 is on the bound."""
    prior = Prior([Bound("a", 0.0, 1.0), Bound("sigma_eps", 0.0, 1.0)])
    clear = np.column_stack([np.full(40, 0.5), np.linspace(0.00167, 0.00193, 40)])
    assert bound_warnings(_posterior(prior, clear, [0.5, 0.00177]), lower_only=("sigma_eps",)) == []
    reaching = np.column_stack([np.full(40, 0.5), np.linspace(1e-5, 0.002, 40)])
    (line,) = bound_warnings(_posterior(prior, reaching, [0.5, 1e-4]), lower_only=("sigma_eps",))
    assert line.startswith("sigma_eps MAP 0.0001, 2.5 % quantile") and "at the lower bound 0 of its prior" in line


def test_failed_solves_say_whether_the_posterior_reached_them():
    """Failures of prior draws (early stages) are regions the programme cannot follow; only failures at the final
    stage concern the calibrated parameters, and the line says which it is."""
    samples = np.tile([70.0, 0.5, 1e-3, 0.02], (10, 1))
    reason = "ForwardModelError: integration failed at p' = {} kPa"
    post = _posterior(PRIOR, samples, samples[0])
    post.stages, post.n_forward_solves = [{}, {}, {}], 300
    post.failures = [{"stage": 0, "reason": reason.format(25)}, {"stage": 1, "reason": reason.format(50)}]
    assert failure_warnings(post) == [
        "2 of 300 forward solves failed and count as zero likelihood, none at the final stage: regions of the prior "
        "the programme cannot follow (failed_solves.jsonl); most frequent reason (2): " + reason.format(25)]
    post.failures.append({"stage": 2, "reason": "ValueError: negative stress"})
    line, = failure_warnings(post)
    assert line.startswith("3 of 300 forward solves failed and count as zero likelihood, 1 of them at the final "
                           "stage: the posterior reaches parameters the programme cannot follow")
    post.failures = []
    assert failure_warnings(post) == []


def test_a_model_form_class_is_judged_net_of_its_discrepancy():
    """Records 4 % above a flat simulation in a smooth bump (sin over the curve), noise-free: against sigma_eps 0.2 %
    the bump is a poor fit of the physics alone, and the smooth discrepancy (amplitude 5 %, length half the curve)
    takes it up: net of the discrepancy's posterior mean the residual is far below 3 sigma_eps, so no warning."""
    from inference import Discrepancy

    x = np.linspace(0.0, 10.0, 41)
    y = 100.0 * (1.0 + 0.04 * np.sin(np.pi * x / 10.0))
    obs = Observations([Test("T", {"q": Curve(x, y, "axial_strain", "q", "%", "kPa")})])
    flat = {"T": {"q": (x, np.full(x.size, 100.0))}}
    plain = Likelihood(obs, lambda p: flat)
    prior = Prior([Bound("a", 0.0, 1.0), Bound("sigma_eps", 1e-4, 0.3, "log-uniform")])
    plain.bind(prior.names)
    post = _posterior(prior, np.tile([0.5, 0.002], (10, 1)), [0.5, 0.002])
    sim = {("T", "q"): np.full(x.size, 100.0)}
    (warning,) = calibration_warnings(post, plain, sim)
    assert warning.startswith("poor fit: test T, curve q: RMS relative residual 2.7")
    solves = []
    model_form = Likelihood(obs, lambda p: solves.append(p) or flat, discrepancy=Discrepancy())
    names = model_form.discrepancy_names
    prior = Prior([Bound("a", 0.0, 1.0), Bound("sigma_eps", 1e-4, 0.3, "log-uniform"),
                   Bound(names[0], 1e-3, 0.05, "log-uniform"),
                   Bound(names[1], 0.05, 1.0, "log-uniform")])
    model_form.bind(prior.names)
    theta = [0.5, 0.002, 0.05, 0.5]
    post = _posterior(prior, np.tile(theta, (10, 1)), theta)
    assert calibration_warnings(post, model_form, sim) == []
    assert solves == []   # judged from the MAP curves at hand, not solved again
    net = np.nanmax(np.abs(model_form.residuals(theta)["T", "q"] - model_form.discrepancy_mean(theta)["T", "q"]))
    assert net < 0.006   # below 3 x sigma_eps: the discrepancy carries the bump

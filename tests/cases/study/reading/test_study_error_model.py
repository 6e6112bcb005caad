"""The study file's error groups, per-test weights and prior constraints (cases.study.reading.error_model,
cases.study.reading.constraints, cases.study.reading.schema): what is accepted, what the likelihood and prior get, and
the errors."""
from pathlib import Path

import numpy as np
import pytest

from cases.study.checks import StudyError
from cases.study.loop.study_problem import StudyProblem
from cases.study.reading.records import load_observations
from cases.study.reading.schema import load_study

EXAMPLE = Path(__file__).resolve().parents[4] / "cases" / "examples" / "triaxial_undrained.toml"


def _study(tmp_path, model="", sigma="[sigma_eps]\nbounds = [0.001, 0.3]", weight=""):
    """The shipped undrained MCC example with its [model] and [sigma_eps] tables replaced."""
    text = EXAMPLE.read_text().replace('file = "data/', f'file = "{EXAMPLE.parent}/data/')
    head, rest = text.split("[model]", 1)
    rest = rest[rest.index("[sampler.quick]"):]
    model = model or ("[model.fixed]\nlambda_ = 0.2\nkappa = 0.04\nnu = 0.3\n[model.free]\nM = [0.8, 1.8]\n"
                      "ocr = [1.0, 4.0]")
    rest = rest.replace('strain_rate = 2.8e-6       # 1 %/h', f'strain_rate = 2.8e-6\n{weight}', 1)
    path = tmp_path / "study.toml"
    path.write_text(f'{head}[model]\nname = "ModifiedCamClay"\n{model}\n\n{sigma}\n\n{rest}')
    return path


def test_overlapping_kappa_lambda_box_is_accepted_with_the_constraint(tmp_path):
    model = ('[model.fixed]\nnu = 0.3\nocr = 1.5\n[model.free]\nM = [0.8, 1.8]\nlambda_ = [0.05, 0.3]\n'
             'kappa = [0.01, 0.1]')
    study = load_study(_study(tmp_path, model))
    assert [c.text for c in study.constraints] == ["kappa < lambda_"]
    problem = StudyProblem(study, *load_observations(study.tests), quick=True)
    prior = problem.prior(study.free, study.log_uniform)
    draws = prior.sample(np.random.default_rng(0), 500)
    k, lam = prior.index("kappa"), prior.index("lambda_")
    assert np.all(draws[:, k] < draws[:, lam])
    # box fraction with kappa < lambda: 1 - (area with lambda <= kappa) / (0.25 * 0.09) = 1 - 0.5 * 0.05^2 / 0.0225
    assert prior.accepted_fraction == pytest.approx(1 - 0.5 * 0.05**2 / 0.0225, abs=0.005)


def test_a_constraint_the_box_always_satisfies_is_left_out(tmp_path):
    model = ('[model.fixed]\nkappa = 0.04\nnu = 0.3\n[model.free]\nM = [0.8, 1.8]\nlambda_ = [0.1, 0.3]\n'
             'ocr = [1.0, 4.0]')
    assert load_study(_study(tmp_path, model)).constraints == ()
    assert load_study(_study(tmp_path)).constraints == ()


@pytest.mark.parametrize("model, message", [
    ('[model.fixed]\nkappa = 0.5\nnu = 0.3\nocr = 1.5\n[model.free]\nM = [0.8, 1.8]\nlambda_ = [0.1, 0.3]',
     "no point of the prior box satisfies kappa < lambda_"),
    ('constraints = ["M < 2 * kappa"]\n[model.fixed]\nM = 1.2\nkappa = 0.04\nlambda_ = 0.2\nnu = 0.3\n'
     '[model.free]\nocr = [1.0, 4.0]',
     r"model.constraints = 'M < 2 \* kappa': does not hold for the fixed values \{'M': 1.2, 'kappa': 0.04\}"),
    ('constraints = ["M < foo"]\n[model.fixed]\nlambda_ = 0.2\nkappa = 0.04\nnu = 0.3\n[model.free]\n'
     'M = [0.8, 1.8]\nocr = [1.0, 4.0]', r"model.constraints = 'M < foo': .*unknown parameter 'foo'"),
    ('constraints = ["M > 10 * ocr"]\n[model.fixed]\nlambda_ = 0.2\nkappa = 0.04\nnu = 0.3\n[model.free]\n'
     'M = [0.8, 1.8]\nocr = [1.0, 4.0]', "no point of the prior box satisfies M > 10 \\* ocr"),
    ('constraints = ["M > 1.79999 * ocr"]\n[model.fixed]\nlambda_ = 0.2\nkappa = 0.04\nnu = 0.3\n[model.free]\n'
     'M = [0.8, 1.8]\nocr = [1.0, 4.0]', r"model.constraints = \['M > 1.79999 \* ocr'\]: .*only .* of the prior box")])
def test_impossible_or_unreadable_constraints_are_refused(tmp_path, model, message):
    with pytest.raises(StudyError, match=message):
        load_study(_study(tmp_path, model))


def test_a_user_constraint_restricts_the_prior(tmp_path):
    model = ('constraints = ["M <= 0.5 * ocr"]\n[model.fixed]\nlambda_ = 0.2\nkappa = 0.04\nnu = 0.3\n'
             '[model.free]\nM = [0.8, 1.8]\nocr = [1.0, 4.0]')
    study = load_study(_study(tmp_path, model))
    prior = StudyProblem(study, *load_observations(study.tests), quick=True).prior(study.free, study.log_uniform)
    assert prior.names == ("M", "ocr", "sigma_eps")
    assert prior.logpdf([[1.0, 3.0, 0.05]])[0] > -np.inf and prior.logpdf([[1.6, 3.0, 0.05]])[0] == -np.inf


def test_error_groups_and_weights_reach_the_likelihood(tmp_path):
    sigma = ('[sigma_eps]\nbounds = [0.001, 0.3]\ngroups = { stress = ["q", "p"], pore = ["excess_pore_pressure"] }'
             '\n[sigma_eps.bounds_of]\npore = [0.001, 0.1]')
    study = load_study(_study(tmp_path, sigma=sigma, weight="weight = 0.5"))
    observations, times = load_observations(study.tests)
    problem = StudyProblem(study, observations, times, quick=True)
    assert problem.sigma_bounds == {"sigma_eps_stress": (0.001, 0.3), "sigma_eps_pore": (0.001, 0.1)}
    assert problem.weights == {"CK0UC": 0.5}
    like = problem.make_likelihood(observations, study.switches)
    prior = problem.prior(study.free, study.log_uniform)
    like.bind(prior.names)
    assert like.sigma_names == ("sigma_eps_stress", "sigma_eps_pore") and like.weights["CK0UC"] == 0.5
    assert like.group_of["CK0UC", "excess_pore_pressure"] == "pore" and like.group_of["CIUE", "p"] == "stress"


@pytest.mark.parametrize("sigma, weight, message", [
    ('groups = { stress = ["q"], pore = ["excess_pore_pressure"] }', "", "test CIUE, curve p is in no group"),
    ('groups = { stress = ["q", "p"], all = ["p", "excess_pore_pressure"] }', "", "curve p is in 2 groups"),
    ('groups = { stress = ["q", "p"], pore = ["excess_pore_pressure", "void_ratio"] }\n[sigma_eps.bounds_of]\n'
     'volume = [0.001, 0.1]', "", "sigma_eps.bounds_of.volume = .*not a group"),
    ('groups = { stress = ["q", "p", "excess_pore_pressure"] }', "", "one group is the single sigma_eps"),
    ("", "weight = 0", r"tests\['CK0UC'\]\.weight = 0: must be > 0")])
def test_bad_groups_and_weights_are_refused(tmp_path, sigma, weight, message):
    path = _study(tmp_path, sigma=f"[sigma_eps]\nbounds = [0.001, 0.3]\n{sigma}", weight=weight)
    with pytest.raises(StudyError, match=message):
        study = load_study(path)
        StudyProblem(study, *load_observations(study.tests), quick=True)

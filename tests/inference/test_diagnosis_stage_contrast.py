"""The between-stage contrast of a stage property (inference.diagnosis.stage_contrast through attribute): a rate
step inside one staged test is seen, and stage means that drift smoothly without a rate effect are not mistaken for
one. SYNTHETIC residuals: an undrained shear of 21 stages cycling the strain rate 0.107 / 0.054 / 0.011 %/min (a
kaolin rate-step programme's design), 30 points per stage, 1 % noise."""
import numpy as np

from inference.diagnosis import attribute
from inference.diagnosis.stage_contrast import MIN_STAGES, stage_groups

RATES = np.tile([0.107, 0.054, 0.011], 7)        # %/min, stage by stage


def _programme(rng, per_decade, noise=0.01, points=30, phi=0.0):
    """Residuals {("TX", "q@s<k>"): r} of stages whose mean drifts smoothly (a model-form misfit rising then falling
    along the strain) plus per_decade x log10(rate / 0.054); AR(1) noise with lag-1 correlation phi."""
    residuals = {}
    n = RATES.size
    for k, rate in enumerate(RATES):
        drift = 0.03 * np.sin(np.pi * k / (n - 1)) - 0.01 * k / n
        e = np.empty(points)
        e[0] = rng.standard_normal()
        for i in range(1, points):
            e[i] = phi * e[i - 1] + np.sqrt(1 - phi ** 2) * rng.standard_normal()
        residuals["TX", f"q@s{k}"] = drift + per_decade * np.log10(rate / 0.054) + noise * e
    rate = {key: RATES[k] for k, key in enumerate(residuals)}
    return residuals, {"strain rate": rate}


def test_a_rate_step_of_three_percent_per_decade_is_seen_in_one_test():
    rng = np.random.default_rng(1)
    residuals, covariates = _programme(rng, 0.035)
    a = attribute(residuals, covariates, n_shifts=2000)[0]
    assert a.name == "strain rate" and a.p_value < 0.01 and a.contrast["q"]["z"] > 0
    assert a.contrast["q"]["points"] == RATES.size - 2 and a.contrast["q"]["groups"] == 1
    # the explained size is of the order of the step's: 3.5 % per decade over rates 0.7 decade apart
    assert 0.005 < a.explained_rms < 0.03
    # faster stronger: the same step with the sign turned gives z < 0
    residuals, covariates = _programme(np.random.default_rng(1), -0.035)
    assert attribute(residuals, covariates, n_shifts=2000)[0].contrast["q"]["z"] < 0


def test_smoothly_drifting_stage_means_are_not_a_rate_effect():
    """False-alarm rate at alpha 0.05 over 300 programmes without a rate effect (white and AR(1) 0.5 noise): within
    alpha + 3 binomial standard errors."""
    rng = np.random.default_rng(2)
    for phi in (0.0, 0.5):
        p = [attribute(*_programme(rng, 0.0, phi=phi), n_shifts=400)[0].p_value for _ in range(300)]
        rate = np.mean(np.array(p) <= 0.05)
        assert rate <= 0.05 + 3 * np.sqrt(0.05 * 0.95 / 300), (phi, rate)


def test_a_test_with_too_few_stages_or_one_rate_is_left_to_the_other_nulls():
    rng = np.random.default_rng(3)
    residuals, covariates = _programme(rng, 0.035)
    few = {k: v for k, v in list(residuals.items())[:MIN_STAGES - 1]}
    assert stage_groups(few, {k: np.full(v.size, covariates["strain rate"][k]) for k, v in few.items()}) == {}
    one_rate = {k: np.full(v.size, 0.054) for k, v in residuals.items()}
    assert stage_groups(residuals, one_rate) == {}

"""What may confirm an enrichment (inference.diagnosis.trust, rank.conclude): a model-form class it must beat, a
posterior that did not collapse, an added parameter away from the end where its physics vanishes, an evidence
estimate that passed its check, and a sampler that agrees in sign."""
import math
from dataclasses import replace

import numpy as np

from inference import diagnosis
from inference.diagnosis import DecisionRule, ModelClass
from inference.diagnosis.trust import (
    confirmation_blocks,
    evidence_check,
    evidence_trusted,
    out_of_reach,
    sampler_disagrees,
)

RULE = DecisionRule(threshold=20.0)
ENRICHMENT = {"inert_at": {"xi": "lower", "tau": "lower"}}
PRIORS = {"M": [0.8, 1.6, "uniform"], "xi": [1.0, 30.0, "log-uniform"], "tau": [1e2, 1e7, "log-uniform"]}


def _class(name, role, candidate, lnz, parameters=None, sampler=None, evidence=None, discrepancy=()):
    return ModelClass(name, role, candidate, lnz, {}, parameters or {}, 0.02, {}, {}, np.empty(0),
                      sampler_log_evidence=sampler, evidence=evidence, priors=PRIORS, discrepancy=list(discrepancy))


def _params(**maps):
    return {n: {"map": v, "mean": v, "std": 0.1 * v} for n, v in maps.items()}


def _ranked(*names):
    return [diagnosis.CandidateScore(n, "", 0.0, True, True, False, ENRICHMENT, "") for n in names]


def _by_evidence(covariate, *statuses):
    """_ranked("A") named by the evidence alone, with primary signature items on ``covariate`` of these statuses."""
    from inference.diagnosis.records import SignatureItem

    items = tuple(SignatureItem(covariate, "primary", 1.0, 1, "", None, None, None, None, None, None, status, 0.0)
                  for status in statuses)
    return [replace(r, named=False, items=items) for r in _ranked("A")]


def test_a_candidate_must_beat_the_model_form_class_too():
    base = _class("base", "base", None, 0.0)
    form = _class("base + delta", "model form", None, 40.0)
    wins = _class("base + A", "enriched", "A", 65.0, _params(M=1.2, xi=8.0))
    d = diagnosis.conclude(_ranked("A"), [base, form, wins], RULE)
    assert d.omitted_physics == "A" and "25.00 over the model-form class" in d.candidates[0].decision
    close = replace(wins, log_evidence=50.0)
    d = diagnosis.conclude(_ranked("A"), [base, form, close], RULE)
    assert d.omitted_physics == "none"
    assert "10.00 < 20 over the model-form class" in d.candidates[0].decision
    assert d.model_form["prevails"] and d.model_form["log_bayes"] == 40.0
    assert d.model_form["log_bayes_enriched"] == {"base + A": 10.0}


def test_the_model_form_class_does_not_prevail_below_the_threshold():
    base = _class("base", "base", None, 0.0)
    form = _class("base + delta", "model form", None, 5.0)
    d = diagnosis.conclude(_ranked("A"), [base, form, _class("base + A", "enriched", "A", 8.0, _params(xi=8.0))],
                           RULE)
    assert d.omitted_physics == "none" and not d.model_form["prevails"]


def test_an_added_parameter_at_its_inert_end_blocks():
    at_floor = _class("e", "enriched", "A", 50.0, _params(M=1.2, xi=1.015))  # log position 0.0044 of [1, 30]
    blocks = confirmation_blocks(at_floor, ENRICHMENT, RULE)
    assert len(blocks) == 1 and "xi = 1.015 sits at the lower end of its prior (1)" in blocks[0]
    assert confirmation_blocks(replace(at_floor, parameters=_params(M=1.2, xi=1.2)), ENRICHMENT, RULE) == []
    # a swelling time constant at its floor: an instantaneous compliance, not a time effect
    fast = _class("e", "enriched", "A", 50.0, _params(tau=106.0))
    assert "tau = 106 sits at the lower end" in confirmation_blocks(fast, ENRICHMENT, RULE)[0]
    d = diagnosis.conclude(_ranked("A"), [_class("base", "base", None, 0.0), at_floor], RULE)
    assert d.omitted_physics == "none" and "where the effect vanishes" in d.candidates[0].decision


def test_a_collapsed_posterior_blocks():
    collapsed = _class("e", "enriched", "A", 1754.0,
                       {n: {"map": v, "mean": v, "std": 1e-24} for n, v in (("M", 1.2), ("xi", 8.0))})
    assert "posterior collapsed" in confirmation_blocks(collapsed, ENRICHMENT, RULE)[0]


def test_an_added_parameter_the_sampler_lost_blocks():
    """A swelling class of a held-out CIU programme: the population stood at tau = 5.3e5 s with a standard deviation
    of 73 s (1.2e-5 of the log range of [1e2, 1e7]) while the refined mode sat at 1.0e3 s; a parameter the data pin
    down, at 1e-3 of its range, passes. Only the candidate's added parameters are asked."""
    enrichment = {**ENRICHMENT, "parameters": {"tau": [1e2, 1e7]}}
    lost = _class("e", "enriched", "A", 50.0, {"M": {"map": 1.2, "mean": 1.2, "std": 0.1},
                                               "tau": {"map": 1026.0, "mean": 5.308e5, "std": 73.0}})
    blocks = confirmation_blocks(lost, enrichment, RULE)
    assert len(blocks) == 1 and blocks[0].startswith("the sampler lost its added parameter tau: posterior standard "
                                                     "deviation 1.2e-05 of its prior range (below 0.0001), MAP 1026")
    pinned = {"map": 5.3e5, "mean": 5.3e5, "std": 5.3e5 * 1e-3 * math.log(1e5)}
    assert confirmation_blocks(replace(lost, parameters={**lost.parameters, "tau": pinned}), enrichment, RULE) == []
    narrow_base = {"map": 1.2, "mean": 1.2, "std": 1e-9}     # a base parameter: not this check's
    assert confirmation_blocks(replace(lost, parameters={"M": narrow_base, "tau": pinned}), enrichment, RULE) == []


def test_refined_evidence_is_trusted_by_its_importance_check_or_the_sampler():
    ev = {"log_evidence": 756.5, "method": "importance sampling", "ess": 300.0, "n_draws": 1000, "std_error": 0.2}
    cls = _class("e", "enriched", "A", 756.5, sampler=584.9, evidence=ev)
    assert evidence_trusted(cls, RULE) == ""
    few = replace(cls, evidence={**ev, "ess": 30.0})
    why = evidence_trusted(few, RULE)
    assert "effective sample size of 30 of 1000 draws (needs 10 %)" in why and "differs by +171.6" in why
    laplace = replace(cls, evidence={**ev, "method": "Laplace"})
    assert "Laplace estimate" in evidence_trusted(laplace, RULE)
    assert evidence_trusted(replace(laplace, sampler_log_evidence=756.0), RULE) == ""  # agrees within 1 nat


def test_the_sampler_must_not_favour_the_class_compared_with():
    """The control of the precision issue: the sampler said 584.9 against the base's 610.4, the refined estimates
    756.5 against 624.6."""
    base = _class("base", "base", None, 624.6, sampler=610.4)
    enriched = _class("e", "enriched", "A", 756.5, _params(M=1.2, xi=8.0), sampler=584.9)
    assert "sampler's own estimate favours the base class (ln B = -25.5 by the sampler, +131.9 refined)" in \
        sampler_disagrees(enriched, base)
    d = diagnosis.conclude(_ranked("A"), [base, enriched], RULE)
    assert d.omitted_physics == "none" and "favours the base class" in d.candidates[0].decision
    agrees = replace(enriched, sampler_log_evidence=780.0)
    assert diagnosis.conclude(_ranked("A"), [base, agrees], RULE).omitted_physics == "A"
    assert diagnosis.conclude(_ranked("A"), [base, agrees], replace(RULE, sampler_agrees=False)).omitted_physics == "A"
    d = diagnosis.conclude(_ranked("A"), [base, enriched], replace(RULE, sampler_agrees=False))
    assert d.omitted_physics == "A"


def test_the_rule_round_trips_with_its_new_settings():
    rule = DecisionRule(threshold=20.0, inert_fraction=0.05, ess_fraction=0.2, sampler_agrees=False)
    assert DecisionRule.from_dict(rule.to_dict()) == rule


def test_a_misfit_the_size_of_the_discretisation_error_confirms_nothing():
    """Alternating +-4-8 % bands in the wall pore pressure of a coarse FE mesh: the refined mesh moves the curve by
    3 % RMS against a located misfit of 5 %."""
    from types import SimpleNamespace as Region

    from inference.diagnosis.trust import numerics_comparable
    regions = [Region(test="SBP1", curve="pore_pressure", mean_relative=-0.05),
               Region(test="SBP2", curve="pore_pressure", mean_relative=0.06)]
    base = replace(_class("base", "base", None, 0.0), numerical_error=[
        {"test": "SBP1", "curve": "pore_pressure", "rms": 0.03, "max": 0.08},
        {"test": "SBP2", "curve": "pore_pressure", "rms": 0.03, "max": 0.07}])
    why = numerics_comparable(base, regions, RULE)
    assert "55 % of the located misfit" in why and "confirm with a finer discretisation" in why
    assert numerics_comparable(replace(base, numerical_error=[]), regions, RULE) == ""
    small = replace(base, numerical_error=[{**e, "rms": 0.005} for e in base.numerical_error])
    assert numerics_comparable(small, regions, RULE) == ""
    d = diagnosis.conclude(_ranked("A"), [base, _class("e", "enriched", "A", 50.0, _params(M=1.2, xi=8.0))], RULE,
                           numerics=why)
    assert d.omitted_physics == "none" and "may be numerical" in d.candidates[0].decision


def test_the_margin_over_the_model_form_class_is_a_setting_of_the_rule():
    """The CRS programme with hidden viscosity: 72.1 over the base, 14.8 over the model-form class (57.4)."""
    base = _class("base", "base", None, 205.4, sampler=200.1)
    form = _class("base + delta", "model form", None, 262.7, sampler=249.1)
    viscous = _class("base + A", "enriched", "A", 277.5, _params(M=1.2, xi=8.0), sampler=240.0)
    assert diagnosis.conclude(_ranked("A"), [base, form, viscous], RULE).omitted_physics == "none"
    rule = replace(RULE, model_form_margin=10.0)
    d = diagnosis.conclude(_ranked("A"), [base, form, viscous], rule)
    assert d.omitted_physics == "A" and "14.80 over the model-form class" in d.candidates[0].decision
    assert DecisionRule.from_dict(rule.to_dict()).model_form_lead == 10.0


def test_structured_curves_stand_for_regions_when_none_was_located():
    """A relaxation curve misfit in shape (+5 % early, -5 % late: mean 0) with no contiguous region located: the
    structured curve is compared whole by its RMS residual."""
    from types import SimpleNamespace

    from inference.diagnosis.rank import CurveSpan, located_misfit, misfit_explained
    base = {("T", "relax"): np.array([0.05] * 5 + [-0.05] * 5), ("T", "load"): np.full(10, 0.001)}
    report = SimpleNamespace(regions=[], curves=[SimpleNamespace(test="T", curve="relax", structured=True),
                                                 SimpleNamespace(test="T", curve="load", structured=False)])
    spans = located_misfit(report, base)
    assert spans == [CurveSpan("T", "relax", 0, 10)]
    better = {("T", "relax"): np.array([0.01, -0.01] * 5), ("T", "load"): base["T", "load"]}
    assert misfit_explained(spans, base, better)[0]
    ok, left = misfit_explained(spans, base, base)
    assert not ok and "100 %" in left[0]
    nothing = SimpleNamespace(regions=[], curves=[SimpleNamespace(test="T", curve="load", structured=False)])
    assert not misfit_explained(located_misfit(nothing, base), base, better)[0]


def test_laplace_is_checked_by_an_importance_estimate_that_agrees():
    """A destructuration class of a CRS programme: Laplace 270.41, importance sampling 270.08 (ESS 25 of 256,
    standard error 0.19), the sampler 174.3: two independent refined estimates agree, the lagging sampler does not."""
    ev = {"log_evidence": 270.41, "method": "Laplace", "log_laplace": 270.41, "log_is": 270.08, "ess": 24.9,
          "n_draws": 256, "std_error": 0.19}
    cls = _class("e", "enriched", "A", 270.41, sampler=174.3, evidence=ev)
    assert evidence_check(cls, RULE) == "Laplace and importance sampling agree" and evidence_trusted(cls, RULE) == ""
    apart = replace(cls, evidence={**ev, "log_is": 264.67, "std_error": 0.71, "ess": 1.95})   # 4.8 apart
    why = evidence_trusted(apart, RULE)
    assert evidence_check(apart, RULE) == "" and "importance sampling differs by -5.7" in why


def test_the_sampler_sign_is_not_asked_of_two_importance_checked_estimates():
    """The same class against the base (importance sampling 246.16, ESS 113 of 256; the sampler 240.9): the sampler
    favours the base by 66.6, the two checked refined estimates the enriched class by 24.2 (threshold 20)."""
    base = _class("base", "base", None, 246.16, sampler=240.9,
                  evidence={"log_evidence": 246.16, "method": "importance sampling", "ess": 113.0, "n_draws": 256,
                            "std_error": 0.07})
    ev = {"log_evidence": 270.41, "method": "Laplace", "log_laplace": 270.41, "log_is": 270.08, "ess": 24.9,
          "n_draws": 256, "std_error": 0.19}
    enriched = _class("e", "enriched", "A", 270.41, _params(M=1.2, xi=8.0), sampler=174.3, evidence=ev)
    assert sampler_disagrees(enriched, base)
    assert diagnosis.conclude(_ranked("A"), [base, enriched], RULE).omitted_physics == "A"
    # a base whose refined estimate had no importance check: the sampler's sign is asked again
    unchecked = replace(base, evidence={"log_evidence": 246.16, "method": "Laplace", "std_error": 0.0})
    d = diagnosis.conclude(_ranked("A"), [unchecked, enriched], RULE)
    assert d.omitted_physics == "none" and "favours the base class" in d.candidates[0].decision


def test_the_sampler_sign_is_not_asked_when_the_base_cannot_reach_the_class():
    """A swelling class on a viscous base (a relaxation programme with both effects): importance sampling 302.42 (ESS
    140 of 512), its sampler stuck at 159.6 in a poorer mode; the base's Laplace 223.02 and importance estimate
    225.8 (ESS 26 of 1024) disagree, its sampler says 198.4. The base's ln L at its refined mode, 250.0, bounds
    every estimate of its ln Z (Z <= max L), 52.4 below the class: the sampler's sign is not asked. With the base's
    ln L within the threshold of the class, or not recorded, it is."""
    base_ev = {"log_evidence": 223.02, "method": "Laplace", "log_laplace": 223.02, "log_is": 225.8, "ess": 26.2,
               "n_draws": 1024, "std_error": 0.19, "log_likelihood_mode": 250.0}
    base = _class("base", "base", None, 223.02, sampler=198.4, evidence=base_ev)
    ev = {"log_evidence": 302.42, "method": "importance sampling", "log_laplace": 302.53, "log_is": 302.42,
          "ess": 140.3, "n_draws": 512, "std_error": 0.07}
    enriched = _class("e", "enriched", "A", 302.42, _params(M=1.2, xi=8.0), sampler=159.6, evidence=ev)
    assert sampler_disagrees(enriched, base) and evidence_check(base, RULE) == ""
    assert out_of_reach(enriched, base, 20.0) and not out_of_reach(enriched, base, 52.5)
    assert diagnosis.conclude(_ranked("A"), [base, enriched], RULE).omitted_physics == "A"
    for top in (290.0, None):
        near = replace(base, evidence={**base_ev, "log_likelihood_mode": top})
        d = diagnosis.conclude(_ranked("A"), [near, enriched], RULE)
        assert d.omitted_physics == "none" and "favours the base class (ln B = -38.8 by the sampler" in \
            d.candidates[0].decision


def test_a_lower_bound_that_clears_the_base_and_the_model_form_class_checks_the_evidence():
    """An IL programme with hidden destructuration: the class's Laplace value 259.86 and importance estimate 264.34
    (ESS 17 of 1024) disagree, but the first batch's estimate 264.67 gives a 95 % lower bound 261.67 (Markov), above
    the model-form class (259.71) and the base plus the threshold (200.95 + 20); the sampler's lag (182.1 against
    the base's 191.2) is not asked of it. A bound below the model-form class does not check it. The soil loop's rule:
    threshold 20 over the base, margin 0 over the model-form class."""
    rule = replace(RULE, model_form_margin=0.0)
    base = _class("base", "base", None, 200.95, sampler=191.2,
                  evidence={"log_evidence": 200.95, "method": "importance sampling", "ess": 59.2, "n_draws": 256,
                            "std_error": 0.11})
    form = _class("base + delta", "model form", None, 259.71, sampler=243.3,
                  evidence={"log_evidence": 259.71, "method": "importance sampling", "ess": 101.3, "n_draws": 768,
                            "std_error": 0.09})
    ev = {"log_evidence": 259.86, "method": "Laplace", "log_laplace": 259.86, "log_is": 264.34, "ess": 16.9,
          "n_draws": 1024, "std_error": 0.24, "log_lower": 264.67 + math.log(0.05)}
    enriched = _class("e", "enriched", "A", 259.86, _params(M=1.2, xi=8.0), sampler=182.1, evidence=ev)
    assert evidence_check(enriched, rule) == ""
    assert evidence_check(enriched, rule, floor=259.71) == "its 95 % lower bound clears what it must reach"
    assert diagnosis.conclude(_ranked("A"), [base, form, enriched], rule).omitted_physics == "A"
    # a model-form class whose own estimates were not checked is taken at the higher of them
    unchecked = replace(form, evidence={"log_evidence": 259.71, "method": "Laplace", "log_laplace": 259.71,
                                        "log_is": 262.5, "ess": 3.0, "n_draws": 1024, "std_error": 0.7})
    assert diagnosis.conclude(_ranked("A"), [base, unchecked, enriched], rule).omitted_physics == "none"
    short = replace(enriched, evidence={**ev, "log_lower": 258.0})
    d = diagnosis.conclude(_ranked("A"), [base, form, short], rule)
    assert d.omitted_physics == "none" and "its 95 % lower bound 258.0 falls short of 259.7" in d.candidates[0].decision
    # the bound as the class's ln Z (its Laplace value below it: inference.mode_evidence): confirmed where the bound
    # clears the model-form class, refused with the importance check's shortfall where it does not
    bound = {**ev, "log_evidence": 261.67, "method": "lower bound", "log_lower": 261.67}
    d = diagnosis.conclude(_ranked("A"), [base, form, replace(enriched, log_evidence=261.67, evidence=bound)], rule)
    assert d.omitted_physics == "A" and "1.96 over the model-form class" in d.candidates[0].decision
    low = {**bound, "log_evidence": 258.0, "log_lower": 258.0}
    d = diagnosis.conclude(_ranked("A"), [base, form, replace(enriched, log_evidence=258.0, evidence=low)], rule)
    assert d.omitted_physics == "none" and "effective sample size of 17 of 1024 draws" in d.candidates[0].decision


def test_a_class_whose_ln_z_could_not_be_refined_neither_confirms_nor_leads():
    """A class whose refinement at the mode was asked for and gave nothing (inference.diagnosis.NOT_REFINED) has the
    sampler's ln Z alone: far above the base and the model-form class, it is refused, naming why, and is not the
    tentative leader either; the same class with a checked estimate confirms."""
    base = _class("base", "base", None, 0.0)
    form = _class("base + delta", "model form", None, 40.0)
    lead = _class("base + A", "enriched", "A", 95.0, _params(M=1.2, xi=8.0),
                  evidence={"method": diagnosis.NOT_REFINED})
    d = diagnosis.conclude(_ranked("A"), [base, form, lead], RULE)
    assert d.omitted_physics == "none" and d.tentative is None
    assert "its ln Z could not be refined at its mode" in d.candidates[0].decision
    below = replace(lead, log_evidence=35.0)   # below the model-form class: not tentative either
    d = diagnosis.conclude(_ranked("A"), [base, form, below], RULE)
    assert d.omitted_physics == "none" and d.tentative is None
    checked = replace(lead, evidence={"log_evidence": 95.0, "method": "importance sampling", "ess": 80.0,
                                      "n_draws": 256, "std_error": 0.1})
    assert diagnosis.conclude(_ranked("A"), [base, form, checked], RULE).omitted_physics == "A"


def test_a_leader_that_leaves_its_misfit_is_tentative_not_confirmed():
    """Two effects at once: the leading class passes every check but leaves the located misfit (the other effect's):
    nothing is confirmed and it is the tentative candidate the stepwise loop tries next; below the threshold it is
    not even that."""
    base = _class("base", "base", None, 0.0)
    leader = _class("base + A", "enriched", "A", 58.6, _params(M=1.2, xi=8.0))
    left = {"A": (False, ["the located misfit falls only to 100 %"])}
    c = diagnosis.conclude(_ranked("A"), [base, leader], RULE, explained=left)
    assert c.omitted_physics == "none" and c.tentative == "A"
    c = diagnosis.conclude(_ranked("A"), [base, replace(leader, log_evidence=16.0)], RULE, explained=left)
    assert c.omitted_physics == "none" and c.tentative is None
    c = diagnosis.conclude(_ranked("A"), [base, leader], RULE)
    assert c.omitted_physics == "A" and c.tentative is None


def test_a_leader_below_the_model_form_class_is_tentative():
    """Two effects at once (a CRS programme with viscosity and bonding): the viscous class beats the base by 63 and
    is named by its signature, but stays 1.3 below the model-form class, whose smooth discrepancy also absorbs what
    bonding leaves: it is tentative (the stepwise loop tries a second effect on top of it). Named by the evidence
    alone it is too, unless its signature cannot show in the records (every primary item "not reported"); with the
    rule's ``joint_below_model_form`` off, or below the threshold, it is not."""
    base = _class("base", "base", None, 0.0)
    form = _class("base + delta", "model form", None, 64.3)
    leader = _class("base + A", "enriched", "A", 63.0, _params(M=1.2, xi=8.0))
    c = diagnosis.conclude(_ranked("A"), [base, form, leader], RULE)
    assert c.omitted_physics == "none" and c.tentative == "A"
    assert "-1.30 < 20 over the model-form class" in c.candidates[0].decision
    reported = _by_evidence("hold time after loading", "not significant")
    assert diagnosis.conclude(reported, [base, form, leader], RULE).tentative == "A"
    unseen = _by_evidence("hold time after loading", "not reported")
    assert diagnosis.conclude(unseen, [base, form, leader], RULE).tentative is None
    off = replace(RULE, joint_below_model_form=False)
    assert diagnosis.conclude(_ranked("A"), [base, form, leader], off).tentative is None
    below = replace(leader, log_evidence=16.0)   # below the threshold over the base
    assert diagnosis.conclude(_ranked("A"), [base, form, below], RULE).tentative is None


def test_a_margin_of_zero_confirms_the_leader():
    """The margin is how far the chosen class must lead the others: at 0 any lead will do (the leader is always
    within 0 of itself), and a tie within it goes to the candidate its signature names."""
    base = _class("base", "base", None, 0.0)
    a, b = _class("base + A", "enriched", "A", 40.0, _params(xi=8.0)), _class("base + B", "enriched", "B", 30.0)
    rule = replace(RULE, margin=0.0)
    assert diagnosis.conclude(_ranked("A", "B"), [base, a, b], rule).omitted_physics == "A"
    tie = replace(b, log_evidence=40.0)
    ranked = [replace(r, named=r.name == "B") for r in _ranked("A", "B")]
    assert diagnosis.conclude(ranked, [base, a, tie], rule).omitted_physics == "B"


def test_a_signature_the_records_cannot_show_does_not_confirm_on_top_of_an_effect():
    """The second step of CK0U programmes holding anisotropy (+ viscosity): delayed swelling, named by the evidence
    alone (+99.8 over the anisotropic class), with every primary item of its signature "not reported" (no hold after
    unloading in the programme). With ``signature_unseen_confirms`` off, as the stepwise loop sets it from the second
    step on, it does not confirm, and the reason says why; a primary item the records report (even not significant)
    lets it confirm, as at the first step."""
    base = _class("base", "base", None, 0.0)
    swelling = _class("base + A", "enriched", "A", 99.8, _params(M=1.2, xi=8.0))
    unseen = _by_evidence("hold time after unloading", "not reported", "not reported")
    later = replace(RULE, signature_unseen_confirms=False)
    assert diagnosis.conclude(unseen, [base, swelling], RULE).omitted_physics == "A"
    d = diagnosis.conclude(unseen, [base, swelling], later)
    assert d.omitted_physics == "none" and d.tentative is None
    assert "its signature cannot show in these records (no record reports hold time after unloading)" in \
        d.candidates[0].decision
    seen = _by_evidence("hold time after unloading", "not significant", "not reported")
    assert diagnosis.conclude(seen, [base, swelling], later).omitted_physics == "A"

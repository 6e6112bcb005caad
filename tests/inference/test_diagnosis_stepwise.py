"""The stepwise discovery of inference.diagnosis.run_loop (module docstring, step 6) on a toy problem that knows no
soil: SYNTHETIC records of y = (a x + b x^2)(1 + k [test T2]) with 1 % relative noise (Eq. (1), docs/reference.md
section 1) hold two effects, a curvature along x and a test T2 stiffer by k; the base class y = a x misses both.
Oracles: the generating model (which effects, their values b and k) and the records of y = a x + b x^2 alone, where
the second step must find noise and calibrate nothing."""
import numpy as np
import pytest
from toy_classes import batched_likelihood, calibrated_class

from inference import Curve, Likelihood, Observations, Test, diagnosis
from inference.diagnosis import run_loop

A, B, K, SIGMA = 2.0, 0.08, 0.04, 0.01
X = {"T1": np.linspace(1.0, 10.0, 40), "T2": np.linspace(1.0, 10.0, 40)}
#: the test covariate: 1 on T2
IN_T2 = {"T1": np.zeros(40), "T2": np.ones(40)}
#: candidate -> (its parameter, prior bounds)
TERMS = {"curvature": ("b", (0.0, 0.5)), "stiffer T2": ("k", (0.0, 0.2)), "saturation": ("d", (0.0, 0.5))}


def _item(covariate, direction, meaning):
    return {"covariate": covariate, "role": "primary", "weight": 1.0, "direction": direction, "curves": None,
            "meaning": meaning}


SIGNATURES = {"curvature": [_item("x", 1, "recorded above simulated at large x")],
              "stiffer T2": [_item("in_T2", 1, "recorded above simulated in T2")],
              "saturation": [_item("x", -1, "recorded below simulated at large x")]}


class TwoEffects:
    """A toy LoopProblem with ``adopt``: each confirmed term joins the base class of the next step."""

    description = "SYNTHETIC records y = (a x + b x^2)(1 + k [T2]), base class y = a x"

    def __init__(self, b, k, seed=5):
        rng = np.random.default_rng(seed)
        self.observations = Observations([Test(t, {"y": Curve(x, (A * x + b * x ** 2) * (1 + k * IN_T2[t]) * (
            1 + SIGMA * rng.standard_normal(x.size)))}) for t, x in X.items()])
        self.adopted = []
        self.likelihood = Likelihood(self.observations, self.forward([]))
        self.calibrated = []

    @staticmethod
    def forward(terms):
        def simulate(p):
            out = {}
            for t, x in X.items():
                y = p["a"] * x + p.get("b", 0.0) * x ** 2 - p.get("d", 0.0) * x ** 2
                out[t] = {"y": y * (1.0 + p.get("k", 0.0) * IN_T2[t])}
            return out
        return simulate

    def candidates(self):
        return [{"name": k, "physics": k, "signature": SIGNATURES[k], "enrichment": {"adds": k},
                 "in_base": k in self.adopted} for k in TERMS]

    def calibrate(self, candidate):
        terms = self.adopted + ([] if candidate is None else [candidate])
        self.calibrated.append(tuple(terms))
        bounds = {"a": (0.5, 5.0), **{TERMS[k][0]: TERMS[k][1] for k in terms}}
        return calibrated_class(batched_likelihood(self.observations, self.forward(terms)), self.forward(terms), bounds,
                                " + ".join(["y = a x", *terms]), "enriched", candidate)

    def covariates(self, base):
        return {"x": dict(X), "in_T2": dict(IN_T2)}

    def adopt(self, confirmed):
        self.adopted.append(confirmed.candidate)
        return confirmed


@pytest.fixture(scope="module")
def both():
    problem = TwoEffects(B, K)
    return problem, run_loop(problem, rule=diagnosis.DecisionRule(threshold=20.0))


def test_two_effects_are_confirmed_one_step_after_the_other(both):
    problem, result = both
    first, second = result.chain
    assert {first, second} == {"curvature", "stiffer T2"} and result.final.omitted_physics == first
    step = result.steps[0]
    # the second step enriches the adopted class: every class it calibrates holds the first effect
    assert step.classes[0].name == f"y = a x + {first}" and step.classes[0].role == "base"
    assert {c.name for c in step.classes[1:]} == {f"y = a x + {first} + {k}" for k in TERMS if k != first}
    assert step.final.log_bayes[f"y = a x + {first} + {second}"] >= 20.0
    confirmed = next(c for c in step.classes if c.candidate == second)
    assert confirmed.parameters["b"]["map"] == pytest.approx(B, rel=0.05)
    assert confirmed.parameters["k"]["map"] == pytest.approx(K, rel=0.15)
    # the third step's base (both terms) leaves noise: nothing more is calibrated, and the discovery stops
    third = result.steps[1]
    assert third.first.verdict == "consistent with noise" and [c.role for c in third.classes] == ["base"]
    assert len(problem.calibrated) == 1 + 3 + 2 and len(result.steps) == 2   # base, step 1's three, step 2's two
    # from the second step on, an effect whose signature the records cannot show does not confirm by evidence alone
    assert result.settings["rule"].signature_unseen_confirms
    assert not any(s.settings["rule"].signature_unseen_confirms for s in result.steps)


def test_one_effect_stops_after_the_second_step_finds_noise():
    problem = TwoEffects(B, 0.0)
    result = run_loop(problem, rule=diagnosis.DecisionRule(threshold=20.0))
    assert result.chain == ["curvature"] and len(result.steps) == 1
    assert result.steps[0].first.verdict == "consistent with noise" and len(result.steps[0].classes) == 1


def test_max_steps_one_is_the_single_step_loop():
    problem = TwoEffects(B, K)
    result = run_loop(problem, rule=diagnosis.DecisionRule(threshold=20.0), max_steps=1)
    assert len(result.chain) == 1 and result.steps == []


def test_the_chain_reports_each_step_and_the_misfit_left(both):
    problem, result = both
    rows = diagnosis.chain_steps(problem.likelihood, result)
    assert [r["confirmed"] for r in rows] == [*result.chain, "none"]
    assert rows[1]["base"] == rows[0]["class"] and rows[1]["log_bayes_over_previous"] >= 20.0
    # the misfit left after both steps is the noise (1 %) on every curve; before, the base misses both effects
    assert all(0.007 < v < 0.013 for v in rows[1]["misfit_left"].values())
    assert rows[0]["misfit_before"]["T2/y"] > 0.03
    text = diagnosis.chain_markdown(rows)
    assert "Step 3: base" in text and "consistent with noise" in text and "| T1/y |" in text


class WithModelForm(TwoEffects):
    """The toy problem with a model-form class whose ln Z is set: at the first step ``lead`` above the better
    single-effect class (so that no single effect beats it), or ``form_log_evidence`` when given; at later steps
    ``later_form_log_evidence``, else the first step's."""

    def __init__(self, b, k, lead):
        super().__init__(b, k)
        self.lead, self.form_log_evidence, self.later_form_log_evidence = lead, None, None

    def calibrate_model_form(self):
        from dataclasses import replace as with_
        if self.form_log_evidence is None:
            singles = [TwoEffects.calibrate(self, k).log_evidence for k in ("curvature", "stiffer T2")]
            self.calibrated = self.calibrated[:-2]
            self.form_log_evidence = max(singles) + self.lead
        base = TwoEffects.calibrate(self, None)
        self.calibrated.pop()
        later = self.adopted and self.later_form_log_evidence is not None
        return with_(base, name=base.name + " + delta", role="model form",
                     log_evidence=self.later_form_log_evidence if later else self.form_log_evidence)


def test_a_leader_below_the_model_form_class_is_confirmed_only_with_a_second_effect_that_beats_it():
    """Neither effect alone beats a model-form class 10 above the better of them; the leader, named by its
    signature, is adopted tentatively, and the combined class (both effects, about 100 above either alone) beats the
    model-form class: both are confirmed. When the first step's model-form class lies above what the combined class
    reaches, neither is, even though the second step confirms its effect over its own model-form class, and the
    reason names the first step's."""
    rule = diagnosis.DecisionRule(threshold=20.0, model_form_margin=0.0)
    problem = WithModelForm(B, K, lead=10.0)
    result = run_loop(problem, rule=rule)
    assert result.final.omitted_physics == "none" and result.final.tentative is not None
    assert result.joint["explained"] and set(result.chain) == {"curvature", "stiffer T2"}
    combined = next(c for c in result.steps[0].classes if c.candidate == result.joint["with"])
    assert combined.log_evidence > problem.form_log_evidence
    problem = WithModelForm(B, K, lead=10.0)
    problem.later_form_log_evidence = result.steps[0].classes[0].log_evidence   # the second step's base
    problem.form_log_evidence = combined.log_evidence + 5.0
    result = run_loop(problem, rule=rule)
    assert result.steps[0].final.omitted_physics != "none"
    assert result.chain == [] and not result.joint["explained"]
    assert "-5.00 < 0 over the model-form class at the tentative step" in result.joint["left"][-1]


def test_a_tentative_candidate_counts_only_when_the_next_effect_explains_the_rest():
    from dataclasses import replace as with_

    from inference.diagnosis import LoopResult

    def step(omitted, joint=None):
        final = diagnosis.Diagnosis("", 0.05, "structured mismatch", omitted, "", (), (), (), (), {},
                                    diagnosis.DecisionRule(), {}, (), {})
        return LoopResult(final, final, [], {}, [], [], {}, joint=joint)

    second = step("swelling")
    first = with_(step("none", {"tentative": "viscosity", "with": "swelling", "explained": True, "left": []}),
                  steps=[second])
    assert first.chain == ["viscosity", "swelling"]
    refused = with_(first, joint={**first.joint, "explained": False})
    assert refused.chain == []

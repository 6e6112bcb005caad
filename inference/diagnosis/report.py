"""The diagnosis of a calibrate -> diagnose loop: every model class screened, the candidates ranked on the base
class, the conclusion by the Bayes factor; as a record (`records.Diagnosis`, JSON by its ``to_json``) and as a report
an engineer reads (Markdown).

`diagnose` works in memory on the recorded curves' Likelihood, the model-class records, the base class's covariates
and the candidates (plain data, `rank.rank_candidates`). Its record (`records.Diagnosis`) holds: the screening verdict
of the base class, the mismatch regions, the covariate attribution, the ranked candidates with their decisions, per
class the log-evidence, ln B against the base, J_g at the MAP, parameters and residual-structure statistics
(before/after), the full screening of every class, the omitted physics ("none" when nothing is confirmed, by ln B, the
margin and the candidate's own pattern: `rank.conclude`, whose docstring states how to calibrate the threshold on
negative controls), the recommendation, the calibration warnings of the classes and, per candidate not named, what the
records lack to test it (`next_tests`). Every class is screened with the covariates (the enriched classes' screenings
tell whether the candidate's own pattern is gone). The Markdown report says, when no catalog entry explains the
structure, where (test, curve, abscissa range), how (sign and size) and which covariates the residual follows.
"""
from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from .attribution import expand_covariates, split_spec
from .rank import conclude, located_misfit, misfit_explained, names_curve, pattern_explained, rank_candidates
from .records import ClassSummary, DecisionRule, DiagnosedCandidate, Diagnosis, MismatchRegion, ModelClass, NextTest
from .screening import POSITION, relative_residuals, screen
from .trust import numerics_comparable

__all__ = ["diagnose", "markdown", "next_tests"]


def _declared(covariates: dict, likelihood) -> dict:
    """Every covariate spec in its declared form, its values in full form (`expand_covariates`), with the recorded
    abscissae of the curves (the few-test contrasts' common abscissa, `contrast.common_grid`) unless the spec names
    its own."""
    x = {(t.name, c): curve.x for t in likelihood.observations for c, curve in t.curves.items()}
    full = expand_covariates(covariates, {k: likelihood.observations[k[0]].curves[k[1]].y for k in x})
    out = {}
    for name, spec in covariates.items():
        meta = split_spec(name, spec)[1]
        out[name] = {"values": full[name], **meta, "abscissa": meta.get("abscissa", x)}
    return out


def diagnose(likelihood, classes: list, covariates: dict, candidates: list, description="", alpha=0.05, level=0.95,
             rule=DecisionRule(), n_shifts=1000) -> Diagnosis:
    """Screen every model class, rank the candidates on the base class, conclude; returns the `records.Diagnosis`.

    likelihood: an inference.Likelihood of the recorded curves (observations and near-zero floor; its forward model
    is not called); classes: model classes (``records.ModelClass`` or its dict: name, role "base" | "enriched",
    candidate, log_evidence, J_g, parameters, sigma_eps, wall_s, map_simulated {(test, curve): values},
    sample_simulated {(test, curve): (n_s, n)}, sample_sigma (n_s,), optional warnings [str]), exactly one with role
    "base"; covariates: per-point covariates of the base class in the form of ``screen`` (plain or declared specs,
    `attribution.split_spec`); candidates: plain-data catalog entries (``rank.rank_candidates``); alpha: family-wise
    false-alarm level of each screening; level: predictive band level; rule: the `records.DecisionRule` that confirms
    an enrichment (module docstring: calibration); n_shifts: null draws of the attribution. Deterministic (fixed
    seeds).
    """
    t0 = time.perf_counter()
    alpha, level = float(alpha), float(level)
    classes = [ModelClass.of(cl) for cl in classes]
    screened = _declared(covariates, likelihood)
    screens, structure, ranked_by_class = {}, {}, {}
    for cl in classes:
        rep = screen(likelihood, cl.map_simulated, cl.sigma_eps, cl.sample_simulated, cl.sample_sigma, screened,
                     alpha=alpha, level=level, n_shifts=n_shifts)
        screens[cl.name], structure[cl.name] = rep, _structure(rep)
        ranked_by_class[cl.name] = rank_candidates(rep, relative_residuals(likelihood, cl.map_simulated), screened,
                                                   candidates, alpha)
    base = next(cl for cl in classes if cl.role == "base")
    ranked, base_screen = ranked_by_class[base.name], screens[base.name]
    explained = {}
    base_r = relative_residuals(likelihood, base.map_simulated)
    for cl in classes:
        if cl.role == "enriched":
            own = {r.name: r for r in ranked_by_class[cl.name]}
            entry = next((r for r in ranked if r.name == cl.candidate), None)
            if entry is not None:
                ok, left = pattern_explained(entry, own.get(cl.candidate), rule.pattern_reduction)
                ok2, left2 = misfit_explained(located_misfit(base_screen, base_r), base_r,
                                              relative_residuals(likelihood, cl.map_simulated), rule.misfit_reduction)
                explained[cl.candidate] = (ok and ok2, left + left2)
    verdict = conclude(ranked, classes, rule, explained, numerics_comparable(base, base_screen.regions, rule))
    recorded = sorted({c for t in likelihood.observations for c in t.curves})
    warnings = {cl.name: list(cl.warnings) for cl in classes if cl.warnings}
    candidates_out = []
    for r, d in zip(ranked, verdict.candidates):
        by_evidence = d.named_by_evidence or d.confirmed
        candidates_out.append(DiagnosedCandidate(
            **{**vars(r), "named": r.named or by_evidence},
            named_by="signature" if r.named else "evidence" if by_evidence else None, decision=d.decision,
            confirmed=d.confirmed, pattern_explained=explained.get(r.name, (None, []))[0],
            pattern_left=tuple(explained.get(r.name, (None, []))[1])))
    summaries = tuple(ClassSummary(cl.name, cl.role, cl.candidate, cl.log_evidence, cl.J_g, cl.parameters,
                                   cl.sigma_eps, cl.wall_s, cl.warnings,
                                   verdict.log_bayes.get(cl.name, 0.0 if cl.role == "base" else
                                                         (verdict.model_form or {}).get("log_bayes")
                                                         if cl.role == "model form" else None),
                                   structure[cl.name], (cl.evidence or {}).get("method")) for cl in classes)
    regions = tuple(MismatchRegion(**vars(r), x_unit=likelihood.observations[r.test].curves[r.curve].x_unit)
                    for r in base_screen.regions)
    form = verdict.model_form
    if form is not None and form["prevails"]:
        model_form_class = next(cl for cl in classes if cl.role == "model form")
        form = {**form, "where": list(model_form_class.discrepancy[:5])}
    out = Diagnosis(description, alpha, base_screen.verdict, verdict.omitted_physics,
                    _recommendation(verdict.omitted_physics, ranked, base_screen, warnings.get(base.name), form),
                    regions,
                    tuple(base_screen.attribution), tuple(candidates_out), summaries, verdict.log_bayes, rule,
                    warnings, next_tests(ranked, base_screen.attribution, recorded), screens, model_form=form,
                    tentative=verdict.tentative)
    return replace(out, wall_s=time.perf_counter() - t0)


def _structure(report) -> dict:
    """Residual-structure statistics of one screening, summarized for a before/after table: the verdict, curves and
    structured curves, regions, the smallest adjusted p, the mean lag-1 autocorrelation, the mean |mean r|, the
    predictive coverage (fraction, None without samples), points outside the band, points, the screening's wall
    time (s)."""
    curves = report.curves
    covs = [c.coverage for c in curves if c.coverage is not None]
    return {"verdict": report.verdict, "structured_curves": sum(c.structured for c in curves),
            "curves": len(curves), "regions": len(report.regions),
            "min_p_adjusted": float(min(min(c.p_adjusted.values()) for c in curves)),
            "mean_lag1": float(np.mean([c.lag1 for c in curves])),
            "mean_abs_mean_r": float(np.mean([abs(c.mean) for c in curves])),
            "coverage": float(np.mean(covs)) if covs else None,
            "points_outside": int(sum(c.n_outside or 0 for c in curves)),
            "points": int(sum(c.n_points for c in curves)), "screen_wall_s": report.wall_s}


def next_tests(ranked: list, attribution: list, recorded: list) -> tuple:
    """What the records lack to test each candidate that is not already in the base model and not named: for each
    primary signature item, the covariate it needs when the records do not report it ("not reported": no test
    varies that condition, or the forward model does not report it), the curves it is measured on when none of them
    is recorded, and more tests at other levels when a between-test condition could not be tested by a few-test
    contrast. ranked: [CandidateScore]; attribution: the base class's [Attribution]. Returns (NextTest) for the
    candidates that need something."""
    attribution = {a.name: a for a in attribution}
    out = []
    for r in ranked:
        if r.in_base or r.named:
            continue
        needs = []
        for i in r.items:
            if i.role != "primary":
                continue
            a = attribution.get(i.covariate)
            if not any(names_curve(i.curves, c) for c in recorded):
                needs.append(f"record {' or '.join(i.curves)} (its pattern: {i.meaning})")
            elif i.status == "not reported":
                needs.append(f"tests that differ in {i.covariate}, reported as a covariate (its pattern: "
                             f"{i.meaning})")
            elif i.status == "not significant" and a is not None and a.kind == "between" and not a.contrast:
                needs.append(f"more tests at other levels of {i.covariate} (the tests cannot be compared on a "
                             f"common abscissa and too few for a permutation test: p = {i.p_adjusted:.2g})")
        if needs:
            out.append(NextTest(r.name, tuple(dict.fromkeys(needs))))
    return tuple(out)


def _recommendation(omitted, ranked, report, warnings=None, model_form=None) -> str:
    """The recommendation in one line, from the omitted physics, the ranked candidates, the base class's screening,
    its calibration warnings and the model-form verdict (`rank.conclude`)."""
    poor = f"; warnings on the base class's calibration: {'; '.join(warnings)}" if warnings else ""
    if report.verdict != "structured mismatch":
        return "no structured mismatch: no enrichment recommended" + poor
    if omitted != "none":
        return f"adopt the enriched class that adds {omitted}" + poor
    if model_form is not None and model_form["prevails"]:
        return ("a structured misfit of model form that none of the catalog's physics explains (a smooth discrepancy "
                f"without physics raises ln Z by {model_form['log_bayes']:.1f} and no enrichment beats it by the "
                "threshold): no enrichment adopted" + poor)
    named = [r.name for r in ranked if r.named]
    if not named:
        return "structured mismatch that no catalog signature explains: no enrichment recommended" + poor
    return (f"candidates named ({', '.join(named)}) but none confirmed by the Bayes factor and its own residual "
            "pattern: no enrichment adopted" + poor)


def _follows(a) -> str:
    """How the residual follows one significant covariate attribution, in words."""
    text = f"{a.name} ({a.kind}-test, R^2 = {a.r2:.2f}, p = {a.p_adjusted:.2g}"
    for curve, d in (a.contrast or {}).items():
        if "levels" in d:
            lo, hi = d["levels"]
            text += f"; {curve}: {hi} {100 * d['mean']:+.1f} % relative to {lo}"
        else:
            text += f"; {curve}: {'rises' if d['z'] > 0 else 'falls'} with it"
    return text + ")"


def _fmt(v, spec=".3g"):
    if isinstance(v, (list, tuple)):  # per-curve sigma of error groups: the distinct values
        return " / ".join(format(x, spec) for x in dict.fromkeys(v))
    return "-" if v is None else format(v, spec)


def _region_words(r) -> str:
    where = "above" if r.sign == "+" else "below"
    unit = "" if r.x_unit == "-" else f" {r.x_unit}"
    return (f"{r.curve} at {r.x_start:.3g} to {r.x_end:.3g}{unit}: recorded {where} simulated by "
            f"{abs(100 * r.mean_relative):.1f} %")


def _engineer_summary(d: Diagnosis) -> list:
    """The conclusion in words, from the diagnosis."""
    poor = [f"Calibration warnings of {name}: {'; '.join(w)}." for name, w in d.warnings.items()]
    if d.verdict != "structured mismatch":
        return ["The base model's residuals are consistent with the measurement noise (no test, curve or strain "
                "range misfits beyond the false-alarm level): nothing is missing that these records can reveal, and "
                "no enrichment is recommended."] + poor
    lines = poor
    by_test = {}
    for r in d.mismatch_regions:
        by_test.setdefault(r.test, []).append(r)
    parts = [f"{t} ({', '.join(_region_words(r) for r in rs)})" for t, rs in by_test.items()]
    lines.append("Misfit located in " + ("; ".join(parts) if parts else "the curves' overall scatter or trend "
                                          "(no single contiguous region)") + ".")
    sig = [a for a in d.attribution if a.p_adjusted <= d.alpha and a.name != POSITION]
    if sig:
        lines.append("The structured residual follows " + ", ".join(_follows(a) for a in sig) + ".")
    else:
        lines.append("No reported covariate explains it beyond the false-alarm level.")
    top = next((c for c in d.candidates if c.named_by == "signature"), None)
    if top is not None:
        said = [i.meaning + ("" if i.rank_correlation is None else f" (rank correlation {i.rank_correlation:+.2f})")
                for i in top.items if i.status == "supports"]
        lines.append(f"This is the signature of {top.name}: " + "; ".join(said) + ".")
    else:
        lines.append("No catalog entry's signature explains this structure.")
    by_evidence = [c.name for c in d.candidates if c.named_by == "evidence"]
    if by_evidence:
        lines.append(f"The evidence points at {', '.join(by_evidence)}: the enriched class raises ln Z beyond the "
                     f"threshold {d.rule.threshold:g} and no primary item of the signature contradicts it.")
    for c in d.candidates:
        if c.named and not c.confirmed:
            lines.append(f"{c.name}: {c.decision}.")
    if d.omitted_physics == "none" and d.next_tests:
        lines.append("To separate the remaining hypotheses: " + "; ".join(
            f"{n.candidate} needs {', '.join(n.needs)}" for n in d.next_tests) + ".")
    if d.model_form is not None and d.model_form["prevails"]:
        where = "; ".join(f"{w['test']} {w['curve']} at {w['x_start']:.3g} to {w['x_end']:.3g}"
                          f"{'' if w['x_unit'] == '-' else ' ' + w['x_unit']} ({w['x_name']}): up to "
                          f"{100 * w['max']:.1f} % (RMS {100 * w['rms']:.1f} %)" for w in d.model_form["where"])
        lines.append("The misfit is of model form: a smooth discrepancy without physics (the base plus a Gaussian-"
                     f"process discrepancy per curve) explains it with ln B = {d.model_form['log_bayes']:.1f} over the "
                     "base, and no catalog physics beats that by the threshold. It lies in: " + where + ". Look for "
                     "a convention of the model or the data (specific volume, elasticity, the compression law, the "
                     "initial K0), the discretisation of the simulation, or an effect outside the catalog.")
    if d.omitted_physics != "none":
        cl = next(c for c in d.classes if c.role == "enriched" and c.candidate == d.omitted_physics)
        lnb = d.log_bayes[cl.name]
        bf = f"{math.exp(lnb):.3g}" if lnb < 700 else f"e^{lnb:.0f}"
        lines.append(f"The omitted physics is {d.omitted_physics}: the evidence favours {cl.name} over the "
                     f"base model by ln B = {lnb:.1f} (Bayes factor {bf}).")
    else:
        lines.append(f"Conclusion: {d.recommendation}.")
    return lines


def markdown(d: Diagnosis) -> str:
    """A `records.Diagnosis` as a Markdown report: the conclusion in words, the model classes before and after, the
    enriched parameters, the ranked candidates and the screening of every class."""
    lines = ["# Missing-physics diagnosis", ""]
    if d.description:
        lines += [d.description, ""]
    lines += ["## Conclusion", ""] + _engineer_summary(d) + ["", f"Omitted physics: **{d.omitted_physics}**. "
                                                              f"Recommendation: {d.recommendation}.", ""]
    lines += ["## Model classes (before / after)", "",
              "| class | role | ln Z | ln B vs base | J_g at MAP (per test) | sigma_eps | verdict | "
              "structured curves | regions | mean lag-1 | coverage (95 %) |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
    for c in d.classes:
        s = c.structure
        jg = ", ".join(f"{t} {v:.3g}" for t, v in (c.J_g or {}).items() if isinstance(v, float))
        bound = " (95 % lower bound)" if c.evidence_method == "lower bound" else ""
        lines.append(f"| {c.name} | {c.role} | {_fmt(c.log_evidence, '.2f')}{bound} | "
                     f"{_fmt(c.log_bayes_vs_base, '+.2f')} | {jg} | {_fmt(c.sigma_eps, '.4f')} | {s['verdict']} | "
                     f"{s['structured_curves']}/{s['curves']} | {s['regions']} | {s['mean_lag1']:+.2f} | "
                     f"{_fmt(None if s['coverage'] is None else 100 * s['coverage'], '.0f')} % |")
    for c in d.classes:
        if c.role == "enriched" and c.parameters:
            lines += ["", f"Parameters of {c.name} (posterior):", "",
                      "| parameter | MAP | mean | std | 95 % interval |", "|---|---|---|---|---|"]
            for n, p in c.parameters.items():
                lines.append(f"| {n} | {p['map']:.4g} | {p['mean']:.4g} | {p['std']:.3g} | "
                             f"[{p.get('q2.5', float('nan')):.4g}, {p.get('q97.5', float('nan')):.4g}] |")
    lines += ["", "## Candidate physics ranked by signature score", "",
              "Score = sum of weight x R^2 over the signature items the screening supports (significant after Holm and "
              "in the expected direction), divided by the sum of the weights (inference.diagnosis.rank).", "",
              "| rank | candidate | score | named | decision | items (covariate: status) |",
              "|---|---|---|---|---|---|"]
    for k, c in enumerate(d.candidates, 1):
        items = "; ".join(f"{i.covariate}: {i.status}" for i in c.items)
        lines.append(f"| {k} | {c.name} | {c.score:.3f} | {'yes' if c.named else 'no'} | {c.decision} | {items} |")
    for name, rep in d.screens.items():
        lines += ["", f"# Screening of {name}", "", rep.to_markdown()]
    return "\n".join(lines) + "\n"

"""The chain of a stepwise discovery (`loop.run_loop`, step 6) in numbers and words: each step's base class, the
class it confirmed, ln B over the step's base (the class the previous step confirmed), and the misfit left per curve
(RMS of the relative residual r = U_obs/U_sim - 1, Eq. (1) of the screening, over the points above the likelihood's
floor)."""
from __future__ import annotations

import numpy as np

from .screening import relative_residuals

__all__ = ["misfit_per_curve", "chain_steps", "chain_markdown"]


def misfit_per_curve(likelihood, cls) -> dict:
    """{"test/curve": RMS relative residual (-)} of the class ``cls`` (a `records.ModelClass`) at its MAP."""
    out = {}
    for (test, curve), r in relative_residuals(likelihood, cls.map_simulated).items():
        r = r[np.isfinite(r)]
        out[f"{test}/{curve}"] = float(np.sqrt(np.mean(r ** 2))) if r.size else float("nan")
    return out


def chain_steps(likelihood, result) -> list:
    """One row per step of the loop's ``result`` (`loop.LoopResult`, its later steps in ``steps``): {step, base,
    verdict (the base's screening), confirmed (candidate or "none"; a tentative one confirmed jointly with the next
    step's, `loop` step 6), jointly_with, alone (a jointly confirmed candidate's decision on its own),
    tentative_refused ({candidate, why} or None), class (the confirmed class or None), log_bayes_over_previous (its
    ln Z minus the step's base's), misfit_before (the base's per curve), misfit_left (the confirmed class's, else the
    base's)}."""
    rows = []
    for k, step in enumerate([result, *result.steps], start=1):
        base = step.classes[0]
        joint = step.joint or {}
        confirmed = joint["tentative"] if joint.get("explained") else step.final.omitted_physics
        cls = next((c for c in step.classes if c.role == "enriched" and c.candidate == confirmed), None)
        before = misfit_per_curve(likelihood, base)
        rows.append({"step": k, "base": base.name, "verdict": step.first.verdict, "confirmed": confirmed,
                     "jointly_with": joint.get("with") if joint.get("explained") else None,
                     "alone": joint.get("alone", "") if joint.get("explained") else "",
                     "tentative_refused": None if not joint or joint["explained"] else
                     {"candidate": joint["tentative"], "why": "; ".join(joint["left"])},
                     "class": None if cls is None else cls.name,
                     "log_bayes_over_previous": None if cls is None else cls.log_evidence - base.log_evidence,
                     "misfit_before": before, "misfit_left": before if cls is None else misfit_per_curve(likelihood,
                                                                                                       cls)})
    return rows


def chain_markdown(rows: list) -> str:
    """The chain as Markdown: one line per step, then the misfit per curve at each step (RMS, %)."""
    lines = ["# Stepwise discovery", ""]
    for r in rows:
        if r["class"] is None:
            why = ("its residual is consistent with noise" if r["verdict"] != "structured mismatch"
                   else "nothing more is confirmed")
            if r["tentative_refused"]:
                why = (f"{r['tentative_refused']['candidate']} was tried as the next step's base but is not confirmed "
                       f"({r['tentative_refused']['why']})")
            lines.append(f"- Step {r['step']}: base {r['base']}; {why}: the discovery stops.")
        else:
            joint = ("" if not r["jointly_with"] else
                     f" (alone it was {r['alone'] or 'not confirmed'}; confirmed jointly with {r['jointly_with']}, "
                     "whose class on top of it removes the located misfit and beats the model-form class)")
            lines.append(f"- Step {r['step']}: base {r['base']}; confirmed **{r['confirmed']}**: {r['class']}, "
                         f"ln B = {r['log_bayes_over_previous']:+.1f} over the step's base{joint}.")
    curves = list(rows[0]["misfit_before"])
    lines += ["", "Misfit per curve (RMS of U_obs/U_sim - 1, %): the first base, then the class each step leaves.",
              "", "| curve | base | " + " | ".join(f"after step {r['step']}" for r in rows) + " |",
              "|---|---|" + "---|" * len(rows)]
    for c in curves:
        cells = [f"{100 * rows[0]['misfit_before'][c]:.2f}"] + [f"{100 * r['misfit_left'][c]:.2f}" for r in rows]
        lines.append(f"| {c} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"

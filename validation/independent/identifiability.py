"""Whether a hidden effect shows in a one-dimensional programme's records at all: the generator's own plain clay
fitted to the clay with the effect, with the generator's code only.

    python -m validation.independent.identifiability [--programmes crs il relaxation] [--effects destructuration ...]
                                                 [--seeds 1 2 3]

For a programme of the oedometer (crs, il, relaxation: :data:`validation.independent.programmes.PROGRAMMES`), an effect
and a noise seed: the noise-free records of the clay with the effect, at the points that seed logs
(:func:`validation.independent.recording.logged_times`), against the plain clay (no effect) with M, lambda, kappa and
the preconsolidation sigma'_p free, fitted by least squares (scipy) on the records in units of the generator's own
noise standard deviation (recording docstring): sigma'_v where it is measured, sqrt((0.015 sigma'_v)^2 + 0.3^2)
kPa; the axial strain where it is a response (load and hold stages), sqrt((0.01 eps)^2 + 0.002^2) %. The best fit's
sum of squares E is the largest gain of log-likelihood, E/2, that any model class reproducing the effect exactly
can have over the plain clay on those records (a Gaussian likelihood with the known noise); a Bayes factor must
also pay for the added parameters (about 5-10 units of ln Z with the catalog's priors). An effect with E/2 below the
diagnosis loop's threshold of ln B (20) cannot be confirmed from that programme by any calibrated class: a miss
there is a programme that does not show the effect, not a fault of the diagnosis.

With ``--against EFFECT`` the fitted clay is the generator's clay with that effect instead of the plain one, its own
parameters free as well (:data:`AGAINST_FREE`: C_alpha_e of the creep-rate law; chi0 and a of the bonding): E/2 is
then the largest gain a second effect can add on top of the first, e.g. time-dependent swelling on top of viscosity
in the multi-effect programmes (``--effects viscosity+time-dependent swelling --against viscosity``), whose records
are those of the effect cases' logging and noise streams (:mod:`validation.independent.multi`).
"""
from __future__ import annotations

import argparse

import numpy as np
from scipy.optimize import least_squares

from .programmes import CLAY, COMBINED, EFFECTS, PROGRAMMES, simulate
from .recording import SEEDS, STRAIN_NOISE, STRESS_NOISE, logged_times

__all__ = ["ONE_DIMENSIONAL", "FREE", "AGAINST_FREE", "records_with_effect", "plain_residual", "best_plain_fit",
           "main"]

ONE_DIMENSIONAL = ("crs", "il", "relaxation")
#: the plain clay's free values and their bounds (the study files' priors)
FREE = {"M": (0.8, 1.6), "lambda_": (0.1, 0.5), "kappa": (0.01, 0.09), "sigma_p": (30.0, 400.0)}
#: the parameters of the effect fitted against, free where it has them (the bounds of the catalog's enrichment priors:
#: C_alpha_e of viscosity; chi0 and the destructuration rate, xi there, a here)
AGAINST_FREE = {"C_alpha_e": (0.001, 0.1), "chi0": (0.1, 50.0), "a": (1.0, 30.0)}


def best_plain_fit(programme: str, effect: str, seed: int, start: dict | None = None, against: str = "none") -> dict:
    """The plain clay (or the clay with the effect ``against``, its :data:`AGAINST_FREE` parameters free too) closest
    to the records of the clay with ``effect`` (module docstring), the search started at ``start`` (default: the
    generating values): {"E": sum of squares in noise units, "n": responses compared, "values": the fitted clay,
    "ln_L_gain": E/2}."""
    own = {**EFFECTS, **COMBINED}[against]
    free = {**FREE, **{k: v for k, v in AGAINST_FREE.items() if k in own}}
    names = list(free)
    truth = records_with_effect(programme, effect, seed)
    x0 = np.array([{**CLAY, **own, **(start or {})}[n] for n in names], dtype=float)
    lower, upper = (np.array([free[n][k] for n in names]) for k in (0, 1))
    fit = least_squares(lambda x: plain_residual(programme, truth, dict(zip(names, x)), against), x0,
                        bounds=(lower, upper), x_scale=np.where(x0 > 0, x0, 1.0), diff_step=1e-4, max_nfev=200)
    E = float(np.sum(fit.fun ** 2))
    return {"E": E, "n": int(fit.fun.size), "values": dict(zip(names, map(float, fit.x))), "ln_L_gain": 0.5 * E}


def records_with_effect(programme: str, effect: str, seed: int) -> list:
    """Per test of ``programme``: [(stage, its trajectory rows, the times ``seed`` logs)] of the clay with ``effect``
    (noise-free; :func:`validation.independent.recording.logged_times`)."""
    index = list(PROGRAMMES).index(programme)
    tests = PROGRAMMES[programme][1]
    return [[(stage, seg, times) for _, stage, seg, times in logged_times(t, *simulate(t, effect), seed, index, j)]
            for j, t in enumerate(tests)]


def plain_residual(programme: str, truth: list, clay: dict, against: str = "none") -> np.ndarray:
    """(plain clay, or the clay with the effect ``against``, with the values ``clay`` - the records ``truth`` of
    :func:`records_with_effect`) at the logged times, in units of the noise standard deviation at the latter's values
    (module docstring); a plain-clay stage shorter than a logged time takes its end value."""
    out = []
    for test, stages in zip(PROGRAMMES[programme][1], truth):
        spans, rows = simulate(test, against, clay)
        r = np.array(rows)
        for stage, seg_t, times in stages:
            a, b = spans[stage.name]
            seg = r[a:b]
            if stage.kind != "load":
                s_t = np.interp(times, seg_t[:, 0], seg_t[:, 3])
                s = np.interp(times, seg[:, 0], seg[:, 3])
                out.append((s - s_t) / np.hypot(STRESS_NOISE[0] * s_t, STRESS_NOISE[1]))
            if stage.kind in ("load", "creep", "consolidation"):
                e_t = 100.0 * np.interp(times, seg_t[:, 0], seg_t[:, 1])
                e = 100.0 * np.interp(times, seg[:, 0], seg[:, 1])
                out.append((e - e_t) / np.hypot(STRAIN_NOISE[0] * e_t, STRAIN_NOISE[1]))
    return np.concatenate(out)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m validation.independent.identifiability",
                                 description=__doc__.split("\n")[0])
    ap.add_argument("--programmes", nargs="+", default=list(ONE_DIMENSIONAL), choices=ONE_DIMENSIONAL)
    effects = ["none", "viscosity", "destructuration", *COMBINED]
    ap.add_argument("--effects", nargs="+", default=["destructuration", "viscosity", "none"], choices=effects)
    ap.add_argument("--against", default="none", choices=["none", "viscosity", "destructuration"],
                    help="the effect the fitted clay holds (default: the plain clay)")
    ap.add_argument("--seeds", type=int, nargs="+", default=list(SEEDS))
    args = ap.parse_args(argv)
    print(f"| programme | effect | seed | records | largest ln L gain E/2 over the {args.against} clay | clay fitted "
          "|\n|---|---|---|---|---|---|")
    for prog in args.programmes:
        for effect in args.effects:
            for seed in args.seeds:
                r = best_plain_fit(prog, effect, seed, against=args.against)
                fitted = ", ".join(f"{k} {v:.4g}" for k, v in r["values"].items())
                print(f"| {prog} | {effect} | {seed} | {r['n']} | {r['ln_L_gain']:.1f} | {fitted} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

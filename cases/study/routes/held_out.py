"""Tests a study predicts but does not calibrate on (``role = "predict"``; docs/reference.md section 10): the
model error (P2) by leave-one-test-out calibrations, growing with a test's distance from the calibrated tests in the
space of their conditions, the predictions of the held-out tests scored with it ((P1), (P3), (P4)), and what a route
writes of them (report lines, predictions.png, summary.json). Shared by the general route (laboratory and
pressuremeter tests) and the sand route; a route supplies the likelihood of any subset of its tests and every
test's conditions."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import inference
from cases.study.outputs.figures.labels import QUANTITY_LABELS
from cases.study.outputs.predictions import draws_at_records, plot_predictions, prediction_lines, score_predictions
from cases.study.programme import split_key
from cases.study.runner import calibrate, method_name
from inference.executors import mpi_world
from inference.prediction import ModelError, StateSpace

__all__ = ["leave_one_out", "amplitudes_at", "predict_held_out"]


def leave_one_out(names, likelihood_of, prior, run, out, seed, n_samples, sampler, space) -> tuple:
    """The model error (P2) of docs/reference.md section 10 by leaving out each calibration test of ``names`` in
    turn: calibrate on the others (``likelihood_of(tests)``: the likelihood of those tests, under ``prior``; the same
    settings, in ``out``/leave_one_out/<test>), the left-out test's relative residuals at that calibration's MAP
    beyond the variance it predicts (its noise and its parameters' spread), and its distance to the nearest of the
    others in ``space`` (:class:`inference.prediction.StateSpace`). Returns (:class:`inference.prediction.ModelError`
    pooled over the left-out tests, check rows: each left-out curve's coverage without the model-error term and with
    the model error of the other left-out tests only). (no model error, []) with fewer than two calibration tests; a
    left-out test whose calibration or prediction fails is said on stderr and skipped."""
    names = list(names)
    if len(names) < 2:
        return ModelError({}, {}), []
    folds = []
    for name in names:
        others = [t for t in names if t != name]
        try:
            like = likelihood_of(others)
            like_left = likelihood_of([name])
            # under mpirun the other ranks have left with the main run's executor: the root calibrates alone
            executor = inference.SerialExecutor() if mpi_world() is not None else None
            post = calibrate(like, prior, run, Path(out) / "leave_one_out" / name, seed, n_samples, executor,
                             **sampler)
            like_left.bind(post.names)
            residuals = like_left.residuals(post.map_theta)
            sims, sigma = draws_at_records(like_left, post)
        except Exception as exc:  # noqa: BLE001 - a fold that cannot be run leaves the others their say
            print(f"note: leave-one-out without {name}: {type(exc).__name__}: {exc}", file=sys.stderr, flush=True)
            continue
        reach = space.nearest(name, others)
        terms = {}
        for k, key in enumerate(like_left.curve_keys):
            drawn = sims[key][:, like_left.masks[key]]
            explained = float(np.mean(sigma[:, k] ** 2) + np.mean(np.var(drawn / drawn.mean(axis=0), axis=0)))
            terms[key] = (residuals[key], explained, reach)
        folds.append((name, like_left, post, reach, terms))

    def model_error(chosen):
        curves = {}
        for *_, terms in chosen:
            for (_, curve), term in terms.items():
                curves.setdefault(split_key(curve)[0], []).append(term)
        return ModelError.from_held_out(curves)

    check = []
    for k, (name, like_left, post, reach, _) in enumerate(folds):
        others = model_error(folds[:k] + folds[k + 1:])
        amplitude = amplitudes_at(others, like_left, {name: reach})
        for r in score_predictions(like_left, post, [name], amplitude):
            known = split_key(r["curve"])[0] in others.excess
            check.append({"test": name, "curve": r["curve"], "distance": reach,
                          "coverage_noise": r["noise"]["coverage"],
                          "coverage_model": r["model"]["coverage"] if known else None,
                          "amplitude": r["amplitude"] if known else None})
    return model_error(folds), check


def amplitudes_at(model_error, like, distance: dict) -> dict:
    """{(test, curve): a_k} of the curves in ``like`` of the tests of ``distance`` {test: its distance to the
    calibrated tests} (:class:`inference.prediction.ModelError`, quantity k of each curve)."""
    return {(t, c): model_error.amplitude(split_key(c)[0], d) for t, d in distance.items()
            for c in like.observations[t].curves}


def predict_held_out(like_all, calibrated, predicted, likelihood_of, prior, post, run, out, seed, n_samples, sampler,
                     title: str, conditions: dict) -> tuple:
    """The predictions of the ``predicted`` tests (``like_all``: the likelihood of every test) from the calibration
    ``post`` on the ``calibrated`` ones, with the model error of :func:`leave_one_out` at each predicted test's
    distance to the nearest calibrated test (``conditions`` {test: features}, every test's, e.g.
    :func:`cases.study.programme.condition_features`): (report lines (the Predictions section), summary.json's
    ``predictions`` entry, the amplitudes {(test, curve): a_k}); predictions.png in ``out`` (``title`` above it)."""
    space = StateSpace(conditions)
    model_error, check = leave_one_out(calibrated, likelihood_of, prior, run, out, seed, n_samples, sampler, space)
    distance = {t: space.nearest(t, calibrated) for t in predicted}
    amplitude = amplitudes_at(model_error, like_all, distance)
    rows = score_predictions(like_all, post, predicted, amplitude)
    for r in rows:
        r["distance"] = distance[r["test"]]
    plot_predictions(Path(out) / "predictions.png", rows, f"{title}: {method_name(run.method)}, predictions "
                     "(95 % bands)", QUANTITY_LABELS)
    summary = {"model_error": {"excess_variance": model_error.excess, "distance": model_error.distance},
               "leave_one_out": check,
               "curves": [{k: v for k, v in r.items() if k in ("test", "curve", "unit", "point_error", "amplitude",
                                                                "distance")}
                          | {b: {k: v for k, v in r[b].items() if k not in ("lower", "upper")}
                             for b in ("noise", "model")} for r in rows]}
    return prediction_lines(rows, model_error, check), summary, amplitude

"""Tests a study predicts but does not calibrate on (``role = "predict"``; docs/reference.md section 10): the
model-error amplitudes (P2) by leave-one-test-out calibrations, the predictions of the held-out tests scored with
them ((P1), (P3), (P4)), and what a route writes of them (report lines, predictions.png, summary.json). Shared by
the general route (laboratory and pressuremeter tests) and the sand route; a route supplies the likelihood of any
subset of its tests."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import inference
from cases.study.outputs.figures.labels import QUANTITY_LABELS
from cases.study.outputs.predictions import draws_at_records, plot_predictions, prediction_lines, score_predictions
from cases.study.runner import calibrate, method_name
from inference.executors import mpi_world
from inference.prediction import model_error_amplitude

__all__ = ["leave_one_out", "predict_held_out"]


def leave_one_out(names, likelihood_of, prior, run, out, seed, n_samples, sampler) -> tuple:
    """The model-error amplitudes (P2) of docs/reference.md section 10 by leaving out each calibration test of
    ``names`` in turn: calibrate on the others (``likelihood_of(tests)``: the likelihood of those tests, under
    ``prior``; the same settings, in ``out``/leave_one_out/<test>), the left-out test's relative residuals at that
    calibration's MAP beyond the variance it predicts (its noise and its parameters' spread). Returns ({curve name:
    a_k} pooled over the left-out tests, check rows: each left-out curve's coverage without the model-error term and
    with the amplitude of the other left-out tests only). ({}, []) with fewer than two calibration tests; a left-out
    test whose calibration or prediction fails is said on stderr and skipped."""
    names = list(names)
    if len(names) < 2:
        return {}, []
    folds = []
    for name in names:
        try:
            like = likelihood_of([t for t in names if t != name])
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
        explained = {}
        for k, key in enumerate(like_left.curve_keys):
            drawn = sims[key][:, like_left.masks[key]]
            explained[key] = float(np.mean(sigma[:, k] ** 2) + np.mean(np.var(drawn / drawn.mean(axis=0), axis=0)))
        folds.append((name, like_left, post, {key: (residuals[key], explained[key]) for key in like_left.curve_keys}))

    def amplitudes(chosen):
        curves = {}
        for _, _, _, terms in chosen:
            for (_, curve), term in terms.items():
                curves.setdefault(curve, []).append(term)
        return {c: model_error_amplitude(*zip(*terms)) for c, terms in curves.items()}

    check = []
    for k, (name, like_left, post, _) in enumerate(folds):
        others = amplitudes(folds[:k] + folds[k + 1:])
        for r in score_predictions(like_left, post, [name], others):
            check.append({"test": name, "curve": r["curve"], "coverage_noise": r["noise"]["coverage"],
                          "coverage_model": r["model"]["coverage"] if r["curve"] in others else None,
                          "amplitude": others.get(r["curve"])})
    return amplitudes(folds), check


def predict_held_out(like_all, calibrated, predicted, likelihood_of, prior, post, run, out, seed, n_samples, sampler,
                     title: str) -> tuple:
    """The predictions of the ``predicted`` tests (``like_all``: the likelihood of every test) from the calibration
    ``post`` on the ``calibrated`` ones, with the model-error amplitudes of :func:`leave_one_out`: (report lines (the
    Predictions section), summary.json's ``predictions`` entry, the amplitudes {curve: a_k}); predictions.png in
    ``out`` (``title`` above it)."""
    amplitude, check = leave_one_out(calibrated, likelihood_of, prior, run, out, seed, n_samples, sampler)
    rows = score_predictions(like_all, post, predicted, amplitude)
    plot_predictions(Path(out) / "predictions.png", rows, f"{title}: {method_name(run.method)}, predictions "
                     "(95 % bands)", QUANTITY_LABELS)
    summary = {"model_error_amplitude": amplitude, "leave_one_out": check,
               "curves": [{k: v for k, v in r.items() if k in ("test", "curve", "unit", "point_error", "amplitude")}
                          | {b: {k: v for k, v in r[b].items() if k not in ("lower", "upper")}
                             for b in ("noise", "model")} for r in rows]}
    return prediction_lines(rows, amplitude, check), summary, amplitude

"""Predictions of the tests a study did not calibrate on (``role = "predict"``; docs/reference.md section 10): the
posterior draws at the recorded points, the 95 % band of (P1) without and with the model-error term, its scores
(coverage, mean width, interval score (P3), CRPS (P4), the point error of the predictive mean), the report's
Predictions section and predictions.png. Widths, scores and values are in each curve's unit (kPa for q and u, - for
the void ratio e); relative quantities are fractions written as %.
"""
from __future__ import annotations

import numpy as np

from cases.study.outputs.figures.canvas import save
from cases.study.outputs.figures.sheet import padded, panel_sheet
from inference.diagnosis import simulate_samples
from inference.prediction import band_scores, prediction_bands

__all__ = ["draws_at_records", "score_predictions", "prediction_lines", "plot_predictions"]


def draws_at_records(like, post, n_draws=200, seed=0):
    """Up to ``n_draws`` final-stage samples of ``post`` simulated at the recorded points of ``like``'s curves:
    ({(test, curve): (m, n_recorded)}, each curve's error parameter (m, n_curves) in ``like.curve_keys`` order). A
    draw whose forward solve fails is left out (m counts the others)."""
    rng = np.random.default_rng(seed)
    idx = rng.choice(len(post.samples), size=min(n_draws, len(post.samples)), replace=False)
    draws = post.samples[idx]
    like.bind(post.names)
    try:
        sims, sigma = simulate_samples(like, draws)
    except Exception:  # noqa: BLE001 - one failed draw: keep the others, each solved alone
        kept, rows = [], []
        for i, theta in enumerate(draws):
            try:
                rows.append(like.simulated_many(theta[None, :]))
                kept.append(i)
            except Exception:  # noqa: BLE001 - a draw outside the model's reach is no prediction
                continue
        if not kept:
            raise
        sims = {key: np.concatenate([r[key] for r in rows]) for key in rows[0]}
        sigma = like.curve_sigmas(draws[kept])
    return sims, sigma if sigma.ndim == 2 else np.repeat(sigma[:, None], len(like.curve_keys), axis=1)


def score_predictions(like, post, tests, amplitude: dict, level=0.95, n_draws=200, seed=0) -> list:
    """The predictions of ``tests`` (names in ``like``, whose calibration produced ``post``) with the model-error
    amplitudes ``amplitude`` {(test, curve): a_k} (a curve not named: none): one row per (test, curve) with its
    recorded points (x, observed), the MAP-free predictive mean, the bands without ("noise": parameters and noise)
    and with ("model": + model error) the model-error term, its ``amplitude``, and their scores
    (:func:`inference.prediction.band_scores`) plus ``point_error`` (RMS of the predictive mean's relative error, the
    same in both)."""
    sims, sigma = draws_at_records(like, post, n_draws, seed)
    column = {key: k for k, key in enumerate(like.curve_keys)}
    rows = []
    for label, amp in (("noise", {}), ("model", amplitude)):
        bands = prediction_bands(like, sims, sigma, amp, level=level)
        for name in tests:
            for curve in like.observations[name].curves:
                key = (name, curve)
                relative = np.sqrt(sigma[:, column[key]] ** 2 + amp.get(key, 0.0) ** 2)
                mean = sims[key]
                used = like.masks[key]
                scores = band_scores(bands[key], mean, np.abs(mean) * relative[:, None], used)
                if label == "noise":
                    c = like.observations[name].curves[curve]
                    error = (bands[key].mean[used] - c.y[used]) / c.y[used]
                    rows.append({"test": name, "curve": curve, "unit": c.y_unit, "x": c.x, "observed": c.y,
                                 "x_label": f"{c.x_name} ({c.x_unit})",
                                 "mean": bands[key].mean, "point_error": float(np.sqrt(np.mean(error**2))),
                                 "amplitude": float(amplitude.get(key, 0.0))})
                row = next(r for r in rows if (r["test"], r["curve"]) == key)
                row[label] = {**scores, "lower": bands[key].lower, "upper": bands[key].upper}
    return rows


def _pooled(rows, label, curve):
    """Coverage, relative width and point error of ``curve`` over the rows, each point weighted equally."""
    chosen = [r for r in rows if r["curve"] == curve]
    n = np.array([r[label]["n"] for r in chosen], dtype=float)
    return tuple(float(np.sum(n * np.array([r[label][k] if k != "point_error" else r[k] for r in chosen])) / n.sum())
                 for k in ("coverage", "relative_width", "point_error"))


def prediction_lines(rows, model_error, check: list, level=0.95) -> list:
    """The report's Predictions section: the model error (:class:`inference.prediction.ModelError`) and its check
    (``check``: rows of the leave-one-test-out calibrations, :func:`cases.study.routes.held_out.leave_one_out`), one
    table row per predicted curve (``distance``: its test's distance to the calibrated tests; ``amplitude``: its a_k)
    and the pooled coverage per quantity, without and with the model-error term."""
    pct = f"{100 * level:g} %"
    lines = ["## Predictions", "",
             f"Tests not calibrated on (role = \"predict\"), predicted from the posterior and compared with their "
             f"measurements: {pct} band of (P1) (docs/reference.md section 10) from the posterior draws (parameters) "
             "and the noise of Eq. (1) (\"noise\"), and with the model-error term of the curve's quantity added "
             "(\"+ model\"). Coverage: fraction of the measured points inside the band (the goal is about "
             f"{pct}); width: mean band width (the curve's unit) and relative to the measured value; interval score "
             "(P3) and CRPS (P4): mean penalties in the curve's unit, lower is better; point error: RMS relative "
             "error of the predictive mean.", ""]
    if model_error.excess:
        lines += ["Model error (P2), from the leave-one-test-out predictions of the calibration tests: the amplitude "
                  "a_k of each quantity grows with a test's distance d from the nearest calibrated test in the space "
                  "of the tests' conditions (initial void ratio and stress, stage stresses, rates, drainage; each "
                  "scaled by its range over the study's tests), a_k^2 = excess_k d / d_k: " + ", ".join(
                      f"{k} {100 * np.sqrt(v):.2f} % at d_k = {model_error.distance[k]:.2f}"
                      for k, v in model_error.excess.items()) + " (d_k: the left-out tests' mean distance to "
                  "their calibration's tests). A test inside the calibrated range is nearer than the left-out tests "
                  "were and gets less; one beyond it gets more.", ""]
        if len({c["test"] for c in check}) == 2:
            lines += ["With two calibration tests each leave-one-out calibration has one test and predicts the other "
                      "by extrapolation (to another density or stress): the amplitude then rests on two one-test "
                      "calibrations (notes/predictions.md). A third calibration test inside the range of the others "
                      "makes it a measure of interpolation.", ""]
    else:
        lines += ["No model-error amplitude: it is estimated by leaving out each calibration test in turn, which "
                  "needs at least two calibration tests; the bands carry parameters and noise only.", ""]
    if check:
        lines += ["Check by leave-one-test-out (each calibration test predicted from a calibration on the others, its "
                  "model error from the other left-out tests only, at its own distance d):", "",
                  "| left-out test | curve | distance d | coverage noise | coverage + model | "
                  "model error a_k used (%) |",
                  "|---|---|---|---|---|---|"]
        for c in check:
            model = ("- | -" if c["amplitude"] is None else
                     f"{100 * c['coverage_model']:.0f} % | {100 * c['amplitude']:.2f}")
            lines.append(f"| {c['test']} | {c['curve']} | {c['distance']:.2f} | {100 * c['coverage_noise']:.0f} % | "
                         f"{model} |")
        lines.append("")
    lines += ["| test | curve | points | distance d | model error a_k | coverage noise | width noise | "
              "coverage + model | width + model | interval score + model | CRPS + model | point error |",
              "|---" * 12 + "|"]
    for r in rows:
        n, m = r["noise"], r["model"]
        lines.append(f"| {r['test']} | {r['curve']} ({r['unit']}) | {n['n']} | {r['distance']:.2f} | "
                     f"{100 * r['amplitude']:.2f} % | "
                     f"{100 * n['coverage']:.0f} % | "
                     f"{n['mean_width']:.4g} ({100 * n['relative_width']:.2g} %) | {100 * m['coverage']:.0f} % | "
                     f"{m['mean_width']:.4g} ({100 * m['relative_width']:.2g} %) | {m['interval_score']:.4g} | "
                     f"{m['crps']:.4g} | {100 * r['point_error']:.2g} % |")
    lines += ["", "Pooled over the predicted tests (every point weighs the same): " + "; ".join(
        "{}: coverage {:.0f} % / {:.0f} %, relative width {:.2g} % / {:.2g} %, point error {:.2g} %".format(
            curve, 100 * _pooled(rows, "noise", curve)[0], 100 * _pooled(rows, "model", curve)[0],
            100 * _pooled(rows, "noise", curve)[1], 100 * _pooled(rows, "model", curve)[1],
            100 * _pooled(rows, "noise", curve)[2])
        for curve in dict.fromkeys(r["curve"] for r in rows)) + " (noise / + model).", ""]
    return lines


def plot_predictions(path, rows, title, labels):
    """predictions.png: one row per predicted test, one panel per curve, on a sheet
    (:mod:`cases.study.outputs.figures.sheet`): the measurements, the predictive mean and the bands without and with
    the model-error term, each band's share of the measurements in its panel; ``labels`` {curve: axis label}."""
    tests = list(dict.fromkeys(r["test"] for r in rows))
    ncol = max(sum(r["test"] == t for r in rows) for t in tests)
    sheet, frames = panel_sheet(len(tests) * ncol, (4.6, 3.0), ncol, legend=4)
    ax = sheet.ax
    for row, t in enumerate(tests):
        for col, r in enumerate([r for r in rows if r["test"] == t]):
            order = np.argsort(r["x"])
            x = r["x"][order]
            ys = [r[k][b][order] for k in ("model", "noise") for b in ("lower", "upper")]
            cell = sheet.cell(*frames[row * ncol + col], padded(x),
                              padded(np.concatenate([*ys, r["mean"], r["observed"]])))
            ax.fill_between(cell.x(x), cell.y(ys[0]), cell.y(ys[1]), color="C1", alpha=0.25, lw=0,
                            label=sheet.once("+ model error"))
            ax.fill_between(cell.x(x), cell.y(ys[2]), cell.y(ys[3]), color="C0", alpha=0.35, lw=0,
                            label=sheet.once("parameters + noise"))
            ax.plot(cell.x(x), cell.y(r["mean"][order]), "C0-", lw=1.2, label=sheet.once("predictive mean"))
            ax.plot(cell.x(x), cell.y(r["observed"][order]), ".", color="C3", ms=3, label=sheet.once("measured"))
            cell.note(f"inside: {100 * r['noise']['coverage']:.0f} % (parameters + noise), "
                      f"{100 * r['model']['coverage']:.0f} % (+ model error)", top=False, color="0.3", fontsize=7)
            cell.title(f"{t} (prediction): {r['curve']}")
            cell.x_axis(r["x_label"], edge=0.0)
            cell.y_axis(labels.get(r["curve"], r["curve"]), edge=0.0)
    sheet.legend_row()
    save(sheet.finish(), path, title, 110)

"""The figures of a calibration (cases.study.outputs.figures) on constructed posteriors and records: labels with the
quantity's symbol and unit, a grid of at most four columns, marginals zoomed to the posterior, the pairs plot, the MAP
drawn between the records, the stress paths, the MAP between the records asked of a forward model."""
from types import SimpleNamespace

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

from cases.study.outputs.figures.canvas import MAX_COLUMNS, TITLE_ROOM, pyplot, save
from cases.study.outputs.figures.curves import (
    curves_figure,
    model_at_records,
    recorded_mean_stress,
    stress_paths_figure,
)
from cases.study.outputs.figures.dense import dense_curves, densified, with_mean_stress
from cases.study.outputs.figures.labels import abscissa_label, panel_title, parameter_label, quantity_label
from cases.study.outputs.figures.panels import curve_panels, stage_axes
from cases.study.outputs.figures.posterior import (
    marginals_figure,
    pairs_figure,
    stages_figure,
    write_posterior_figures,
    zoom,
)
from cases.study.outputs.figures.sheet import LEGEND_ROW, TICK_FONT, grid, legend_columns
from cases.study.outputs.report import loop_figure
from cases.study.programme import InitialState, Stage, TestSpec
from inference import Curve, Observations, Test

plt = pyplot()


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def _posterior(seed=0, n=200):
    """A ridge M = 1.0 + 0.002 sigma_p0 (+ noise), as M against sigma'_p0 in a pressuremeter calibration."""
    rng = np.random.default_rng(seed)
    sigma_p0 = rng.normal(100.0, 5.0, n)
    M = 1.0 + 0.002 * sigma_p0 + rng.normal(0.0, 0.002, n)
    samples = np.column_stack([M, sigma_p0])
    return SimpleNamespace(names=("M", "sigma_p0"), samples=samples, map_theta=samples[0],
                           stage_samples=[rng.uniform([0.5, 20.0], [2.0, 200.0], (n, 2)), samples])


UNITS = {"M": "-", "sigma_p0": "kPa"}


def test_labels_name_the_quantity_and_its_unit_and_put_the_stage_in_the_title():
    assert quantity_label("axial_stress@relax_ocr1") == "sigma'_v (kPa)"
    assert quantity_label("q@shear") == "q (kPa)" and quantity_label("void_ratio") == "void ratio e (-)"
    assert quantity_label("water_content", "%") == "water_content (%)"
    assert abscissa_label("axial_strain", "%") == "axial strain eps_a (%)"
    assert abscissa_label("time", "s") == "time t (s)" and abscissa_label("depth", "m") == "depth (m)"
    assert panel_title("OED", "axial_stress@relax_ocr1") == "OED, stage relax_ocr1" and panel_title("T1", "q") == "T1"
    assert parameter_label("sigma_p0", UNITS) == "sigma_p0 (kPa)" and parameter_label("n", {}) == "n (-)"


def test_the_grid_wraps_many_curves_into_rows_of_four():
    sheet, frames = grid(24, (4.2, 3.2), (0.9, 0.15, 0.6, 0.35), MAX_COLUMNS)
    assert len(frames) == 24
    assert sheet.fig.get_size_inches()[0] == pytest.approx(MAX_COLUMNS * 4.2)
    assert sheet.fig.get_size_inches()[1] == pytest.approx(6 * 3.2 + TITLE_ROOM)    # 24 panels / 4 columns, the title
    assert [f[0] for f in frames[:5]] == pytest.approx([0.9, 5.1, 9.3, 13.5, 0.9])   # the fifth starts a row
    assert frames[4][1] == pytest.approx(frames[0][1] - 3.2)
    sheet, frames = grid(5, (4.2, 3.2), (0.9, 0.15, 0.6, 0.35), MAX_COLUMNS, legend=3)
    assert len(frames) == 5 and sheet.fig.get_size_inches()[0] == pytest.approx(4 * 4.2)
    assert sheet.fig.get_size_inches()[1] == pytest.approx(2 * 3.2 + TITLE_ROOM + LEGEND_ROW + 0.08)   # one row
    # one panel 4.2 inches wide holds two legend entries side by side: four take two rows
    assert legend_columns(4.2) == 2
    sheet, frames = grid(1, (4.2, 3.2), (0.9, 0.15, 0.6, 0.35), MAX_COLUMNS, legend=4)
    assert sheet.fig.get_size_inches()[1] == pytest.approx(3.2 + TITLE_ROOM + 2 * LEGEND_ROW + 0.08)

def test_a_legend_row_wraps_to_the_sheets_width(tmp_path):
    """Four entries over one panel 4.6 inches wide (predictions.png of one predicted curve): two rows, inside the
    figure, in the room the grid left under the title."""
    sheet, frames = grid(1, (4.6, 3.0), (0.9, 0.15, 0.6, 0.35), MAX_COLUMNS, legend=4)
    cell = sheet.cell(*frames[0], (0.0, 1.0), (0.0, 1.0))
    cell.x_axis("axial strain eps_a (%)")
    sheet.legend_row([plt.Line2D([], [], color=f"C{k}", label=text) for k, text in enumerate(
        ("+ model error", "parameters + noise", "predictive mean", "measured"))])
    fig = sheet.finish()
    save(fig, tmp_path / "legend.png", "SYNTHETIC data: a figure title")
    renderer = FigureCanvasAgg(fig).get_renderer()
    legend = fig.axes[0].get_legend().get_window_extent(renderer)
    page, dpi = fig.bbox, fig.dpi
    assert page.x0 <= legend.x0 and legend.x1 <= page.x1
    assert legend.y0 >= (cell.bottom + cell.height) * dpi and legend.y1 <= page.y1 - TITLE_ROOM * dpi + 1


def _overlap(a, b) -> float:
    """The area (pixels^2) two bounding boxes share."""
    w = min(a.x1, b.x1) - max(a.x0, b.x0)
    h = min(a.y1, b.y1) - max(a.y0, b.y0)
    return max(w, 0.0) * max(h, 0.0)


@pytest.mark.parametrize("figure, n", [("curves", 6), ("curves", 1), ("loop", 6), ("stress paths", 6)])
def test_a_sheets_texts_lie_inside_the_figure_below_its_title_and_apart(figure, n, tmp_path):
    """Six panels (or one, whose legend entries wrap into rows) of long tick values (-12000 to 99999 kPa) and labels,
    on a sheet (the curves' figure; the loop's figure, records above their residual; the stress paths): the legend
    and every tick value, axis label and panel title lie inside the figure, below the figure's title, and no text
    shares a pixel with the legend or another text."""
    x = np.linspace(0.0, 1e4, 5)
    observations = Observations([Test(f"TEST_{k}", {"axial_stress@relax_ocr1": Curve(
        x, np.linspace(-12000.0, 99999.0, 5), "axial_strain", "axial_stress", "%", "kPa")}) for k in range(n)])
    sims = {(t.name, c): curve.y * 1.01 + 5.0 for t in observations for c, curve in t.curves.items()}
    if figure == "curves":
        bands = {k: SimpleNamespace(lower=v - 900.0, upper=v + 900.0, coverage=1.0) for k, v in sims.items()}
        fig = curves_figure(observations, sims, bands)
    elif figure == "stress paths":
        paths = Observations([Test(f"TEST_{k}", {"q": Curve(x, np.linspace(-12000.0, 99999.0, 5), "axial_strain",
                                                             "q", "%", "kPa")}) for k in range(n)])
        raw = {f"TEST_{k}": {"q": np.linspace(-12000.0, 99999.0, 5), "mean_stress": np.linspace(-9000.0, 88888.0, 5)}
               for k in range(n)}
        fig = stress_paths_figure(paths, raw, {(f"TEST_{k}", None): True for k in range(n)})
    else:
        base = SimpleNamespace(map_simulated=sims, role="base", candidate=None, log_evidence=0.0)
        fig = loop_figure(SimpleNamespace(observations=observations), [base],
                          SimpleNamespace(omitted_physics="none", mismatch_regions=[]))
    save(fig, tmp_path / "sheet.png", "SYNTHETIC data: a figure title")
    renderer = FigureCanvasAgg(fig).get_renderer()
    (ax,) = fig.axes
    title = fig.texts[0].get_window_extent(renderer)
    legend = ax.get_legend().get_window_extent(renderer)
    boxes = [t.get_window_extent(renderer) for t in ax.texts]
    assert len(boxes) > n * 8
    page = fig.bbox
    assert page.x0 <= legend.x0 and legend.x1 <= page.x1 and legend.y1 <= title.y0
    for i, box in enumerate(boxes):
        assert page.x0 <= box.x0 and box.x1 <= page.x1 and page.y0 <= box.y0 and box.y1 <= title.y0
        assert _overlap(box, legend) == 0.0
        for other in boxes[i + 1:]:
            assert _overlap(box, other) == 0.0

def _cells(ax):
    """The frames of a sheet's cells (cases.study.outputs.figures.sheet) as (left, bottom, width, height), in the
    order drawn: the closed rectangles of its line collection of frames."""
    from matplotlib.collections import LineCollection

    frames = next(c for c in ax.collections if isinstance(c, LineCollection)
                  and all(len(seg) == 5 for seg in c.get_segments()))
    out = []
    for seg in frames.get_segments():
        (x0, y0), (x1, _), (_, y1) = seg[0], seg[1], seg[2]
        out.append((x0, y0, x1 - x0, y1 - y0))
    return out


def _values(cell, values, axis, value_range):
    """Positions on a cell's ``axis`` (0: x, 1: y) back to the values of an axis over ``value_range``."""
    lo, hi = value_range
    return lo + (hi - lo) * (np.asarray(values) - cell[axis]) / cell[2 + axis]


def test_marginals_are_zoomed_to_the_posterior_with_units_and_a_legend():
    post = _posterior()
    marks = {"generating": {"M": 1.2, "sigma_p0": 400.0}}
    fig = marginals_figure(post, marks, UNITS)
    (ax,) = fig.axes   # the panels are cells of one axes
    cell_m, cell_s = _cells(ax)
    texts = {t.get_text(): t.get_position() for t in ax.texts}
    # each label under its own panel
    assert cell_m[0] < texts["M (-)"][0] < cell_m[0] + cell_m[2] and texts["M (-)"][1] < cell_m[1]
    assert cell_s[0] < texts["sigma_p0 (kPa)"][0] < cell_s[0] + cell_s[2]
    # zoomed: each histogram spans its cell, which spans the samples' range widened by 15 % on each side
    hist_m, hist_s = ax.patches
    for hist, cell, column in ((hist_m, cell_m, 0), (hist_s, cell_s, 1)):
        lo, hi = post.samples[:, column].min(), post.samples[:, column].max()
        box = hist.get_path().get_extents()
        assert _values(cell, [box.x0, box.x1], 0, zoom(post.samples[:, column])) == pytest.approx(
            [lo - 0.15 * (hi - lo), hi + 0.15 * (hi - lo)])
    # the MAP of M where it is: a vertical red line in M's cell
    red = [line for line in ax.get_lines() if line.get_color() == "C3"]
    assert _values(cell_m, red[0].get_xdata()[0], 0, zoom(post.samples[:, 0])) == pytest.approx(post.map_theta[0])
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert sorted(legend) == ["MAP", "generating", "posterior samples"]
    # 400 kPa is far outside the posterior of sigma_p0: named with its value in its panel, not drawn
    x, y = texts["generating: 400 (off the axis)"]
    assert cell_s[0] < x < cell_s[0] + cell_s[2] and cell_s[1] < y <= cell_s[1] + cell_s[3]
    dashed = [line for line in ax.get_lines() if line.get_linestyle() == "--"]
    assert len(dashed) == 1 and cell_m[0] < dashed[0].get_xdata()[0] < cell_m[0] + cell_m[2]


def test_pairs_plot_shows_the_samples_the_map_and_the_ridge_with_units():
    post = _posterior()
    fig = pairs_figure(post, {"generating": {"M": 1.2, "sigma_p0": 100.0}}, UNITS)
    (ax,) = fig.axes   # the cells of one axes, the lower triangle row by row: (0, 0), (1, 0), (1, 1)
    diagonal, pair, last = _cells(ax)
    assert diagonal[0] == pair[0] and diagonal[1] > pair[1] and last[0] > pair[0] and last[1] == pair[1]
    texts = [t.get_text() for t in ax.texts]
    assert texts.count("M (-)") == 1 and texts.count("sigma_p0 (kPa)") == 2   # under its column and left of its row
    lines = ax.get_lines()
    samples = next(line for line in lines if line.get_marker() == ".")
    star = next(line for line in lines if line.get_marker() == "*")
    mark = next(line for line in lines if line.get_marker() == "s")
    m_range, s_range = zoom(post.samples[:, 0]), zoom(post.samples[:, 1])
    np.testing.assert_allclose(_values(pair, samples.get_xdata(), 0, m_range), post.samples[:, 0], rtol=1e-12)
    np.testing.assert_allclose(_values(pair, samples.get_ydata(), 1, s_range), post.samples[:, 1], rtol=1e-12)
    np.testing.assert_allclose([_values(pair, star.get_xdata()[0], 0, m_range),
                                _values(pair, star.get_ydata()[0], 1, s_range)], post.map_theta, rtol=1e-12)
    np.testing.assert_allclose([_values(pair, mark.get_xdata()[0], 0, m_range),
                                _values(pair, mark.get_ydata()[0], 1, s_range)], (1.2, 100.0), rtol=1e-12)
    # the ridge: the samples of the pair panel are correlated as drawn (M = 1 + 0.002 sigma_p0)
    assert np.corrcoef(samples.get_xdata(), samples.get_ydata())[0, 1] > 0.9
    # the diagonal's histograms stand in their cells: M's in (0, 0), sigma_p0's in (1, 1)
    for hist, cell in zip(ax.patches, (diagonal, last)):
        box = hist.get_path().get_extents()
        assert cell[0] - 1e-9 <= box.x0 and box.x1 <= cell[0] + cell[2] + 1e-9
        assert cell[1] - 1e-9 <= box.y0 and box.y1 <= cell[1] + cell[3] + 1e-9
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend == ["posterior samples", "MAP", "generating"]


def test_a_map_outside_the_final_sample_is_named_not_drawn_outside_its_panel():
    """The MAP is the best evaluated sample of any stage, and may lie outside the final stage's zoomed range: the
    sheet clips nothing to a panel, so it is named in the marginal's panel and left out of the pairs plot, never
    drawn over a neighbouring panel."""
    post = _posterior()
    post.map_theta = np.array([post.samples[:, 0].max() + 10.0, post.samples[:, 1].mean()])
    (ax,) = marginals_figure(post, None, UNITS).axes
    assert f"MAP: {post.map_theta[0]:.4g} (off the axis)" in [t.get_text() for t in ax.texts]
    (ax,) = pairs_figure(post, None, UNITS).axes
    diagonal, pair, last = _cells(ax)
    star = next(line for line in ax.get_lines() if line.get_marker() == "*")
    assert len(star.get_xdata()) == 0
    for line in ax.get_lines():   # every line inside the lower triangle's cells
        x, y = np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)
        if x.size:
            assert x.min() >= diagonal[0] - 1e-9 and x.max() <= last[0] + last[2] + 1e-9
            assert y.min() >= pair[1] - 1e-9 and y.max() <= diagonal[1] + diagonal[3] + 1e-9


def test_tick_values_stay_off_the_cells_edges_and_name_the_value_at_their_place():
    """The tick values under a column of the pairs plot lie in its middle 88 %, so the last label of one column
    and the first of the next do not meet; each names the value at its place (a power of ten shared by an axis's
    values is written once, beside its label)."""
    post = _posterior()
    post.samples[:, 1] *= 1e-11   # sigma_p0 about 1e-9 (a permeability's scale): its values written over 1e-9
    (ax,) = pairs_figure(post, None, UNITS).axes
    diagonal, pair, last = _cells(ax)
    under = [t for t in ax.texts if t.get_fontsize() == TICK_FONT and t.get_position()[1] < pair[1]]
    assert len(under) >= 4
    for t in under:
        x = t.get_position()[0]
        cell, k = (pair, 0) if x < last[0] else (last, 1)
        assert cell[0] + 0.06 * cell[2] <= x <= cell[0] + 0.94 * cell[2]
        scale = 1e-9 if k == 1 else 1.0
        assert float(t.get_text()) * scale == pytest.approx(_values(cell, x, 0, zoom(post.samples[:, k])), rel=1e-3)
    assert "sigma_p0 (kPa) x 1e-9" in [t.get_text() for t in ax.texts]


def test_stages_are_drawn_with_every_stage_ticked():
    post = _posterior()
    (ax,) = stages_figure(post, UNITS).axes
    cell_m, cell_s = _cells(ax)
    dots = ax.get_lines()[0]
    n = sum(len(theta) for theta in post.stage_samples)
    # M's samples in M's cell, then sigma_p0's in its own, each at its stage's index +- 0.3
    np.testing.assert_allclose(np.round(_values(cell_m, dots.get_xdata()[:n], 0, (-0.6, 1.6))),
                               np.repeat([0, 1], [len(t) for t in post.stage_samples]))
    values = np.concatenate([theta[:, 1] for theta in post.stage_samples])
    np.testing.assert_allclose(_values(cell_s, dots.get_ydata()[n:], 1, zoom(values, 0.05)), values, rtol=1e-12)
    stage_ticks = [t.get_text() for t in ax.texts if t.get_fontsize() == TICK_FONT and t.get_position()[1] < cell_m[1]]
    assert stage_ticks.count("0") == 2 and stage_ticks.count("1") == 2


def test_posterior_figures_are_written(tmp_path):
    write_posterior_figures(tmp_path, _posterior(), None, UNITS, "a title")
    for name in ("marginals.png", "pairs.png", "stages.png"):
        assert (tmp_path / name).stat().st_size > 10_000, name


def _records():
    strain = np.array([1.0, 2.0, 4.0])
    return Observations([
        Test("CIU", {"q": Curve(strain, [30.0, 40.0, 45.0], "axial_strain", "q", "%", "kPa"),
                     "excess_pore_pressure": Curve(strain, [10.0, 15.0, 18.0], "axial_strain",
                                                   "excess_pore_pressure", "%", "kPa")}),
        Test("OED", {"axial_stress@relax": Curve([10.0, 100.0, 1e4], [80.0, 70.0, 65.0], "time", "axial_stress", "s",
                                                  "kPa")}),
    ])


def _bands(observations):
    return {(t.name, c): SimpleNamespace(lower=curve.y * 0.9, upper=curve.y * 1.1, coverage=1.0)
            for t in observations for c, curve in t.curves.items()}


def _relative(values):
    """Positions as fractions of their span from the first (a cell's scale taken out)."""
    v = np.asarray(values, float)
    return (v - v[0]) / (v[-1] - v[0])


def _inside(cell, line):
    return cell[0] - 1e-9 <= np.min(line.get_xdata()) and np.max(line.get_xdata()) <= cell[0] + cell[2] + 1e-9


def test_curves_draw_the_map_as_a_line_between_the_records_else_as_markers():
    observations = _records()
    map_simulated = {(t.name, c): curve.y * 1.01 for t in observations for c, curve in t.curves.items()}
    dense_x = np.linspace(1.0, 4.0, 13)
    dense = {("CIU", "q"): (dense_x, 50.0 * (1 - np.exp(-dense_x)))}
    fig = curves_figure(observations, map_simulated, _bands(observations), dense)
    (ax,) = fig.axes   # the panels are cells of one axes
    cells = _cells(ax)
    assert len(cells) == 3   # three panels: one row of three
    cell_q, cell_u, cell_oed = cells
    assert cell_q[1] == cell_u[1] == cell_oed[1] and cell_q[0] < cell_u[0] < cell_oed[0]
    texts = [t.get_text() for t in ax.texts]
    for label in ("axial strain eps_a (%)", "q (kPa)", "excess pore pressure u (kPa)", "time t (s)",
                  "sigma'_v (kPa)", "OED, stage relax"):
        assert label in texts, label
    line = next(v for v in ax.get_lines() if v.get_linestyle() == "-" and _inside(cell_q, v))
    np.testing.assert_allclose(_relative(line.get_xdata()), _relative(dense_x), atol=1e-12)
    # no dense curve: markers at the records, no segments
    markers = next(v for v in ax.get_lines() if v.get_marker() == "x" and _inside(cell_u, v))
    assert markers.get_linestyle() == "None"
    np.testing.assert_allclose(_relative(markers.get_ydata()), _relative(map_simulated["CIU", "excess_pore_pressure"]),
                               atol=1e-12)
    # relaxation times over three decades: on a log axis, the records 10, 100 and 1e4 s at 0, 1/3 and 1
    recorded = next(v for v in ax.get_lines() if v.get_marker() == "o" and _inside(cell_oed, v))
    np.testing.assert_allclose(_relative(recorded.get_xdata()), [0.0, 1.0 / 3.0, 1.0], atol=1e-12)
    recorded_q = next(v for v in ax.get_lines() if v.get_marker() == "o" and _inside(cell_q, v))
    np.testing.assert_allclose(_relative(recorded_q.get_xdata()), [0.0, 1.0 / 3.0, 1.0], atol=1e-12)   # 1, 2, 4 %
    # every mark drawn is named once, in the order first drawn: the u panel's markers too
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend == ["95 % predictive", "MAP", "recorded", "MAP (at the records)"]

def test_recorded_mean_stress_follows_the_total_stress_path_of_the_test():
    """An undrained test from p'0 = 95 kPa, q0 = 0 at constant cell pressure: p' = p'0 + q/3 - u. The model: q 30,
    u 5 -> p' 100; the record: q 33, u 4 -> p' 102. The same within a stage of a programme."""
    model = {"q": np.array([30.0]), "mean_stress": np.array([100.0]), "excess_pore_pressure": np.array([5.0])}
    test = Test("CIU", {"q": Curve([1.0], [33.0]), "excess_pore_pressure": Curve([1.0], [4.0])})
    assert recorded_mean_stress(test, "q", model, drained=False)[0] == pytest.approx(95.0 + 33.0 / 3 - 4.0)
    staged = Test("P", {"q@shear": Curve([1.0], [33.0]), "excess_pore_pressure@shear": Curve([1.0], [4.0])})
    assert recorded_mean_stress(staged, "q@shear", model, drained=False)[0] == pytest.approx(102.0)
    drained = Test("CID", {"q": Curve([1.0], [60.0])})
    assert recorded_mean_stress(drained, "q", {"q": np.array([30.0]), "mean_stress": np.array([110.0])},
                                drained=True)[0] == pytest.approx(100.0 + 60.0 / 3)
    recorded_p = Test("CIUE", {"q": Curve([1.0], [-20.0]), "p": Curve([1.0], [90.0])})
    assert recorded_mean_stress(recorded_p, "q", model, drained=False)[0] == 90.0
    assert recorded_mean_stress(Test("U", {"q": Curve([1.0], [20.0])}), "q", model, drained=False) is None


def test_the_model_at_the_records_comes_from_one_solution():
    """From the solution between the records when it has q and p' (interpolated to the records, whatever the order
    of its abscissae), else from the values at the records."""
    test = Test("P", {"q@shear": Curve([-1.0, -2.0], [-20.0, -30.0])})
    dense = {("P", "q@shear"): (np.array([-0.5, -1.0, -1.5, -2.0]), np.array([-10.0, -21.0, -26.0, -31.0])),
             ("P", "mean_stress@shear"): (np.array([-0.5, -1.0, -1.5, -2.0]), np.array([99.0, 97.0, 95.0, 93.0]))}
    model = model_at_records(test, "q@shear", {"q@shear": np.array([-20.5, -30.5])}, dense)
    np.testing.assert_array_equal(model["q"], [-21.0, -31.0])
    np.testing.assert_array_equal(model["mean_stress"], [97.0, 93.0])
    raw = {"q@shear": np.array([-20.5, -30.5]), "mean_stress@shear": np.array([96.0, 92.0])}
    np.testing.assert_array_equal(model_at_records(test, "q@shear", raw, {})["q"], [-20.5, -30.5])
    assert model_at_records(test, "q@shear", {"q@shear": np.array([-20.5, -30.5])}, {}) is None


def test_stress_paths_are_drawn_for_the_tests_whose_model_gives_p():
    observations = _records()
    raw = {"CIU": {"q": np.array([29.0, 41.0, 44.0]), "mean_stress": np.array([95.0, 90.0, 88.0]),
                   "excess_pore_pressure": np.array([11.0, 14.0, 19.0])},
           "OED": {"axial_stress@relax": np.array([81.0, 69.0, 66.0])}}
    fig = stress_paths_figure(observations, raw, {("CIU", None): False})
    (ax,) = fig.axes
    assert len(_cells(ax)) == 1   # CIU only: the oedometer has no q
    texts = [t.get_text() for t in ax.texts]
    assert {"p' (kPa)", "q (kPa)", "CIU"} <= set(texts)
    at_records = next(v for v in ax.get_lines() if v.get_marker() == "x")   # the MAP at the records: markers
    assert at_records.get_linestyle() == "None"
    recorded = next(v for v in ax.get_lines() if v.get_marker() == "o")
    p_recorded = (raw["CIU"]["mean_stress"] + (observations["CIU"].curves["q"].y - raw["CIU"]["q"]) / 3
                  - (observations["CIU"].curves["excess_pore_pressure"].y - raw["CIU"]["excess_pore_pressure"]))
    # both on one scale: the records' p' against the MAP's, each through the cell's one mapping
    both = np.concatenate([at_records.get_xdata(), recorded.get_xdata()])
    np.testing.assert_allclose(_relative(both), _relative(np.concatenate([raw["CIU"]["mean_stress"], p_recorded])),
                               atol=1e-12)
    strain, p_dense, q_dense = np.linspace(1.0, 4.0, 9), np.linspace(95.0, 88.0, 9), np.linspace(28.0, 44.0, 9)
    fig = stress_paths_figure(observations, raw, {("CIU", None): False}, {("CIU", "q"): (strain, q_dense),
                                                                          ("CIU", "mean_stress"): (strain, p_dense)})
    line = next(v for v in fig.axes[0].get_lines() if v.get_linestyle() == "-")
    np.testing.assert_allclose(_relative(line.get_xdata()), _relative(p_dense), atol=1e-12)
    np.testing.assert_allclose(_relative(line.get_ydata()), _relative(q_dense), atol=1e-12)
    assert stress_paths_figure(observations, {"OED": raw["OED"]}, {}) is None

def test_mean_stress_is_asked_beside_every_q_curve():
    observations = Observations([Test("P", {"q@shear": Curve([1.0, 2.0], [10.0, 20.0], "axial_strain", "q", "%",
                                                             "kPa"),
                                            "void_ratio@swelling": Curve([50.0, 40.0], [1.0, 1.01], "p")})])
    asked = with_mean_stress(observations)["P"].curves
    assert set(asked) == {"q@shear", "void_ratio@swelling", "mean_stress@shear"}
    np.testing.assert_array_equal(asked["mean_stress@shear"].x, [1.0, 2.0])
    assert asked["mean_stress@shear"].x_name == "axial_strain"


def test_densified_abscissae_keep_the_records_and_fill_between_them():
    dense = densified(_records(), factor=2)
    np.testing.assert_array_equal(dense["CIU"].curves["q"].x, [1.0, 1.5, 2.0, 3.0, 4.0])
    np.testing.assert_array_equal(dense["OED"].curves["axial_stress@relax"].x, [10.0, 55.0, 100.0, 5050.0, 1e4])
    assert dense["OED"].curves["axial_stress@relax"].x_name == "time"


def test_dense_curves_are_the_model_at_the_dense_abscissae():
    def simulate(observations):
        return {t.name: {**{c: np.sqrt(curve.x) for c, curve in t.curves.items()},
                         **({"mean_stress": 100.0 - next(iter(t.curves.values())).x} if t.name == "CIU" else {})}
                for t in observations}

    out = dense_curves(simulate, _records(), factor=3)
    x, y = out["CIU", "q"]
    np.testing.assert_allclose(x, [1.0, 4 / 3, 5 / 3, 2.0, 8 / 3, 10 / 3, 4.0])
    np.testing.assert_allclose(y, np.sqrt(x))
    np.testing.assert_allclose(out["CIU", "mean_stress"][1], 100.0 - x)
    assert dense_curves(lambda observations: RuntimeError("diverged"), _records()) == {}


def _staged():
    """A CIU programme as a laboratory reports it: a consolidation against p', two undrained shear stages each zeroed
    at its start (to 1 and 2 %), a creep stage against its own time; and a flat test."""
    tests = [TestSpec(name="P", type="programme", apparatus="triaxial", initial=InitialState(p0=50.0, e0=1.0),
                      stages=(Stage("consolidation", "c", p=100.0, duration=600.0),
                              Stage("shear", "fast", drainage="undrained", strain_rate=1e-5, to_strain=0.01),
                              Stage("shear", "slow", drainage="undrained", strain_rate=1e-6, to_strain=0.02),
                              Stage("creep", "hold", drainage="undrained", duration=1e4))),
             TestSpec(name="F", type="triaxial")]
    observations = Observations([
        Test("P", {"void_ratio@c": Curve([60.0, 100.0], [0.98, 0.95], "p", "void_ratio", "kPa"),
                   "q@fast": Curve([0.5, 1.0], [40.0, 50.0], "axial_strain", "q", "%", "kPa"),
                   "excess_pore_pressure@fast": Curve([0.5, 1.0], [20.0, 25.0], "axial_strain",
                                                      "excess_pore_pressure", "%", "kPa"),
                   "q@slow": Curve([1.0, 2.0], [48.0, 52.0], "axial_strain", "q", "%", "kPa"),
                   "excess_pore_pressure@slow": Curve([1.0, 2.0], [26.0, 27.0], "axial_strain",
                                                      "excess_pore_pressure", "%", "kPa"),
                   "axial_strain@hold": Curve([10.0, 1e4], [3.0, 3.2], "time", "axial_strain", "s", "%")}),
        Test("F", {"q": Curve([1.0, 2.0], [10.0, 20.0], "axial_strain", "q", "%", "kPa")})])
    return tests, observations


def test_a_programmes_stages_of_one_quantity_share_a_panel_end_to_end():
    tests, observations = _staged()
    panels = curve_panels(observations, stage_axes(tests))
    assert [(p.test, p.members) for p in panels] == [
        ("P", (("void_ratio@c", 0.0),)),
        ("P", (("q@fast", 0.0), ("q@slow", 1.0))),
        ("P", (("excess_pore_pressure@fast", 0.0), ("excess_pore_pressure@slow", 1.0))),
        ("P", (("axial_strain@hold", 0.0),)),
        ("F", (("q", 0.0),))]
    assert [p.title for p in panels] == ["P, stage c", "P, stages fast to slow (2)", "P, stages fast to slow (2)",
                                         "P, stage hold", "F"]
    assert [p.label for p in panels[:2]] == ["P void_ratio@c", "P q (stages fast to slow)"]
    assert len(curve_panels(observations)) == 7   # without the study's stages: a panel per curve


def test_joined_stages_are_drawn_on_the_running_strain_with_the_pooled_coverage():
    tests, observations = _staged()
    panels = curve_panels(observations, stage_axes(tests))
    map_simulated = {(t.name, c): curve.y * 1.01 for t in observations for c, curve in t.curves.items()}
    bands = {(t.name, c): SimpleNamespace(lower=curve.y * 0.9, upper=curve.y * 1.1, coverage=1.0,
                                          outside=np.zeros(curve.y.size, bool), n_used=curve.y.size)
             for t in observations for c, curve in t.curves.items()}
    bands["P", "q@slow"] = SimpleNamespace(lower=bands["P", "q@slow"].lower, upper=bands["P", "q@slow"].upper,
                                           coverage=0.5, outside=np.array([True, False]), n_used=2)
    fig = curves_figure(observations, map_simulated, bands, None, panels)
    (ax,) = fig.axes
    cells = _cells(ax)
    assert len(cells) == 5
    cell_q = cells[1]
    recorded = [line for line in ax.get_lines() if line.get_marker() == "o" and _inside(cell_q, line)]
    x = np.concatenate([line.get_xdata() for line in recorded])   # the running strain 0.5, 1, 2, 3 %
    np.testing.assert_allclose(_relative(x), (np.array([0.5, 1.0, 2.0, 3.0]) - 0.5) / 2.5, atol=1e-12)
    # where "slow" starts: a faint line at 1 %
    (start,) = [v for v in ax.get_lines() if v.get_linestyle() == "-" and v.get_color() == "0.75"
                and _inside(cell_q, v)]
    assert (start.get_xdata()[0] - x[0]) / (x[-1] - x[0]) == pytest.approx(0.2)
    assert "75 % of the records in the band" in [t.get_text() for t in ax.texts]   # 1 of 4 outside
    unused = {k: SimpleNamespace(coverage=float("nan"), outside=np.zeros(2, bool), n_used=0) for k in bands}
    assert np.isnan(panels[1].coverage(unused))   # every record below the floor: no share, no division by zero

def test_the_stress_path_of_a_programme_is_one_panel_with_every_stage():
    tests, observations = _staged()
    raw = {"P": {"q@fast": np.array([41.0, 49.0]), "mean_stress@fast": np.array([95.0, 92.0]),
                 "excess_pore_pressure@fast": np.array([19.0, 24.0]), "q@slow": np.array([47.0, 53.0]),
                 "mean_stress@slow": np.array([91.0, 90.0]), "excess_pore_pressure@slow": np.array([25.0, 28.0])}}
    fig = stress_paths_figure(Observations([observations["P"]]), raw, {("P", "fast"): False, ("P", "slow"): False})
    (ax,) = fig.axes
    assert len(_cells(ax)) == 1
    assert "P, stages fast to slow (2)" in [t.get_text() for t in ax.texts]
    recorded = [line for line in ax.get_lines() if line.get_marker() == "o"]
    assert len(recorded) == 2
    p_fast = (raw["P"]["mean_stress@fast"] + (observations["P"].curves["q@fast"].y - raw["P"]["q@fast"]) / 3
              - (observations["P"].curves["excess_pore_pressure@fast"].y - raw["P"]["excess_pore_pressure@fast"]))
    p_slow = (raw["P"]["mean_stress@slow"] + (np.array([48.0, 52.0]) - raw["P"]["q@slow"]) / 3
              - (np.array([26.0, 27.0]) - raw["P"]["excess_pore_pressure@slow"]))
    np.testing.assert_allclose(_relative(np.concatenate([line.get_xdata() for line in recorded])),
                               _relative(np.concatenate([p_fast, p_slow])), atol=1e-12)
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["MAP (at the records)", "recorded"]

def test_the_loop_figure_shades_a_stages_mismatch_where_the_stage_lies_on_the_joined_axis():
    tests, observations = _staged()
    panels = curve_panels(observations, stage_axes(tests))
    sims = {(t.name, c): curve.y * 1.02 for t in observations for c, curve in t.curves.items()}
    base = SimpleNamespace(map_simulated=sims, role="base", candidate=None, log_evidence=0.0)
    model_form = SimpleNamespace(map_simulated=sims, role="model form", candidate=None, log_evidence=30.0)
    viscous = SimpleNamespace(map_simulated=sims, role="enriched", candidate="viscosity", log_evidence=10.0)
    region = SimpleNamespace(test="P", curve="q@slow", x_start=1.2, x_end=1.8)
    diag = SimpleNamespace(omitted_physics="none", mismatch_regions=[region])
    fig = loop_figure(SimpleNamespace(observations=observations), [base, model_form, viscous], diag, panels)
    (ax,) = fig.axes
    # the physics class of largest ln Z is drawn beside the base, not the model-form class
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["recorded", "base MAP", "viscosity MAP"]
    # each panel is a pair of cells, the records above their residual: the second panel's are cells 2 and 3
    cells = _cells(ax)
    top_q, residual_q = cells[2], cells[3]
    assert top_q[0] == residual_q[0] and top_q[1] > residual_q[1] + residual_q[3]
    # the joined strain 0.5, 1, 2, 3 %: the region 1.2-1.8 % of the slow stage, which starts at 1 %, is 2.2-2.8 %
    records = [v for v in ax.get_lines() if v.get_marker() == "o" and v.get_linestyle() == "None"
               and _inside(top_q, v)]
    x = np.concatenate([v.get_xdata() for v in records])
    (span,) = ax.patches
    extent = span.get_path().transformed(span.get_patch_transform()).vertices[:, 0]
    np.testing.assert_allclose((np.array([extent.min(), extent.max()]) - x[0]) / (x[-1] - x[0]),
                               (np.array([2.2, 2.8]) - 0.5) / 2.5)
    assert residual_q[1] - 1e-9 <= span.get_y() and span.get_y() + span.get_height() <= top_q[1]
    assert "P, stages fast to slow (2)" in [t.get_text() for t in ax.texts]

def _hold(name, times, y):
    """A creep hold's curve recorded at ``times`` (s) against the time ``name``."""
    return Curve(times, y, name, "axial_strain", "s", "%")


def test_a_time_axis_over_more_than_two_decades_is_logarithmic_in_the_curves_and_the_loop_figure():
    """A creep hold logged at growing intervals (10 s to 1e5 s) is drawn on a log time axis ticked at its decades,
    in the curves' figure and in both axes of the loop figure's panel; a hold over less than two decades and a
    strain abscissa stay linear. The panels' linear axes carry at most PANEL_TICKS intervals."""
    from cases.study.outputs.figures.canvas import PANEL_TICKS
    from cases.study.outputs.figures.curves import curves_figure

    observations = Observations([Test("C", {
        "axial_strain@long": _hold("stage_time", np.geomspace(10.0, 1e5, 12), np.linspace(8.0, 9.0, 12)),
        "axial_strain@short": _hold("stage_time", np.linspace(100.0, 5000.0, 12), np.linspace(9.0, 9.2, 12)),
        "q@shear": Curve(np.linspace(0.1, 12.0, 12), np.linspace(20.0, 120.0, 12), "axial_strain", "q", "%",
                         "kPa")})])
    sims = {("C", c): curve.y * 1.01 for c, curve in observations["C"].curves.items()}
    bands = {key: SimpleNamespace(lower=y * 0.9, upper=y * 1.1, coverage=1.0) for key, y in sims.items()}
    fig = curves_figure(observations, sims, bands)
    (ax,) = fig.axes
    cells = _cells(ax)
    for cell in cells:   # geomspace on the log axis, linspace on the linear ones: equal steps on the page
        recorded = next(v for v in ax.get_lines() if v.get_marker() == "o" and _inside(cell, v))
        steps = np.diff(recorded.get_xdata())
        np.testing.assert_allclose(steps, steps[0], rtol=1e-9)
    ticks = {}
    for t in ax.texts:
        x, y = t.get_position()
        for k, cell in enumerate(cells):
            if t.get_fontsize() == 7 and cell[0] - 0.2 <= x <= cell[0] + cell[2] + 0.2 and cell[1] - 0.2 < y < cell[1]:
                ticks.setdefault(k, []).append(t.get_text())
    assert ticks[0] == ["10", "100", "1000", "10000", "100000"]   # the decades
    for k in (1, 2):   # at most PANEL_TICKS + 1 ticks on a linear axis
        assert 2 <= len(ticks[k]) <= PANEL_TICKS + 1
    base = SimpleNamespace(map_simulated=sims, role="base", candidate=None, log_evidence=0.0)
    diag = SimpleNamespace(omitted_physics="none", mismatch_regions=[])
    (ax,) = loop_figure(SimpleNamespace(observations=observations), [base], diag).axes
    # records and residual of each curve, both on a log axis for the long hold only: equal steps on the page
    for cell in _cells(ax):
        line = next(v for v in ax.get_lines() if v.get_marker() == "o" and _inside(cell, v))
        steps = np.diff(line.get_xdata())
        np.testing.assert_allclose(steps, steps[0], rtol=1e-9)

"""What the two SIMSAND studies share: test conditions from recorded data, the batched triaxial forward model, the
posterior predictive, and the figures of the paper's sections 3.1-3.2 (curves, CSL, MAP spread over runs).

Curves calibrated (REFERENCE section 1): drained tests q(eps_a) and e(eps_a); undrained tests q(eps_a) and the excess
pore pressure u(eps_a) (the paper's Fig. 13 choice). Axial strain is in percent in data files and figures, a fraction
inside the model. Compression positive, kPa.

Conditions of a test are read from its CSV ``#`` metadata (or given by the caller): ``e0`` (void ratio at the start
of shearing), ``p0_kPa`` (isotropic p'_0 in kPa) and ``drained`` (true/false).

The forward model runs every test of one drainage type for every particle of a batch in ONE call of
``constitutive.labtests.drained_triaxial``/``undrained_triaxial`` (routed to SIMSAND's batched ``triaxial_test``),
with the parameter sets repeated per test: the substep loop then runs once for all tests instead of once per test.
A particle whose integration fails in any test (``failed``, NaN curves) gets a ``ForwardModelError`` naming the test
and the last strain reached: a zero-likelihood particle with a reason, never a crash.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

import inference
from cases import study
from constitutive import SIMSAND, labtests
from inference import DataError, ForwardModelError

__all__ = ["TriaxialTest", "conditions_of", "SimsandTriaxial", "predictive", "plot_curves", "plot_csl",
           "plot_map_spread", "sampler_settings", "write_runs", "CURVES"]

#: observed curves per drainage type (test curve name -> CSV quantity)
CURVES = {True: {"q": "q", "e": "e"}, False: {"q": "q", "u": "u"}}
LABELS = {"q": "q (kPa)", "e": "void ratio e", "u": "excess pore pressure u (kPa)", "p": "p' (kPa)"}


@dataclass(frozen=True)
class TriaxialTest:
    """Conditions of one triaxial test and the axial strains (%) at which its curves are wanted."""

    name: str
    e0: float
    p0: float
    drained: bool
    strain_pct: tuple


def _flag(value, path, field):
    text = str(value).strip().lower()
    if text in ("true", "1", "yes", "drained"):
        return True
    if text in ("false", "0", "no", "undrained"):
        return False
    raise DataError(f"{path}: field {field!r} = {value!r} is not true/false")


def conditions_of(test: inference.Test) -> TriaxialTest:
    """TriaxialTest from an observed test's conditions (``e0``, ``p0_kPa``, ``drained``), errors naming the file."""
    cond, where = test.conditions, test.source or test.name
    values = {}
    for key in ("e0", "p0_kPa"):
        if key not in cond:
            raise DataError(f"{where}: missing condition {key!r} (a '# {key}: value' header line or an option)")
        try:
            values[key] = float(cond[key])
        except (TypeError, ValueError):
            raise DataError(f"{where}: condition {key!r} = {cond[key]!r} is not a number") from None
    if not 0.0 < values["e0"] < 2.97:
        raise DataError(f"{where}: condition 'e0' = {values['e0']} outside (0, 2.97)")
    if not values["p0_kPa"] > 0.0:
        raise DataError(f"{where}: condition 'p0_kPa' = {values['p0_kPa']} must be > 0")
    drained = _flag(cond.get("drained", "true"), where, "drained")
    x = np.unique(np.concatenate([c.x for c in test.curves.values()]))
    if x.min() < 0:
        raise DataError(f"{where}: axial strain {x.min()} % < 0 (compression tests only)")
    return TriaxialTest(test.name, values["e0"], values["p0_kPa"], drained, tuple(x))


class SimsandTriaxial:
    """Batched forward model for :class:`inference.Likelihood` (``batch=True``): a list of parameter dicts (the free
    parameters) -> a list of ``{test: {curve: (eps_a_pct, values)}}`` (an exception in place of a failed particle);
    the sampler's path is :meth:`simulate_arrays` (the likelihood's array protocol: the whole batch as arrays, no
    per-particle objects).

    tests: TriaxialTest list; fixed: SIMSAND parameters not identified (merged under each particle's dict);
    grid_pct: simulate at these axial strains (%) and let the likelihood interpolate to the recorded ones (the
    largest recorded strain must be on the grid); None: simulate exactly at the recorded strains. The initial state
    (eps_a = 0) is prepended.
    Curves: q, e, u (excess pore pressure), p.
    """

    def __init__(self, tests, fixed, grid_pct=None, model_options=None):
        self.tests = list(tests)
        self.fixed = dict(fixed)
        self.model_options = dict(model_options or {})
        self.groups = []
        for drained in (True, False):
            specs = [t for t in self.tests if t.drained == drained]
            if not specs:
                continue
            wanted = np.unique(np.concatenate([t.strain_pct for t in specs]))
            grid = wanted if grid_pct is None else np.unique(np.asarray(grid_pct, dtype=float))
            if grid.max() < wanted.max():
                raise ValueError(f"simulation grid ends at {grid.max():g} % before the largest recorded strain "
                                 f"{wanted.max():g} %")
            self.groups.append((drained, specs, grid[grid > 0]))

    def parameters(self, params: dict) -> dict:
        """Full SIMSAND parameter dict: ``fixed`` updated with ``params`` (a sample's error parameter sigma_eps,
        if present, is not a SIMSAND parameter and is left out)."""
        return self._complete({k: v for k, v in params.items() if k != "sigma_eps"})

    def _complete(self, free: dict) -> dict:
        full = dict(self.fixed)
        full.update(free)
        missing = set(SIMSAND.parameter_names) - set(full)
        if missing:
            raise ValueError(f"SIMSAND parameters neither free nor fixed: {sorted(missing)}")
        return full

    def simulate(self, batch):
        """Raw curves of a list of parameter dicts: {test: {curve: (m, n_grid + 1)}} with the initial point first,
        plus {test: failed (m,)} and {test: grid_pct}."""
        full = [self.parameters(p) for p in batch]
        return self._simulate({k: np.array([f[k] for f in full], dtype=float) for k in SIMSAND.parameter_names},
                              len(batch))

    def _simulate(self, columns, m):
        """:meth:`simulate` from one array (m,) (or a scalar) per SIMSAND parameter."""
        curves, failed, grids = {}, {}, {}
        for drained, specs, grid in self.groups:
            T = len(specs)
            params = {k: np.repeat(np.broadcast_to(np.asarray(v, dtype=float), (m,)), T) for k, v in columns.items()}
            model = SIMSAND(**params, **self.model_options)
            e0 = np.tile([t.e0 for t in specs], m)
            p0 = np.tile([t.p0 for t in specs], m)
            driver = labtests.drained_triaxial if drained else labtests.undrained_triaxial
            c = driver(model, e0, p0, grid / 100.0, on_failure="nan")
            for j, t in enumerate(specs):
                rows = slice(j, None, T)
                start = {"q": 0.0, "e": t.e0, "u": 0.0, "p": t.p0}
                curves[t.name] = {k: np.concatenate([np.full((m, 1), start[k]), c[src][rows]], axis=1)
                                  for k, src in (("q", "q"), ("e", "e"), ("u", "excess_pore_pressure"), ("p", "p"))}
                failed[t.name] = c["failed"][rows]
                grids[t.name] = np.concatenate([[0.0], grid])
        return curves, failed, grids

    def _failure(self, curves, failed, grids, i):
        """The reason particle i failed (None if it did not): the failing tests and the last strain reached."""
        bad = [t.name for t in self.tests if failed[t.name][i]]
        if not bad:
            return None
        t = bad[0]
        reached = grids[t][np.flatnonzero(np.isfinite(curves[t]["q"][i]))[-1]]
        return (f"SIMSAND triaxial integration failed in test(s) {bad}: {t} stopped after eps_a = {reached:g} % "
                f"(drained path lost control or local integration failed)")

    def __call__(self, batch):
        curves, failed, grids = self.simulate(batch)
        results = []
        for i in range(len(batch)):
            reason = self._failure(curves, failed, grids, i)
            if reason is not None:
                results.append(ForwardModelError(reason))
                continue
            results.append({t.name: {k: (grids[t.name], v[i]) for k, v in curves[t.name].items()}
                            for t in self.tests})
        return results

    def simulate_arrays(self, names, values):
        """The array protocol of :class:`inference.Likelihood`: free parameter ``names`` and their ``values``
        (m, k) -> ({test: {curve: (grid_pct, (m, n_grid + 1))}}, [None or the failure reason per particle])."""
        values = np.asarray(values, dtype=float)
        m = len(values)
        columns = self._complete({n: values[:, k] for k, n in enumerate(names) if n != "sigma_eps"})
        curves, failed, grids = self._simulate({k: columns[k] for k in SIMSAND.parameter_names}, m)
        any_failed = np.zeros(m, dtype=bool)
        for f in failed.values():
            any_failed |= f
        reasons = [None] * m
        for i in np.flatnonzero(any_failed):
            reasons[i] = self._failure(curves, failed, grids, i)
        return {t.name: {k: (grids[t.name], v) for k, v in curves[t.name].items()} for t in self.tests}, reasons


def predictive(forward: SimsandTriaxial, post, n_draws=200, seed=0):
    """Posterior predictive of Eq. (1): U = c U_num(b), c ~ N(1, sigma_eps^2), over ``n_draws`` final-stage samples
    (one batched forward call). Returns ({test: {curve: (q2.5, q50, q97.5) arrays}}, {test: grid}, MAP curves)."""
    rng = np.random.default_rng(seed)
    names = list(post.names)
    idx = rng.choice(len(post.samples), size=min(n_draws, len(post.samples)), replace=False)
    draws = post.samples[idx]
    sig = draws[:, names.index("sigma_eps")] if "sigma_eps" in names else np.zeros(len(draws))
    soil = [{n: float(v) for n, v in zip(names, th) if n != "sigma_eps"} for th in np.vstack([draws, post.map_theta])]
    curves, failed, grids = forward.simulate(soil)
    band, at_map = {}, {}
    for t in forward.tests:
        band[t.name], at_map[t.name] = {}, {}
        for k, v in curves[t.name].items():
            sims = v[:-1] * (1.0 + sig[:, None] * rng.standard_normal(v[:-1].shape))
            ok = ~failed[t.name][:-1]
            band[t.name][k] = np.nanquantile(sims[ok], [0.025, 0.5, 0.975], axis=0) if ok.any() else None
            at_map[t.name][k] = v[-1]
    return band, grids, at_map


def plot_curves(path, observations, forward, post, title, reference=None, predict=(), seed=0):
    """Data vs MAP curves with the 95 % posterior predictive band, one row per test (the paper's Figs. 2-4, 13).
    ``reference``: optional {test: {curve: (x, y)}} drawn dashed (true-value curves); ``predict``: names of tests
    not used in the calibration (titled "prediction")."""
    plt = study.pyplot()
    band, grids, at_map = predictive(forward, post, seed=seed)
    tests = list(forward.tests)
    ncol = max(len(CURVES[t.drained]) for t in tests)
    fig, axes = plt.subplots(len(tests), ncol, figsize=(4.6 * ncol, 3.0 * len(tests)), squeeze=False)
    for row, t in zip(axes, tests):
        obs = observations[t.name] if t.name in observations.tests else None
        for ax, k in zip(row, CURVES[t.drained]):
            x = grids[t.name]
            if band[t.name][k] is not None:
                ax.fill_between(x, band[t.name][k][0], band[t.name][k][2], color="C0", alpha=0.25,
                                label="95 % posterior predictive")
            ax.plot(x, at_map[t.name][k], "C0-", lw=1.5, label="MAP")
            if reference and t.name in reference:
                ax.plot(*reference[t.name][k], "k--", lw=1, label="true values")
            if obs is not None and k in obs.curves:
                ax.plot(obs.curves[k].x, obs.curves[k].y, ".", color="C3", ms=3, label="data")
            role = "prediction" if t.name in predict else "calibration"
            ax.set_title(f"{t.name} ({role}): e0 {t.e0:g}, p'0 {t.p0:g} kPa", fontsize=9)
            ax.set_xlabel("axial strain (%)")
            ax.set_ylabel(LABELS[k])
        for ax in row[len(CURVES[t.drained]):]:
            ax.axis("off")
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.35 / fig.get_figheight()))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def critical_void_ratio(params, p):
    """(VI) e_c(p') for a full SIMSAND parameter dict (through the model, not a copy of the formula)."""
    return SIMSAND(**params).critical_void_ratio(p)


def plot_csl(path, lines: dict, end_states=None, title=""):
    """CSL in e-log p' (Fig. 6/14 style): ``lines`` {label: full SIMSAND parameter dict}; ``end_states``
    {label: (p', e)} of the data at the end of each test."""
    plt = study.pyplot()
    p = np.geomspace(5.0, 5000.0, 200)
    fig, ax = plt.subplots(figsize=(5.2, 3.8))
    for k, (label, prm) in enumerate(lines.items()):
        ax.semilogx(p, critical_void_ratio(prm, p), ["C3-", "k--", "C0:", "C2-."][k % 4], label=label)
    for label, (pe, ee) in (end_states or {}).items():
        ax.semilogx(pe, ee, "o", mfc="none", label=label)
    ax.set_xlabel("p' (kPa)")
    ax.set_ylabel("critical void ratio e_c")
    ax.legend(fontsize=7)
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_map_spread(path, summaries, names, reference: dict, title):
    """MAP of each run divided by the reference value, per parameter and method (the paper's Fig. 5 style)."""
    plt = study.pyplot()
    fig, ax = plt.subplots(figsize=(1.0 + 0.8 * len(names), 3.6))
    methods = sorted({s["method"] for s in summaries})
    for k, m in enumerate(methods):
        runs = [s for s in summaries if s["method"] == m]
        for j, n in enumerate(names):
            maps = np.array([s["parameters"][n]["map"] for s in runs])
            shift = 0.25 * (k - (len(methods) - 1) / 2)
            ax.plot(np.full(maps.size, j + shift) + np.linspace(-0.08, 0.08, maps.size), maps / reference[n],
                    "os"[k % 2], color=f"C{k}", mfc="none", label=m if j == 0 else None)
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_xticks(range(len(names)))
    ax.set_xticklabels(names, rotation=45)
    ax.set_ylabel("MAP / reference value")
    ax.legend(fontsize=7)
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def sampler_settings(args, preset, max_failure_fraction):
    """tmcmc settings of a SIMSAND study: the preset's sweep cap, ``--sweeps`` (fixed count) or adaptive, and the
    study's failure allowance."""
    return dict(max_steps=preset["max_steps"], n_steps=args.sweeps or "adaptive", min_steps=min(2, args.sweeps or 2),
                max_failure_fraction=max_failure_fraction)


def write_runs(top, title, summaries, names, references, spread_reference, note=""):
    """With several runs: runs.md (average MAP and spread per method beside the references) and map_spread.png."""
    if len(summaries) < 2:
        return
    top = Path(top)
    text = f"# {title}\n\n" + (f"**{note}**\n\n" if note else "")
    (top / "runs.md").write_text(text + study.runs_table(summaries, names, references) + "\n")
    shown = [n for n in names if n in spread_reference]
    plot_map_spread(top / "map_spread.png", summaries, shown, spread_reference,
                    f"MAP of {len(summaries)} runs / reference: {title}")

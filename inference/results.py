"""What a TMCMC run yields: a :class:`Posterior` when its tempering exponent reaches beta = 1, a :class:`RunProgress`
when it stops before.

Posterior: samples, MAP (7), moments, quantiles, log-evidence and stage records, saved as ``posterior.npz`` (every
stage's samples and log-likelihoods, readable with numpy alone), ``posterior.nc`` (the ArviZ InferenceData of
``to_arviz()``), ``summary.json`` and ``failed_solves.jsonl``.

RunProgress: what a run did before it stopped without a posterior (too many failed solves, no convergence, a
signal), saved as ``progress.json`` and ``failed_solves.jsonl``.

Wall times (s): ``wall_s`` is the run's wall time summed over its sessions (a session killed without a checkpoint
at the end counts up to its last checkpoint); ``wall_s_this_session`` is the time of the sampler call that wrote
the file, shorter after a resume.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["Posterior", "RunProgress", "write_failures", "FAILURES_FILE", "PROGRESS_FILE"]

#: one JSON object per failed forward evaluation: stage, where, particle, rank, reason, theta
FAILURES_FILE = "failed_solves.jsonl"
#: where a run stopped without a posterior (:class:`RunProgress`); a finished run's summary.json supersedes it
PROGRESS_FILE = "progress.json"
#: the groups of posterior.nc in the order ArviZ writes them
ARVIZ_GROUP_ORDER = ("posterior", "posterior_predictive", "log_likelihood", "sample_stats", "observed_data")


@dataclass
class Posterior:
    names: tuple
    samples: np.ndarray            # (N, d) final-stage samples (exponent beta = 1), equally weighted
    log_like: np.ndarray           # (N,)
    log_evidence: float            # sum_j ln S_j
    map_theta: np.ndarray          # (d,) the evaluated sample of largest prior x likelihood, Eq. (7)
    map_log_posterior: float
    stages: list                   # per-stage records: beta (the tempering exponent beta_j), log_S, acceptance,
                                   # n_evals, n_failed, sweeps, wall_s, beta2 (the random-walk scale of Eq. (11))
    stage_samples: list            # list of (N, d) arrays, stage 0 = prior
    stage_log_like: list
    failures: list                 # failed evaluations: stage, where, particle, rank, reason, theta
    n_forward_solves: int
    wall_s: float                  # summed over the run's sessions (s)
    ranks: int
    executor: str
    settings: dict = field(default_factory=dict)
    prior: list = field(default_factory=list)
    wall_s_this_session: float = float("nan")   # this sampler call's wall time (s); = wall_s without a resume

    @classmethod
    def from_state(cls, st, prior, settings: dict, executor, wall_s, wall_s_this_session):
        """The posterior of a finished run: ``st`` an ``inference.tmcmc.state.RunState`` in phase DONE."""
        return cls(
            names=tuple(prior.names), samples=st.theta, log_like=st.log_like,
            log_evidence=float(st.log_evidence), map_theta=st.map.theta,
            map_log_posterior=st.map.log_posterior, stages=[r.as_dict() for r in st.records],
            stage_samples=st.stage_theta, stage_log_like=st.stage_log_like, failures=st.failures,
            n_forward_solves=int(st.n_evals), wall_s=float(wall_s), ranks=int(getattr(executor, "ranks", 1)),
            executor=executor.name, settings=dict(settings), prior=prior.describe(),
            wall_s_this_session=float(wall_s_this_session))

    # ---- statistics keyed by parameter name
    def _named(self, values):
        return {n: float(v) for n, v in zip(self.names, values)}

    @property
    def map(self) -> dict:
        return self._named(self.map_theta)

    @property
    def mean(self) -> dict:
        return self._named(self.samples.mean(axis=0))

    @property
    def std(self) -> dict:
        return self._named(self.samples.std(axis=0, ddof=1))

    def quantiles(self, q=(0.025, 0.5, 0.975)) -> dict:
        qs = np.quantile(self.samples, q, axis=0)
        return {n: [float(v) for v in qs[:, i]] for i, n in enumerate(self.names)}

    def credible_interval(self, name, level=0.95):
        i = self.names.index(name)
        lo, hi = np.quantile(self.samples[:, i], [(1 - level) / 2, (1 + level) / 2])
        return float(lo), float(hi)

    @property
    def n_stages(self) -> int:
        return len(self.stages) - 1

    def summary(self) -> dict:
        mean, std, quant = self.mean, self.std, self.quantiles()
        return {
            "n_samples": int(self.samples.shape[0]), "n_stages": self.n_stages,
            "n_forward_solves": self.n_forward_solves, "n_failed_solves": len(self.failures),
            "wall_s": self.wall_s, "wall_s_this_session": self.wall_s_this_session, "ranks": self.ranks,
            "executor": self.executor,
            "log_evidence": self.log_evidence, "map_log_posterior": self.map_log_posterior,
            "parameters": {n: {"map": self.map[n], "mean": mean[n], "std": std[n], "q2.5": quant[n][0],
                               "median": quant[n][1], "q97.5": quant[n][2]} for n in self.names},
            "stages": _plain_records(self.stages),
            "settings": {k: v for k, v in self.settings.items()}, "prior": self.prior,
        }

    def save(self, out_dir, extra: dict | None = None, observations=None, map_simulated=None, pointwise=None,
             later=None) -> Path:
        """Write posterior.npz, posterior.nc (:meth:`write_netcdf` with ``observations``, ``map_simulated`` and
        ``pointwise``; ``later``: a callable ``later(write, *args)`` that keeps that writer to be called later, e.g.
        a loop's queue of outputs that nothing reads before its end; None: now), summary.json (with ``extra`` merged
        at the top level) and failed_solves.jsonl (empty when nothing failed) into out_dir; a progress.json left by an
        earlier stopped session is removed."""
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(
            out / "posterior.npz", names=np.array(self.names), samples=self.samples, log_like=self.log_like,
            map_theta=self.map_theta, beta=np.array([r["beta"] for r in self.stages]),
            log_S=np.array([r["log_S"] for r in self.stages]),
            stage_samples=np.stack(self.stage_samples), stage_log_like=np.stack(self.stage_log_like))
        (later or _now)(self.write_netcdf, out, observations, map_simulated, pointwise)
        summary = self.summary()
        summary.update(extra or {})
        _write_text(out / "summary.json", json.dumps(summary, indent=2, default=_json_default))
        write_failures(out, self.failures)
        (out / PROGRESS_FILE).unlink(missing_ok=True)
        return out

    def write_netcdf(self, out_dir, observations=None, map_simulated=None, pointwise=None):
        """posterior.nc in out_dir: the groups of :meth:`to_arviz`, written whole or not at all (a temporary file
        renamed). The file is the one ``arviz.InferenceData.to_netcdf`` writes (its attributes in the root group, each
        group in a netCDF group of its name, numeric variables zlib-compressed, through h5netcdf), written with
        xarray alone: importing ArviZ takes some 4 s in a fresh process, which each process writing a posterior
        would pay."""
        tmp = Path(out_dir) / "posterior.nc.tmp"
        attrs, groups = self._arviz_groups(observations, map_simulated, pointwise)
        import xarray as xr

        xr.Dataset(attrs=attrs).to_netcdf(tmp, mode="w", engine="h5netcdf")
        for name in (name for name in ARVIZ_GROUP_ORDER if name in groups):
            data = groups[name]
            data.to_netcdf(tmp, mode="a", group=name, engine="h5netcdf", encoding={
                var: {"zlib": True} for var, values in data.variables.items() if values.dtype.kind in "biufcS"})
        tmp.replace(Path(out_dir) / "posterior.nc")

    def to_arviz(self, observations=None, map_simulated=None, pointwise=None):
        """The run as an ArviZ InferenceData (:meth:`write_netcdf` writes its groups as posterior.nc)."""
        import arviz as az

        attrs, groups = self._arviz_groups(observations, map_simulated, pointwise)
        return az.InferenceData(attrs=attrs, **groups)

    def _arviz_groups(self, observations=None, map_simulated=None, pointwise=None):
        """(attributes, {group: xarray.Dataset}) of the run as an ArviZ InferenceData. Groups:

        - ``posterior``: the final-stage samples (beta = 1), one chain of N draws, one variable per parameter;
        - ``log_likelihood``: ``total``, each draw's log-likelihood summed over every test and point (Eq. (6) with
          its sigma_eps); with ``observations`` and ``pointwise`` ({(test, curve): (N, n_recorded)},
          ``inference.Likelihood.pointwise_log_likelihood`` of the draws) also each point's term, one variable per
          curve named as in ``observed_data`` (what LOO/WAIC read);
        - ``sample_stats``: per draw ``log_likelihood``; per tempering stage j (dimension ``stage``, 0 = the prior)
          the exponent ``beta``, ``log_S`` (ln S_j, Eq. (10)), ``acceptance``, ``sweeps``, ``n_evals`` and
          ``n_failed``; attribute ``log_evidence`` (ln Z = sum_j ln S_j); the samples of the earlier stages are in
          posterior.npz only;
        - ``observed_data`` (with ``observations``, an :class:`inference.Observations`): one variable per recorded
          curve, named ``<test>:<curve>``, over its points with the abscissa as a coordinate, units in its attributes;
        - ``posterior_predictive`` (with ``map_simulated``, {(test, curve): simulated values at the recorded
          abscissae}): the forward model's curves at the MAP (Eq. (7)), one draw without the error term; curves of
          other draws are not stored.

        The file-level attributes hold ``log_evidence`` and ``sampler``."""
        import xarray as xr

        n = len(self.samples)
        draws = {"chain": [0], "draw": np.arange(n)}
        posterior = xr.Dataset({name: (("chain", "draw"), self.samples[None, :, i])
                                for i, name in enumerate(self.names)}, coords=draws)
        stage_values = {key: ("stage", np.array([float(r[key]) for r in self.stages]))
                        for key in ("beta", "log_S", "acceptance", "sweeps", "n_evals", "n_failed")}
        groups = {
            "posterior": posterior,
            "log_likelihood": xr.Dataset({"total": (("chain", "draw"), self.log_like[None, :])}, coords=draws),
            "sample_stats": xr.Dataset({"log_likelihood": (("chain", "draw"), self.log_like[None, :]),
                                        **stage_values}, coords={**draws, "stage": np.arange(len(self.stages))},
                                       attrs={"log_evidence": self.log_evidence}),
        }
        def curves(values, unit=None, attrs=None):
            """One variable per recorded curve, ``values[test, curve]`` over its points."""
            return xr.Dataset({_curve_variable(t.name, c): _curve_array(xr, curve, t.name, c, values[t.name, c], unit)
                               for t in observations for c, curve in t.curves.items()}, attrs=attrs)

        if observations is not None:
            groups["observed_data"] = curves({(t.name, c): curve.y for t in observations
                                              for c, curve in t.curves.items()})
            if pointwise is not None:
                groups["log_likelihood"] = groups["log_likelihood"].merge(curves(pointwise, unit="-"))
            if map_simulated is not None:
                groups["posterior_predictive"] = curves(
                    {key: np.atleast_2d(v) for key, v in map_simulated.items()},
                    attrs={"draws": "the MAP (Eq. (7)) only, without the error term"})
        return {"log_evidence": self.log_evidence, "sampler": "TMCMC"}, groups


def _now(write, *args):
    write(*args)


def _curve_variable(test: str, curve: str) -> str:
    """The InferenceData variable of a recorded curve (netCDF names take no "/")."""
    return f"{test}:{curve}".replace("/", "_")


def _curve_array(xr, curve, test, name, values, unit=None):
    """One curve's values over its points as an xarray DataArray (``xr`` the xarray module): ``values`` (n,) the
    record, or (draws, n) one chain of draws; the abscissa a coordinate, ``unit`` (default the curve's) an
    attribute."""
    values = np.asarray(values, dtype=float)
    point = f"{_curve_variable(test, name)}:point"
    coords = {f"{_curve_variable(test, name)}:{curve.x_name}": (point, curve.x)}
    if values.ndim == 2:
        values, dims = values[None], ("chain", "draw", point)
        coords.update(chain=[0], draw=np.arange(values.shape[1]))
    else:
        dims = (point,)
    return xr.DataArray(values, dims=dims, coords=coords,
                        attrs={"test": test, "curve": name, "unit": curve.y_unit if unit is None else unit,
                               "abscissa": curve.x_name, "abscissa_unit": curve.x_unit})


@dataclass
class RunProgress:
    """What a run did before it stopped without a posterior; carried by the stop (``progress`` of the
    :class:`inference.SamplerError` or of the ``SystemExit`` that :func:`inference.tmcmc` raises).

    ``stages`` holds the records of the finished stages (as :attr:`Posterior.stages`), ``stage_under_way`` the
    record of the stage that was running (its evaluations and failures so far) or None; ``failures`` every failed
    evaluation of the finished batches (those of a batch cut by a signal are in the checkpoint); ``exponent`` the
    tempering exponent beta_j reached and ``log_evidence_so_far`` sum_j ln S_j over the stages begun (ln Z only at
    beta = 1); the MAP so far (Eq. (7)) when any evaluation succeeded; ``checkpoint`` the file to resume from, or None.
    """

    reason: str                    # one line: why the run stopped
    names: tuple
    stages: list
    stage_under_way: dict | None
    failures: list
    n_forward_solves: int
    exponent: float
    log_evidence_so_far: float
    map_theta: np.ndarray | None
    map_log_posterior: float | None
    wall_s: float                  # summed over the run's sessions (s)
    wall_s_this_session: float
    checkpoint: str | None = None

    @classmethod
    def from_state(cls, st, prior, reason: str, wall_s, wall_s_this_session, checkpoint=None):
        """The progress of ``st``, an ``inference.tmcmc.state.RunState`` of a run that stopped."""
        return cls(
            reason=reason, names=tuple(prior.names), stages=[r.as_dict() for r in st.records],
            stage_under_way=st.current.as_dict() if st.current is not None else None, failures=list(st.failures),
            n_forward_solves=int(st.n_evals), exponent=float(st.exponent),
            log_evidence_so_far=float(st.log_evidence),
            map_theta=None if st.map is None else np.array(st.map.theta),
            map_log_posterior=None if st.map is None else float(st.map.log_posterior),
            wall_s=float(wall_s), wall_s_this_session=float(wall_s_this_session),
            checkpoint=None if checkpoint is None else str(checkpoint))

    @property
    def map(self) -> dict | None:
        return None if self.map_theta is None else {n: float(v) for n, v in zip(self.names, self.map_theta)}

    def summary(self) -> dict:
        under_way = self.stage_under_way
        return {
            "stopped": self.reason, "n_stages_finished": max(len(self.stages) - 1, 0), "exponent": self.exponent,
            "log_evidence_so_far": self.log_evidence_so_far, "n_forward_solves": self.n_forward_solves,
            "n_failed_solves": len(self.failures), "wall_s": self.wall_s,
            "wall_s_this_session": self.wall_s_this_session, "checkpoint": self.checkpoint,
            "map": self.map, "map_log_posterior": self.map_log_posterior, "stages": _plain_records(self.stages),
            "stage_under_way": None if under_way is None else _plain_records([under_way])[0],
        }

    def save(self, out_dir, extra: dict | None = None) -> Path:
        """Write progress.json (with ``extra`` merged at the top level) and failed_solves.jsonl (empty when nothing
        failed) into out_dir."""
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        summary = self.summary()
        summary.update(extra or {})
        _write_text(out / PROGRESS_FILE, json.dumps(summary, indent=2, default=_json_default))
        write_failures(out, self.failures)
        return out


def write_failures(out_dir, failures) -> Path:
    """Write failed_solves.jsonl into out_dir: one JSON object per failed evaluation (stage, where, particle, rank,
    reason, theta by name), an empty file when the list is empty. Returns the file's path."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / FAILURES_FILE
    _write_text(path, "".join(json.dumps(f, default=_json_default) + "\n" for f in failures))
    return path


def _write_text(path: Path, text: str) -> None:
    """Write a file whole or not at all (a temporary file renamed over it)."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    tmp.replace(path)


def _plain_records(records) -> list:
    return [{k: (float(v) if isinstance(v, (float, np.floating)) else v) for k, v in r.items()} for r in records]


def _json_default(obj):
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    return str(obj)

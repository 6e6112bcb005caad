"""The result of a TMCMC run: posterior samples, MAP (7), moments, quantiles, log-evidence and stage records.

Saved as ``posterior.npz`` (every stage's samples and log-likelihoods, readable with numpy alone) plus
``summary.json``; ``to_arviz()`` builds an ArviZ InferenceData when arviz is installed.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["Posterior"]


@dataclass
class Posterior:
    names: tuple
    samples: np.ndarray            # (N, d) final-stage samples (exponent p = 1), equally weighted
    log_like: np.ndarray           # (N,)
    log_evidence: float            # sum_j ln S_j
    map_theta: np.ndarray          # (d,) the evaluated sample of largest prior x likelihood, Eq. (7)
    map_log_posterior: float
    stages: list                   # per-stage records: q (the tempering exponent p_j), log_S, acceptance, n_evals,
                                   # n_failed, sweeps, wall_s, beta2
    stage_samples: list            # list of (N, d) arrays, stage 0 = prior
    stage_log_like: list
    failures: list                 # failed evaluations: stage, where, particle, rank, reason, theta
    n_forward_solves: int
    wall_s: float
    ranks: int
    executor: str
    settings: dict = field(default_factory=dict)
    prior: list = field(default_factory=list)

    @classmethod
    def from_state(cls, st, prior, settings: dict, executor, wall_s):
        """The posterior of a finished run: ``st`` an ``inference.tmcmc.state.RunState`` in phase "done"."""
        return cls(
            names=tuple(prior.names), samples=st.theta, log_like=st.log_like,
            log_evidence=float(st.log_evidence), map_theta=st.map.theta,
            map_log_posterior=st.map.log_posterior, stages=[r.as_dict() for r in st.records],
            stage_samples=st.stage_theta, stage_log_like=st.stage_log_like, failures=st.failures,
            n_forward_solves=int(st.n_evals), wall_s=float(wall_s), ranks=int(getattr(executor, "ranks", 1)),
            executor=executor.name, settings=dict(settings), prior=prior.describe())

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
            "wall_s": self.wall_s, "ranks": self.ranks, "executor": self.executor,
            "log_evidence": self.log_evidence, "map_log_posterior": self.map_log_posterior,
            "parameters": {n: {"map": self.map[n], "mean": mean[n], "std": std[n], "q2.5": quant[n][0],
                               "median": quant[n][1], "q97.5": quant[n][2]} for n in self.names},
            "stages": [{k: (float(v) if isinstance(v, (float, np.floating)) else v) for k, v in r.items()}
                       for r in self.stages],
            "settings": {k: v for k, v in self.settings.items()}, "prior": self.prior,
        }

    def save(self, out_dir, extra: dict | None = None) -> Path:
        """Write posterior.npz and summary.json (with ``extra`` merged at the top level) into out_dir."""
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(
            out / "posterior.npz", names=np.array(self.names), samples=self.samples, log_like=self.log_like,
            map_theta=self.map_theta, q=np.array([r["q"] for r in self.stages]),
            log_S=np.array([r["log_S"] for r in self.stages]),
            stage_samples=np.stack(self.stage_samples), stage_log_like=np.stack(self.stage_log_like))
        summary = self.summary()
        summary.update(extra or {})
        tmp = out / "summary.json.tmp"
        tmp.write_text(json.dumps(summary, indent=2, default=_json_default))
        tmp.replace(out / "summary.json")
        if self.failures:
            with open(out / "failed_solves.jsonl", "w") as fh:
                for f in self.failures:
                    fh.write(json.dumps(f, default=_json_default) + "\n")
        return out

    def to_arviz(self):
        """ArviZ InferenceData of the final-stage samples (needs the optional arviz package). The log_likelihood
        group holds one variable, ``total``: each sample's log-likelihood summed over every test and point (Eq. (6)
        with its sigma_eps), not the pointwise values that LOO/WAIC would need."""
        try:
            import arviz as az
        except ImportError as exc:
            raise ImportError("to_arviz needs arviz: pip install 'geoinfer[arviz]'") from exc
        post = {n: self.samples[None, :, i] for i, n in enumerate(self.names)}
        return az.from_dict(posterior=post, log_likelihood={"total": self.log_like[None, :]},
                            attrs={"log_evidence": self.log_evidence, "sampler": "TMCMC"})


def _json_default(obj):
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    return str(obj)

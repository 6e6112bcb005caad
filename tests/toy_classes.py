"""A calibrated model class of a toy problem (the diagnosis loop's tests): TMCMC with 300 particles, its record as
``inference.diagnosis.ModelClass`` with 40 posterior-sample curves for the predictive band; the likelihood of a toy
forward model of one parameter set, scored a batch at a time."""
import numpy as np

from inference import Likelihood, SerialExecutor, UniformPrior, diagnosis, tmcmc
from inference.diagnosis import ModelClass


def batched_likelihood(observations, simulate) -> Likelihood:
    """The likelihood of ``simulate`` (parameters -> curves) taking a list of parameter sets, so that the sampler's
    executor hands it batches: the same values as one set at a time, with less Python per set."""
    return Likelihood(observations, lambda sets: [simulate(p) for p in sets], batch=True)


def calibrated_class(like, simulate, bounds, name, role, candidate, sigma_bounds=(0.001, 0.1)) -> ModelClass:
    """Calibrate ``like`` (an inference.Likelihood with one sigma_eps, of the forward model ``simulate``: parameters
    -> curves) under uniform ``bounds``; its record."""
    post = tmcmc(like, UniformPrior({**bounds, "sigma_eps": sigma_bounds}), n_samples=300, max_steps=5, seed=7,
                 executor=SerialExecutor(), progress=False)
    params, sigma = like.split(post.map_theta)
    rows = np.random.default_rng(0).choice(len(post.samples), size=40, replace=False)
    sims, sigmas = diagnosis.simulate_samples(like, post.samples[rows])
    map_simulated = like.simulated_at_observations(simulate(params))
    q = post.quantiles()
    return ModelClass(
        name=name, role=role, candidate=candidate, log_evidence=post.log_evidence,
        J_g=like.goodness_of_fit(map_simulated),
        parameters={n: {"map": post.map[n], "mean": post.mean[n], "std": post.std[n], "q2.5": q[n][0],
                        "q97.5": q[n][2]} for n in post.names},
        sigma_eps=sigma, map_simulated=map_simulated, sample_simulated=sims, sample_sigma=sigmas,
        wall_s=post.wall_s, n_forward_solves=post.n_forward_solves, extra={"posterior": post})

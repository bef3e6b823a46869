"""emcee moves, the interruptible run, and the sampling loops of both posteriors.

* :func:`ensemble_moves`: differential-evolution or stretch moves with a
  vectorised accept step;
* :func:`run_with_progress`: ``run_mcmc`` that logs its progress and stops
  cleanly on SIGINT/SIGTERM (also used by :mod:`studies.discovery.fitting`);
* :func:`sample_regression_chain`: one run of the regression posterior (a)
  from a small ball around the least-squares solution;
* :func:`sample_trajectory_chain`: the two-stage run of the trajectory
  posterior (b), whose likelihood is corrected for autocorrelation between
  the stages.

Every sampler draws from its own ``numpy.random.RandomState(seed)``, so the
samples do not depend on numpy's global state.
"""

from __future__ import annotations

import logging

import emcee
import numpy as np
from emcee.state import State

from ... import interrupt
from ...errors import ConfigError
from .diagnostics import MIN_TAU_MULTIPLE, ChainDiagnostics, ChainHistory, autocorr_time, diagnose
from .likelihood import RegressionPosterior, TrajectoryLikelihood

__all__ = ["ensemble_moves", "run_with_progress", "ensemble_sampler", "sample_regression_chain",
           "sample_trajectory_chain"]

#: one logger for the whole package: ``studies.identification.bayes``
logger = logging.getLogger(__package__)


def _vectorised(move_class):
    """``move_class`` (an emcee red-blue move) with the accept step vectorised.

    emcee's :meth:`RedBlueMove.propose` accepts walker by walker in a Python
    loop; with a cheap vectorised log-probability that loop is a third of the
    run time. The proposal, the acceptance rule and the bookkeeping are
    emcee's own; only the loop is replaced by array operations.
    """

    class Vectorised(move_class):
        def propose(self, model, state):
            nwalkers, ndim = state.coords.shape
            if nwalkers < 2 * ndim and not self.live_dangerously:
                raise RuntimeError("It is unadvisable to use a red-blue move "
                                   "with fewer walkers than twice the number of dimensions.")
            self.setup(state.coords)
            accepted = np.zeros(nwalkers, dtype=bool)
            inds = np.arange(nwalkers) % self.nsplits
            if self.randomize_split:
                model.random.shuffle(inds)
            for split in range(self.nsplits):
                s1 = inds == split
                sets = [state.coords[inds == j] for j in range(self.nsplits)]
                q, factors = self.get_proposal(sets[split], sets[:split] + sets[split + 1:],
                                               model.random)
                new_log_probs, new_blobs = model.compute_log_prob_fn(q)
                lnpdiff = factors + new_log_probs - state.log_prob[s1]
                accepted[s1] = lnpdiff > np.log(model.random.rand(int(s1.sum())))
                new_state = State(q, log_prob=new_log_probs, blobs=new_blobs)
                state = self.update(state, new_state, accepted, s1)
            return state, accepted

    Vectorised.__name__ = f"Vectorised{move_class.__name__}"
    return Vectorised


def ensemble_moves(kind: str, n_walkers: int, ndim: int):
    """The move of ``kind`` (``"de"`` or ``"stretch"``), vectorised.

    Fewer than ``2 ndim`` walkers are allowed (and diagnosed by
    :func:`~studies.identification.bayes.diagnostics.diagnose`) rather than refused.
    """
    live = n_walkers < 2 * ndim
    if kind == "de":
        return _vectorised(emcee.moves.DEMove)(live_dangerously=live)
    if kind == "stretch":
        return _vectorised(emcee.moves.StretchMove)(live_dangerously=live)
    raise ConfigError(f"method.moves must be 'de' or 'stretch', got {kind!r}")


def run_with_progress(sampler, start, steps: int, label: str | None = None,
                      history: ChainHistory | None = None):
    """``sampler.run_mcmc`` that logs its progress five times when given a
    ``label``, records its acceptance and autocorrelation time at the
    checkpoints of ``history`` when given one, and stops on SIGINT/SIGTERM
    between steps: inside emcee a signal would be caught and printed as a
    traceback.

    Returns
    -------
    emcee.State or None
        The walkers after the last step (``None`` when ``steps`` is 0).
    """
    every = max(1, steps // 5)
    state = None
    with interrupt.deferred():
        for i, state in enumerate(sampler.sample(start, iterations=steps), 1):
            interrupt.checkpoint()
            if history is not None:
                history.record(sampler, i)
            if label and (i % every == 0 or i == steps):
                logger.info("%s: emcee step %d/%d, mean acceptance %.2f", label, i, steps,
                            float(np.mean(sampler.acceptance_fraction)))
    return state


def ensemble_sampler(log_prob, n_walkers: int, ndim: int, moves, seed: int) -> emcee.EnsembleSampler:
    """An :class:`emcee.EnsembleSampler` of a vectorised ``log_prob`` whose
    random numbers come from ``numpy.random.RandomState(seed)``."""
    sampler = emcee.EnsembleSampler(n_walkers, ndim, log_prob, vectorize=True, moves=moves)
    sampler.random_state = np.random.RandomState(seed).get_state()
    return sampler


#: a chain extended for convergence is extended to this multiple of 50 autocorrelation times
EXTENSION_MARGIN = 1.2


def sample_regression_chain(post: RegressionPosterior, n_walkers: int, n_samples: int,
                            burn_in: int, thin: int, init_scale: float, moves: str, seed: int,
                            label: str, max_steps: int | None = None) -> tuple[np.ndarray, ChainDiagnostics]:
    """Sample the regression posterior (a) of one DOF.

    The walkers start in a ball of radius ``init_scale`` around the
    least-squares solution (sampled coordinates, i.e. LS standard errors);
    the chain after ``burn_in`` has ``thin * ceil(n_samples / n_walkers)``
    steps. With ``max_steps``, a chain shorter than 50 autocorrelation
    times runs on by itself from where it stopped, to
    :data:`EXTENSION_MARGIN` x 50 times the autocorrelation time measured
    so far, again while it falls short, until it converges or reaches
    ``max_steps`` steps after burn-in (the budget); the ``n_samples`` kept
    are then thinned from the whole chain.

    Parameters
    ----------
    post : RegressionPosterior
    n_walkers, n_samples, burn_in, thin : int
        See :class:`~studies.identification.bayes.estimator.BayesianRegression`.
    init_scale : float
        Radius of the initial ball [LS standard errors].
    moves : {"de", "stretch"}
    seed : int
        Seed of the initial ball and of the sampler.
    label : str
        The DOF, for the progress log and the diagnostics.
    max_steps : int, optional
        Most steps after burn-in when the chain is extended for convergence
        (``method.max_steps``); None: never extended.

    Returns
    -------
    chain : ndarray (n_samples, p + 1)
        The last ``n_samples`` kept samples, in sampled coordinates
        (:meth:`RegressionPosterior.to_coefficients` maps them back).
    diag : ChainDiagnostics
    """
    ndim = post.ndim
    rng = np.random.default_rng(seed)
    x0 = init_scale * rng.standard_normal((n_walkers, ndim))
    kept = int(np.ceil(n_samples / n_walkers))
    steps = thin * kept
    sampler = ensemble_sampler(post.log_prob, n_walkers, ndim,
                               ensemble_moves(moves, n_walkers, ndim), seed)
    history = ChainHistory(burn_in + steps, burn_in)
    state = run_with_progress(sampler, x0, burn_in + steps, f"bayes {label}", history)
    planned = steps
    while max_steps is not None and steps < max_steps:
        tau = autocorr_time(sampler, burn_in)
        if np.isfinite(tau) and steps > MIN_TAU_MULTIPLE * tau:
            break
        # too short to estimate the autocorrelation time: double it
        target = EXTENSION_MARGIN * MIN_TAU_MULTIPLE * tau if np.isfinite(tau) else 2 * steps + 100
        more = min(int(np.ceil(target)), int(max_steps)) - steps
        if more <= 0:
            break
        logger.info("bayes %s: chain of %d steps shorter than %g autocorrelation times (%s): "
                    "running %d more (method.max_steps=%d)", label, steps, MIN_TAU_MULTIPLE,
                    f"{tau:.0f} steps" if np.isfinite(tau) else "not yet estimable", more, max_steps)
        longer = ChainHistory(more, offset=burn_in + steps, with_autocorr=False)
        state = run_with_progress(sampler, state, more, f"bayes {label} (longer)", longer)
        history.extend(longer)
        steps += more
    diag = diagnose(sampler, burn_in, steps, label, history, budget=max_steps if steps > planned else None)
    every = max(thin, (steps * n_walkers) // max(n_samples, 1)) if steps > planned else thin
    chain = sampler.get_chain(discard=burn_in, thin=every, flat=True)[-n_samples:]
    return chain, diag


def sample_trajectory_chain(likelihood: TrajectoryLikelihood, x0: np.ndarray, x_start: np.ndarray,
                            burn_in: int, steps: int, thin: int, moves: str, seed: int,
                            autocorr_correction: bool) -> tuple[np.ndarray, ChainDiagnostics]:
    """Sample the trajectory posterior (b) in two stages.

    The first half of the burn-in runs with ``kappa = 1`` to find the mode;
    then, with ``autocorr_correction``, the likelihood's ``kappa`` is
    estimated at the best walker and a second sampler (the target changed)
    continues from the walkers for the rest of the burn-in and ``steps``.

    Parameters
    ----------
    likelihood : TrajectoryLikelihood
        Its ``kappa`` is updated in place.
    x0 : ndarray (walkers, k)
        Initial walkers in prior coordinates (``|x| <= 1`` inside the box).
    x_start : ndarray (k,)
        Centre of the initial ball; where ``kappa`` is estimated when there
        is no first stage (``burn_in < 2``).
    burn_in, steps, thin : int
        Burn-in steps (both stages), steps kept after it, thinning.
    moves : {"de", "stretch"}
    seed : int
        Seed of the first sampler; the second uses ``seed + 1``.
    autocorr_correction : bool
        Estimate ``kappa`` between the stages.

    Returns
    -------
    chain : ndarray (n, k)
        Thinned samples after the burn-in, in prior coordinates.
    diag : ChainDiagnostics
    """
    n_walkers, ndim = x0.shape
    move = ensemble_moves(moves, n_walkers, ndim)  # one move object for both stages
    first = burn_in // 2
    sampler = ensemble_sampler(likelihood.log_prob, n_walkers, ndim, move, seed)
    history = ChainHistory(first, burn_in=first)          # the first stage is all burn-in
    state = run_with_progress(sampler, x0, first, history=history) if first else None
    coords = state.coords if state is not None else x0
    if autocorr_correction:
        best = coords[np.argmax(state.log_prob)] if state is not None else x_start
        likelihood.correct_for_autocorrelation(best)
    # second sampler: the target changed (kappa), so restart from the walkers
    sampler = ensemble_sampler(likelihood.log_prob, n_walkers, ndim, move, seed + 1)
    rest = burn_in - first
    second = ChainHistory(rest + steps, rest, offset=first)
    run_with_progress(sampler, coords, rest + steps, "bayes trajectory", second)
    diag = diagnose(sampler, rest, steps, "trajectory", second)
    history.extend(second)
    diag.history = history
    chain = sampler.get_chain(discard=rest, thin=thin, flat=True)
    return chain, diag

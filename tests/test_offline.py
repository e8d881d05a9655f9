import math

import numpy as np
import pytest

from emla_identification import offline
from emla_identification.offline import trajectory, weighted_least_squares
from emla_identification.rls import RecursiveLeastSquares

THETA = np.array([0.8, -1.5, 0.3, 2.0])


def regression(N, seed=0, noise=0.05):
    rng = np.random.default_rng(seed)
    Phi = rng.normal(size=(N, 4)) + [0.0, 1.0, 0.0, 0.5]
    return Phi, Phi @ THETA + noise * rng.normal(size=N)


def recursion(Phi, Y, lam, every=None, **kwargs):
    """The unguarded recursion; its state after every `every` rows (and the last)."""
    rls = RecursiveLeastSquares(Phi.shape[1], forgetting=lam, windup_limit=math.inf, **kwargs)
    ends = list(range(every, len(Y), every)) + [len(Y)] if every else [len(Y)]
    states, start = [], 0
    for end in ends:
        rls.update_block(Phi[start:end], Y[start:end])
        states.append((rls.theta, rls.covariance, rls.residual_variance, rls.parameter_std()))
        start = end
    return [np.array(field) for field in zip(*states)]


def assert_relative(actual, desired, rtol=1e-8):
    actual, desired = np.asarray(actual), np.asarray(desired)
    assert np.abs(actual - desired).max() <= rtol * np.abs(desired).max()


@pytest.mark.parametrize('lam', [1.0, 0.999, 0.98])
def test_offline_equals_the_recursion(lam):
    Phi, Y = regression(20_000)
    theta, P, variance, std = recursion(Phi, Y, lam)
    est = weighted_least_squares(Phi, Y, forgetting=lam)
    assert est.samples == 20_000
    assert_relative(est.theta, theta[0])
    assert_relative(est.covariance, P[0])
    assert est.residual_variance == pytest.approx(variance[0], rel=1e-6)
    np.testing.assert_allclose(est.std, std[0], rtol=1e-6)


@pytest.mark.parametrize('lam, every', [(1.0, 4000), (0.999, 4000), (0.98, 7)])
def test_instrumented_offline_equals_the_instrumented_recursion(lam, every):
    Phi, Y = regression(20_000, noise=0.2)
    Zeta = np.roll(Phi, 1, axis=0) + 0.5 * Phi  # instruments correlated with the regressors
    rls = RecursiveLeastSquares(4, forgetting=lam, windup_limit=math.inf)
    path = trajectory(Phi, Y, every, instruments=Zeta, forgetting=lam)
    start = 0
    for j, end in enumerate(path.samples):
        rls.update_block(Phi[start:end], Y[start:end], Zeta[start:end])
        start = end
        assert_relative(path.theta[j], rls.theta)
        assert_relative(path.covariance[j], rls.covariance)
    residuals = Y - Phi @ rls.theta
    weights = lam ** np.arange(len(Y) - 1, -1, -1.0)
    effective = weights.sum()
    assert path.residual_variance[-1] == pytest.approx(weights @ residuals ** 2 / (effective - 4), rel=1e-6)
    accumulator = offline.WeightedAccumulator(4, instrumented=True, forgetting=lam)
    for k in range(0, len(Y), 3000):
        accumulator.add(Phi[k:k + 3000], Y[k:k + 3000], Zeta[k:k + 3000])
    assert_relative(accumulator.estimate().theta, rls.theta)


def test_offline_equals_the_recursion_when_lambda_to_the_n_underflows():
    Phi, Y = regression(200_000, seed=1)
    lam = 0.99
    assert lam ** len(Y) == 0.0
    theta, P, variance, _ = recursion(Phi, Y, lam)
    est = weighted_least_squares(Phi, Y, forgetting=lam)
    assert_relative(est.theta, theta[0])
    assert_relative(est.covariance, P[0])
    assert est.residual_variance == pytest.approx(variance[0], rel=1e-6)


def test_prior_and_memory_time_are_honoured():
    Phi, Y = regression(30, seed=2)
    prior = dict(initial_theta=[1.0, 1.0, 1.0, 1.0], initial_covariance=np.diag([0.1, 1.0, 10.0, 100.0]))
    theta, P, *_ = recursion(Phi, Y, 0.9, **prior)
    est = weighted_least_squares(Phi, Y, memory_time=1.0, sample_period=0.1, **prior)
    assert_relative(est.theta, theta[0])
    assert_relative(est.covariance, P[0])


def test_direct_formula_on_a_short_record():
    Phi, Y = regression(50, seed=3)
    lam, N = 0.95, 50
    w = lam ** np.arange(N - 1, -1, -1.0)
    R = lam ** N * np.eye(4) / 1e6 + Phi.T @ (w[:, None] * Phi)
    theta = np.linalg.solve(R, Phi.T @ (w * Y))
    rss = np.sum(w * (Y - Phi @ theta) ** 2) + lam ** N * theta @ theta / 1e6
    est = weighted_least_squares(Phi, Y, forgetting=lam)
    assert_relative(est.theta, theta)
    assert est.residual_variance == pytest.approx(rss / ((1 - lam ** N) / (1 - lam) - 4), rel=1e-6)


@pytest.mark.parametrize('lam, every', [(1.0, 1000), (0.995, 1000), (0.995, 1), (0.999, 7)])
def test_trajectory_follows_the_recursion(lam, every):
    N = 3001 if every < 10 else 10_007
    Phi, Y = regression(N, seed=4)
    theta, P, variance, std = recursion(Phi, Y, lam, every)
    traj = trajectory(Phi, Y, every, forgetting=lam)
    np.testing.assert_array_equal(traj.samples, list(range(every, N, every)) + [N])
    assert traj.theta.shape == (len(traj.samples), 4)
    tail = slice(5, None)  # the first few estimates rest on the prior, too few samples for a variance
    assert_relative(traj.theta[tail], theta[tail])
    assert_relative(traj.covariance[tail], P[tail], rtol=1e-7)
    np.testing.assert_allclose(traj.std[tail], std[tail], rtol=1e-6)


@pytest.mark.parametrize('lam, every', [(1.0, 250), (0.99, 250), (0.99, 2500)])
def test_small_chunks_give_the_same_answer(monkeypatch, lam, every):
    """Blocks shorter than, and spanning, several chunks."""
    Phi, Y = regression(10_000, seed=5)
    reference = trajectory(Phi, Y, every, forgetting=lam)
    monkeypatch.setattr(offline, '_CHUNK_ROWS', 1000)
    monkeypatch.setattr(offline, '_MAX_BLOCKS', 3)
    chunked = trajectory(Phi, Y, every, forgetting=lam)
    np.testing.assert_array_equal(chunked.samples, reference.samples)
    assert_relative(chunked.theta, reference.theta, rtol=1e-10)
    theta, *_ = recursion(Phi, Y, lam)
    assert_relative(weighted_least_squares(Phi, Y, forgetting=lam).theta, theta[0])


def test_empty_record_gives_the_prior():
    est = weighted_least_squares(np.empty((0, 2)), np.empty(0), initial_theta=[1.0, 2.0])
    np.testing.assert_array_equal(est.theta, [1.0, 2.0])
    assert est.samples == 0 and math.isnan(est.residual_variance)


def test_bad_input_is_rejected():
    Phi, Y = regression(100)
    Y[70] = np.nan
    with pytest.raises(ValueError, match='row 70'):
        weighted_least_squares(Phi, Y)
    with pytest.raises(ValueError):
        weighted_least_squares(Phi, Y[:50])
    with pytest.raises(ValueError):
        weighted_least_squares(Phi[:, 0], Y)
    with pytest.raises(ValueError):
        trajectory(Phi, Y, 0)

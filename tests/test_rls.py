import math

import numpy as np
import pytest

from emla_identification.rls import RecursiveLeastSquares, forgetting_factor

THETA = np.array([1.0, -2.0, 0.5])


def regression(N, noise=0.01, seed=0):
    rng = np.random.default_rng(seed)
    Phi = rng.normal(size=(N, 3))
    return Phi, Phi @ THETA + noise * rng.normal(size=N)


def weighted_solution(Phi, Y, lam, p0=1e6):
    """argmin sum lam^(N-k) (y_k - phi_k theta)^2 + lam^N |theta|^2 / p0, and the inverse Hessian / 2."""
    N, n = Phi.shape
    w = lam ** np.arange(N - 1, -1, -1.0)
    R = lam ** N * np.eye(n) / p0 + Phi.T @ (w[:, None] * Phi)
    return np.linalg.solve(R, Phi.T @ (w * Y)), np.linalg.inv(R)


def test_memory_time_sets_forgetting():
    assert RecursiveLeastSquares(3, memory_time=0.5, sample_period=1e-4).forgetting == 1.0 - 2e-4
    assert forgetting_factor(memory_time=math.inf, sample_period=1e-4) == 1.0
    assert forgetting_factor(0.97) == 0.97


@pytest.mark.parametrize('kwargs', [
    dict(forgetting=0.0), dict(forgetting=1.5), dict(forgetting=math.nan),
    dict(memory_time=0.5), dict(memory_time=1e-4, sample_period=1e-4),
    dict(memory_time=0.5, sample_period=-1.0), dict(memory_time=0.5, sample_period=1e-4, forgetting=0.99),
    dict(initial_covariance=0.0), dict(initial_covariance=-1.0), dict(initial_covariance=math.inf),
    dict(initial_covariance=np.diag([1.0, -1.0, 1.0])), dict(initial_covariance=np.eye(2)),
    dict(initial_theta=[1.0, 2.0]), dict(windup_limit=0.0), dict(windup_limit=math.nan),
])
def test_invalid_settings_are_rejected(kwargs):
    with pytest.raises(ValueError):
        RecursiveLeastSquares(3, **kwargs)


@pytest.mark.parametrize('n', [0, -1, 2.5, True])
def test_invalid_order_is_rejected(n):
    with pytest.raises(ValueError):
        RecursiveLeastSquares(n)


def test_wrong_shapes_are_rejected():
    rls = RecursiveLeastSquares(3)
    with pytest.raises(ValueError):
        rls.update(1.0, 2.0)
    with pytest.raises(ValueError):
        rls.update([1.0, 2.0], 2.0)
    with pytest.raises(ValueError):
        rls.update_block(np.zeros((5, 2)), np.zeros(5))
    with pytest.raises(ValueError):
        rls.update_block(np.zeros((5, 3)), np.zeros(4))


@pytest.mark.parametrize('lam', [1.0, 0.99])
def test_recursion_is_the_weighted_least_squares_solution(lam):
    Phi, Y = regression(500)
    rls = RecursiveLeastSquares(3, forgetting=lam)  # default guard: inactive under excitation
    rls.update_block(Phi, Y)
    theta, P = weighted_solution(Phi, Y, lam)
    np.testing.assert_allclose(rls.theta, theta, rtol=1e-8)
    np.testing.assert_allclose(rls.covariance, P, rtol=1e-8, atol=1e-8 * np.abs(P).max())
    assert rls.samples == 500


def errors_in_variables(N, seed=0, noise=0.5):
    """Regressors seen through noise that the outputs' error shares (as a fed-back measurement does), and
    instruments: the same noisy regressors one sample earlier (smooth AR(1) signals, independent noise)."""
    rng = np.random.default_rng(seed)
    x = np.zeros((N + 1, 3))
    for k in range(1, N + 1):
        x[k] = 0.95 * x[k - 1] + rng.normal(size=3)
    seen = x + noise * rng.normal(size=x.shape)
    Y = x[1:] @ THETA + 0.01 * rng.normal(size=N)
    return seen[1:], Y, seen[:-1]


@pytest.mark.parametrize('lam', [1.0, 0.995])
def test_instrumented_recursion_is_the_weighted_iv_solution(lam):
    Phi, Y, Zeta = errors_in_variables(3000)
    rls = RecursiveLeastSquares(3, forgetting=lam)
    rls.update_block(Phi, Y, Zeta)
    w = lam ** np.arange(len(Y) - 1, -1, -1.0)
    A = lam ** len(Y) * np.eye(3) / 1e6 + Zeta.T @ (w[:, None] * Phi)
    np.testing.assert_allclose(rls.theta, np.linalg.solve(A, Zeta.T @ (w * Y)), rtol=1e-8)
    np.testing.assert_allclose(rls.covariance, np.linalg.inv(A), rtol=1e-7, atol=1e-8 * np.abs(np.linalg.inv(A)).max())


def test_instruments_remove_the_bias_of_noisy_regressors():
    Phi, Y, Zeta = errors_in_variables(200_000, seed=1)
    least_squares, instrumented = RecursiveLeastSquares(3), RecursiveLeastSquares(3)
    least_squares.update_block(Phi, Y)
    instrumented.update_block(Phi, Y, Zeta)
    assert np.abs(least_squares.theta - THETA).max() > 0.01    # attenuated by the regressor noise
    np.testing.assert_allclose(instrumented.theta, THETA, atol=0.003)
    with pytest.raises(ValueError, match='instruments'):
        instrumented.update_block(Phi, Y, Zeta[:, :2])


def test_update_and_update_block_run_the_same_recursion():
    Phi, Y = regression(300)
    one, block = RecursiveLeastSquares(3, forgetting=0.98), RecursiveLeastSquares(3, forgetting=0.98)
    errors = [one.update(phi, y) for phi, y in zip(Phi, Y)]
    np.testing.assert_array_equal(block.update_block(Phi, Y), errors)
    np.testing.assert_array_equal(one.theta, block.theta)
    np.testing.assert_array_equal(one.covariance, block.covariance)
    assert errors[0] == Y[0]  # a-priori error, from theta0 = 0


def test_covariance_stays_symmetric_positive_definite():
    rng = np.random.default_rng(2)
    mixing = np.array([[1.0, 0.0, 0.0], [0.9, 0.1, 0.0], [0.5, 0.4, 0.05]])  # correlated regressors
    Phi = rng.normal(size=(100_000, 3)) @ mixing.T
    Y = Phi @ THETA + 0.01 * rng.normal(size=len(Phi))
    rls = RecursiveLeastSquares(3, forgetting=0.995)
    for k in range(0, len(Y), 1000):
        rls.update_block(Phi[k:k + 1000], Y[k:k + 1000])
        P = rls.covariance
        assert np.abs(P - P.T).max() <= 1e-12 * np.abs(P).max()
        assert np.linalg.eigvalsh(P).min() > 0.0
    np.testing.assert_allclose(rls.theta, THETA, atol=0.05)


def test_parameter_std_is_the_least_squares_std():
    Phi, Y = regression(2000, noise=0.1)
    rls = RecursiveLeastSquares(3)
    rls.update_block(Phi, Y)
    beta, *_ = np.linalg.lstsq(Phi, Y, rcond=None)
    sigma2 = np.sum((Y - Phi @ beta) ** 2) / (2000 - 3)
    assert rls.residual_variance == pytest.approx(sigma2, rel=1e-6)
    np.testing.assert_allclose(rls.parameter_std(), np.sqrt(sigma2 * np.diag(np.linalg.inv(Phi.T @ Phi))),
                               rtol=1e-6)
    np.testing.assert_allclose(rls.parameter_covariance(), rls.residual_variance * rls.covariance)


def test_residual_variance_is_undefined_before_enough_samples():
    rls = RecursiveLeastSquares(3)
    rls.update_block(*regression(3))
    assert math.isnan(rls.residual_variance)


def test_frozen_estimator_predicts_without_adapting():
    Phi, Y = regression(400)
    rls = RecursiveLeastSquares(3, forgetting=0.99)
    rls.update_block(Phi[:200], Y[:200])
    theta, P = rls.theta, rls.covariance
    rls.freeze()
    assert not rls.enabled
    np.testing.assert_allclose(rls.update_block(Phi[200:], Y[200:]), Y[200:] - Phi[200:] @ theta, atol=1e-14)
    assert rls.update(Phi[0], Y[0]) == pytest.approx(Y[0] - Phi[0] @ theta, rel=1e-12)
    np.testing.assert_array_equal(rls.theta, theta)
    np.testing.assert_array_equal(rls.covariance, P)
    assert rls.samples == 200
    rls.enable()
    rls.update_block(Phi[200:], Y[200:] + 1.0)
    assert rls.samples == 400 and not np.allclose(rls.theta, theta)


def test_reset_returns_to_the_prior():
    rls = RecursiveLeastSquares(3, initial_theta=[1.0, 2.0, 3.0], initial_covariance=np.diag([1.0, 2.0, 3.0]))
    rls.update_block(*regression(50))
    rls.reset()
    np.testing.assert_array_equal(rls.theta, [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(rls.covariance, np.diag([1.0, 2.0, 3.0]))
    assert rls.samples == 0 and rls.effective_samples == 0.0


def test_non_finite_samples_are_skipped():
    Phi, Y = regression(100)
    clean = RecursiveLeastSquares(3, forgetting=0.99)
    clean.update_block(Phi, Y)
    Phi_bad, Y_bad = np.insert(Phi, 50, [1.0, np.nan, 0.0], axis=0), np.insert(Y, 50, 1.0)
    Y_bad = np.insert(Y_bad, 10, np.inf)
    Phi_bad = np.insert(Phi_bad, 10, [1.0, 1.0, 1.0], axis=0)
    dirty = RecursiveLeastSquares(3, forgetting=0.99)
    errors = dirty.update_block(Phi_bad, Y_bad)
    assert np.isnan(errors[[10, 51]]).all() and np.isfinite(np.delete(errors, [10, 51])).all()
    np.testing.assert_array_equal(dirty.theta, clean.theta)
    np.testing.assert_array_equal(dirty.covariance, clean.covariance)
    assert dirty.samples == 100


@pytest.mark.parametrize('stretch', ['constant', 'zero'])
def test_windup_guard_keeps_estimates_bounded_without_excitation(stretch):
    """Excitation, 1e5 samples without (constant or zero regressor), excitation again, at lambda = 0.995."""
    rng = np.random.default_rng(3)
    idle = np.tile([1.0, 0.5, -0.3], (100_000, 1)) if stretch == 'constant' else np.zeros((100_000, 3))
    Phi = np.vstack([rng.normal(size=(2000, 3)), idle, rng.normal(size=(2000, 3))])
    Y = Phi @ THETA + 0.01 * rng.normal(size=len(Phi))

    def run(windup_limit):
        rls = RecursiveLeastSquares(3, forgetting=0.995, windup_limit=windup_limit)
        errors, theta_errors, traces = [], [], []
        for k in range(0, len(Y), 500):
            errors.append(np.abs(rls.update_block(Phi[k:k + 500], Y[k:k + 500])).max())
            theta_errors.append(np.abs(rls.theta - THETA).max())
            traces.append(np.trace(rls.covariance))
        return rls, np.array(errors[1:]), np.array(theta_errors), np.array(traces)

    guarded, errors, theta_errors, traces = run(None)
    assert guarded.windup_limit == 3e6
    assert traces.max() <= guarded.windup_limit / 0.995 * (1 + 1e-12)
    assert theta_errors.max() < 0.01
    assert errors.max() < 0.1  # noise std 0.01
    assert theta_errors[-1] < 1e-3

    *_, plain_traces = run(math.inf)
    assert np.nanmax(plain_traces) > 1e6 * guarded.windup_limit  # the unguarded recursion winds up

import numpy as np
import pytest
from scipy.signal import lfilter

from emla_identification.arx import ArxEstimator, ArxModel, arx_regressors, fit_percent, identify_arx, mse
from emla_identification.rls import RecursiveLeastSquares

# A stable 4th-order system, B with three coefficients and one sample of dead time (the DC motor paper's orders)
POLES = np.array([0.9, 0.6, 0.2 + 0.5j, 0.2 - 0.5j])
A = np.poly(POLES).real
B = np.array([1.0, 0.5, -0.3])
NK = 1


def simulate(u, noise=0.0, seed=0):
    """A(q) y = q^-NK B(q) u + e (equation error, so least squares is unbiased)."""
    e = noise * np.random.default_rng(seed).normal(size=len(u))
    return lfilter(np.r_[np.zeros(NK), B], A, u) + lfilter([1.0], A, e)


def paper_input(N=4000, seed=1):
    """As in the DC motor paper: Ts = 5 ms, random steps between 3.5 and 5.5 V, a new level every 2 s (0.5 Hz).

    Mostly steady state around a large mean: a badly conditioned regression (cond(Phi' Phi) ~ 1e9), on which
    the 1e-6 I of the prior is visible at the 1e-5 level."""
    return np.repeat(np.random.default_rng(seed).uniform(3.5, 5.5, N // 400 + 1), 400)[:N]


def white_input(N, seed=0):
    """Zero-mean white input: well-conditioned regressors."""
    return np.random.default_rng(seed).uniform(-1.0, 1.0, N)


def assert_relative(actual, desired, rtol):
    assert np.abs(np.asarray(actual) - desired).max() <= rtol * np.abs(desired).max()


def test_regressor_rows_start_with_a_complete_history():
    u = np.arange(10.0, 16.0)
    y = np.arange(6.0)
    Phi, Y = arx_regressors(u, y, 2, 2, 1)
    np.testing.assert_array_equal(Phi[0], [-1.0, -0.0, 11.0, 10.0])
    np.testing.assert_array_equal(Y, [2.0, 3.0, 4.0, 5.0])
    Phi, Y = arx_regressors(u, y, 2, 2, 3)  # the input history is the longer one
    np.testing.assert_array_equal(Phi, [[-3.0, -2.0, 11.0, 10.0], [-4.0, -3.0, 12.0, 11.0]])
    np.testing.assert_array_equal(Y, [4.0, 5.0])
    Phi, _ = arx_regressors(u, y, 1, 1, 0)  # nk = 0: direct feed-through
    np.testing.assert_array_equal(Phi[0], [-0.0, 11.0])
    Phi, Y = arx_regressors(u[:2], y[:2], 4, 3, 1)
    assert Phi.shape == (0, 7) and Y.shape == (0,)


@pytest.mark.parametrize('orders', [(-1, 2, 1), (0, 0, 1), (2, 2, 1.5), (True, 1, 1)])
def test_invalid_orders_are_rejected(orders):
    with pytest.raises(ValueError):
        arx_regressors(np.zeros(10), np.zeros(10), *orders)


def test_unequal_or_short_records_are_rejected():
    with pytest.raises(ValueError):
        arx_regressors(np.zeros(10), np.zeros(9), 1, 1, 1)
    with pytest.raises(ValueError, match='too short'):
        identify_arx(np.zeros(4), np.zeros(4), 4, 3, 1)


def test_lambda_one_matches_lstsq_on_well_excited_data():
    u = white_input(6000, seed=2)
    y = simulate(u, noise=0.01)
    Phi, Y = arx_regressors(u, y, 4, 3, NK)
    model = identify_arx(u, y, 4, 3, NK)
    assert_relative(model.theta, np.linalg.lstsq(Phi, Y, rcond=None)[0], rtol=1e-6)


def test_lambda_one_is_the_regularised_solution_on_the_papers_data():
    u = paper_input()
    y = simulate(u, noise=0.01)
    Phi, Y = arx_regressors(u, y, 4, 3, NK)
    model = identify_arx(u, y, 4, 3, NK)  # P(0) = 1e6 I: the prior adds 1e-6 I to the information matrix
    assert_relative(model.theta, np.linalg.solve(Phi.T @ Phi + 1e-6 * np.eye(7), Phi.T @ Y), rtol=1e-6)


def test_forgetting_gives_the_exactly_weighted_solution():
    u = paper_input()
    y = simulate(u, noise=0.01)
    Phi, Y = arx_regressors(u, y, 4, 3, NK)
    lam, N = 0.995, len(Y)
    w = lam ** np.arange(N - 1, -1, -1.0)
    theta = np.linalg.solve(lam ** N * 1e-6 * np.eye(7) + Phi.T @ (w[:, None] * Phi), Phi.T @ (w * Y))
    model = identify_arx(u, y, 4, 3, NK, forgetting=lam)
    assert model.forgetting == lam
    assert_relative(model.theta, theta, rtol=1e-6)


def test_known_system_is_recovered_from_noise_free_data():
    u = white_input(3000, seed=3)
    model = identify_arx(u, simulate(u), 4, 3, NK)
    assert model.orders == (4, 3, NK)
    # the only error left is the prior's 1e-6 I against an information matrix whose smallest eigenvalue is ~1
    np.testing.assert_allclose(model.a, A, rtol=1e-5)
    np.testing.assert_allclose(model.b, B, rtol=1e-5)
    np.testing.assert_allclose(np.sort_complex(model.poles), np.sort_complex(POLES), rtol=1e-5)
    np.testing.assert_allclose(np.sort_complex(model.zeros), np.sort_complex(np.roots(B)), rtol=1e-5)
    assert model.fit_percent > 99.999 and model.mse < 1e-12


def test_fit_percent_and_mse_by_hand():
    y, yhat = np.array([1.0, 2.0, 3.0, 4.0]), np.array([1.0, 2.0, 3.0, 5.0])
    assert mse(y, yhat) == 0.25
    assert fit_percent(y, yhat) == pytest.approx(100.0 * (1.0 - 1.0 / np.sqrt(5.0)))  # ||y - mean|| = sqrt(5)
    assert fit_percent(y, y) == 100.0
    assert fit_percent(y, np.full(4, 2.5)) == 0.0


def test_model_predicts_one_step_ahead():
    model = ArxModel.from_theta([-0.5, 2.0], 1, 1, 1)
    u, y = np.array([1.0, 2.0, 3.0]), np.array([0.0, 2.0, 5.0])
    np.testing.assert_array_equal(model.predict(u, y), [0.5 * 0.0 + 2.0 * 1.0, 0.5 * 2.0 + 2.0 * 2.0])
    np.testing.assert_allclose(model.poles, [0.5])
    assert model.zeros.size == 0


def test_online_estimator_in_frames_equals_the_batch_run():
    u = paper_input(2000)
    y = simulate(u, noise=0.01)
    estimator = ArxEstimator(4, 3, NK, forgetting=0.995)
    sizes = [1, 2, 3, 100, 1, 7, 500]
    bounds = np.cumsum([0] + sizes * 10)
    bounds = bounds[bounds < len(u)].tolist() + [len(u)]
    errors = np.concatenate([estimator.update(u[i:j], y[i:j]) for i, j in zip(bounds[:-1], bounds[1:])])
    assert np.isnan(errors[:4]).all()
    model = identify_arx(u, y, 4, 3, NK, forgetting=0.995)
    np.testing.assert_array_equal(estimator.model.theta, model.theta)
    # from the rows' mean and scatter: ill-conditioned rows (see paper_input) cost a few digits of the MSE
    assert estimator.model.fit_percent == pytest.approx(model.fit_percent, rel=1e-9)
    assert estimator.model.mse == pytest.approx(model.mse, rel=1e-7)
    np.testing.assert_array_equal(errors[4:], RecursiveLeastSquares(7, forgetting=0.995).update_block(
        *arx_regressors(u, y, 4, 3, NK)))
    estimator.reset()
    assert np.isnan(estimator.update(u[:3], y[:3])).all() and estimator.rls.samples == 0


def test_online_estimator_after_a_gap_uses_no_row_that_spans_it():
    u = white_input(1000, seed=5)
    y = simulate(u, noise=0.01)
    estimator = ArxEstimator(4, 3, NK)
    estimator.update(u[:600], y[:600])
    estimator.gap()
    errors = estimator.update(u[610:], y[610:])
    assert np.isnan(errors[:4]).all() and np.isfinite(errors[4:]).all()
    rows = [arx_regressors(u[a:b], y[a:b], 4, 3, NK) for a, b in ((0, 600), (610, 1000))]
    Phi, Y = (np.concatenate(parts) for parts in zip(*rows))
    np.testing.assert_array_equal(estimator.model.theta, identify_arx_rows(Phi, Y))
    assert estimator.model.mse == pytest.approx(np.mean((Y - Phi @ estimator.model.theta) ** 2), rel=1e-9)


def identify_arx_rows(Phi, Y):
    rls = RecursiveLeastSquares(Phi.shape[1])
    rls.update_block(Phi, Y)
    return rls.theta


def test_to_dict_has_the_contract_keys():
    u = white_input(500, seed=4)
    out = identify_arx(u, simulate(u, noise=0.01), 4, 3, NK).to_dict()
    assert out['model'] == 'arx' and out['orders'] == [4, 3, NK] and out['forgetting'] == 1.0
    assert len(out['a']) == 5 and out['a'][0] == 1.0 and len(out['b']) == 3
    assert len(out['poles']) == 4 and all(len(p) == 2 for p in out['poles'])
    assert len(out['zeros']) == 2
    assert isinstance(out['fit_percent'], float) and isinstance(out['mse'], float)

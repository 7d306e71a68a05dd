"""WLS of the identification (S2 §V, Gautier & Poignet: each joint's rows weighted by 1/σ̂_j) against a
hand-weighted least squares that knows the true noise of each joint (issue 22): the σ per joint is recovered and
the estimate equals the oracle's; weighting by 1/σ² instead of 1/σ fails."""

import numpy as np

from tendyn.device import load_device
from tendyn.devices import bundled
from tendyn.ident import IDIM


def _problem(seed, sigma, rows_per_joint=10000, b=12):
    """A linear model with rows of three joints, each joint's equation error of standard deviation sigma[j]."""
    rng = np.random.default_rng(seed)
    na = len(sigma)
    W = rng.standard_normal((na * rows_per_joint, b)) * rng.uniform(0.5, 5.0, b)
    rows = np.repeat(np.arange(na), rows_per_joint)
    x_true = rng.uniform(-2.0, 2.0, b)
    Y = W @ x_true + np.asarray(sigma)[rows] * rng.standard_normal(rows.size)
    return W, Y, rows, na, x_true


def test_wls_recovers_the_noise_of_each_joint_and_equals_the_hand_weighted_oracle():
    sigma = np.array([0.1, 0.3, 1.0])             # unequal joint noise [N·m], a factor 10 apart
    W, Y, rows, na, x_true = _problem(7, sigma)
    est = IDIM(load_device(bundled("tx40")), method="wls")
    x, se, weights = est._solve(W, Y, rows, na)   # the solver IDIM.fit runs on the base regressor
    recovered = np.array([1.0 / weights[rows == j][0] for j in range(na)])
    np.testing.assert_allclose(recovered, sigma, rtol=0.05)
    w_true = 1.0 / sigma[rows]                    # the oracle: weights from the true σ_j, numpy's lstsq
    x_oracle = np.linalg.lstsq(W * w_true[:, None], Y * w_true, rcond=None)[0]
    ols = np.linalg.lstsq(W, Y, rcond=None)[0]
    assert np.max(np.abs(x - x_oracle)) < 0.1 * np.max(np.abs(ols - x_oracle))
    # its standard errors are the oracle's: (Wᵀ Σ⁻¹ W)⁻¹ with the true σ
    se_oracle = np.sqrt(np.diag(np.linalg.inv((W * w_true[:, None]).T @ (W * w_true[:, None]))))
    np.testing.assert_allclose(se, se_oracle, rtol=0.1)
    assert np.all(np.abs(x - x_true) < 4 * se)

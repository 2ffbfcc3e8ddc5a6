"""The optimisers (inverse/optim.py): Levenberg-Marquardt, its IRLS robust cost, the
(1+1)-ES and damped Newton recover known minima; projections keep parameters where they
must stay."""
import numpy as np
import pytest
from scipy.optimize import least_squares

from invrad_wb.core.inverse import optim

T = np.linspace(0.0, 3.0, 40)


def _decay(truth):
    """Residual function of y = A exp(-k t) + B for a batch of problems (true params)."""
    Y = truth[:, :1] * np.exp(-truth[:, 1:2] * T) + truth[:, 2:]

    def fun(p, idx, jac):
        e = np.exp(-p[:, 1:2] * T)
        r = p[:, :1] * e + p[:, 2:] - Y[idx]
        if not jac:
            return r
        return r, np.stack([e, -p[:, :1] * T * e, np.ones_like(e)], axis=-1)
    return fun, Y


def test_levenberg_marquardt_recovers_known_minima_in_a_batch():
    truth = np.array([[2.0, 1.3, 0.5], [5.0, 0.2, -1.0], [0.3, 4.0, 2.0]])
    fun, _ = _decay(truth)
    start = np.array([[1.0, 0.5, 0.0], [1.0, 1.0, 0.0], [1.0, 1.0, 0.0]])
    res = optim.levenberg_marquardt(fun, start)
    np.testing.assert_allclose(res.x, truth, rtol=1e-8)
    assert np.all(res.cost < 1e-20)
    assert np.all(res.iterations < 100) and np.all(res.evaluations > res.iterations)


def _line_with_outlier():
    x = np.linspace(0.0, 1.0, 30)
    y = 2.0 * x + 1.0
    y[7] += 5.0                                          # one wild point
    return x, y


def test_irls_steps_minimise_the_soft_l1_cost_and_ignore_an_outlier():
    """Pseudo-Huber weights in the LM step minimise what least_squares(loss='soft_l1')
    minimises; the outlier pulls a plain least-squares line, hardly the robust one."""
    x, y = _line_with_outlier()
    c = 0.1
    A = np.stack([x, np.ones_like(x)], axis=1)

    def fun(p, idx, jac):
        r = (p @ A.T) - y
        return (r, np.broadcast_to(A, (len(p),) + A.shape)) if jac else r

    def huber(r):
        return np.sum(c * c * (np.sqrt(1.0 + (r / c) ** 2) - 1.0), axis=1)

    def irls(J, r, lam):
        return optim.dense_step(J, r, lam, 1.0 / np.sqrt(1.0 + (r / c) ** 2))

    robust = optim.levenberg_marquardt(fun, np.zeros((1, 2)), cost=huber, step=irls)
    plain = optim.levenberg_marquardt(fun, np.zeros((1, 2)))
    ref = least_squares(lambda p: A @ p - y, np.zeros(2), loss="soft_l1", f_scale=c,
                        xtol=1e-15, ftol=1e-15, gtol=1e-15)
    np.testing.assert_allclose(robust.x[0], ref.x, atol=1e-6)
    err_robust = np.abs(robust.x[0] - [2.0, 1.0]).max()
    err_plain = np.abs(plain.x[0] - [2.0, 1.0]).max()
    assert err_robust < 0.02 and err_plain > 5 * err_robust    # the outlier moved the plain fit
    assert huber(fun(robust.x, [0], False))[0] < huber(fun(plain.x, [0], False))[0]


def test_projection_keeps_fixed_parameters_fixed():
    truth = np.array([[2.0, 1.3, 0.5]])
    fun, _ = _decay(truth)
    start = np.array([[1.0, 0.7, 0.5]])

    def pin_k(x_old, x_new, idx):                        # k may not move, B stays >= 0.6
        out = x_new.copy()
        out[:, 1] = x_old[:, 1]
        out[:, 2] = np.maximum(out[:, 2], 0.6)
        return out

    res = optim.levenberg_marquardt(fun, start, project=pin_k)
    assert res.x[0, 1] == 0.7                            # bit for bit
    assert res.x[0, 2] >= 0.6
    free = optim.levenberg_marquardt(fun, start)
    assert res.cost[0] > free.cost[0] and free.cost[0] < 1e-20


def test_stopping_rules():
    fun, _ = _decay(np.array([[2.0, 1.3, 0.5]]))
    start = np.array([[1.0, 0.5, 0.0]])
    few = optim.levenberg_marquardt(fun, start, max_steps=2)
    assert few.iterations[0] >= 2 and few.cost[0] > 1e-6
    capped = optim.levenberg_marquardt(fun, start, max_iter=3)
    assert capped.iterations[0] == 3


def test_evolution_strategy_finds_the_minimum_and_respects_the_region():
    centre = np.array([[1.0, -2.0, 0.5], [3.0, 0.0, -1.0]])

    def cost(x):
        return np.sum((x - centre) ** 2, axis=1) + 0.1 * np.sum(np.abs(x - centre), axis=1)

    res = optim.evolution_strategy(cost, np.zeros((2, 3)), 0.5, rng=4, xtol=1e-8)
    np.testing.assert_allclose(res.x, centre, atol=1e-6)
    assert np.all(res.cost <= cost(centre) + 1e-6)

    def half_space(x):                                   # x0 <= 0.5 allowed only
        return np.where(x[:, :1] <= 0.5, x, np.nan)

    res = optim.evolution_strategy(cost, np.zeros((2, 3)), 0.5, rng=4, xtol=1e-8,
                                   project=half_space)
    assert np.all(res.x[:, 0] <= 0.5)
    # near the border (where half the mutations are refused the step size shrinks early)
    np.testing.assert_allclose(res.x[:, 0], 0.5, atol=0.05)
    np.testing.assert_allclose(res.x[:, 1:], centre[:, 1:], atol=0.1)
    assert cost(res.x)[0] < cost(np.array([[0.5, -1.0, 0.25]]))[0]


def test_evolution_strategy_step_size_follows_the_one_fifth_rule():
    flat = optim.evolution_strategy(lambda x: np.zeros(len(x)), np.zeros((1, 2)), 1.0,
                                    rng=0, max_generations=50, adapt_every=10)
    # every mutation ties (accepted, no success): sigma shrinks 5 times, nothing else
    assert flat.iterations[0] == 50
    steep = optim.evolution_strategy(lambda x: np.sum(x * x, axis=1), np.zeros((1, 2)),
                                     1.0, rng=0, xtol=1e-3)
    assert steep.iterations[0] < 2000 and np.linalg.norm(steep.x) < 1e-2


def test_newton_minimises_rosenbrock_from_several_starts():
    def value(x):
        return (1 - x[:, 0]) ** 2 + 100 * (x[:, 1] - x[:, 0] ** 2) ** 2

    def fun(x):
        a, b = x[:, 0], x[:, 1]
        g = np.stack([-2 * (1 - a) - 400 * a * (b - a * a), 200 * (b - a * a)], axis=1)
        H = np.empty((len(x), 2, 2))
        H[:, 0, 0] = 2 - 400 * (b - 3 * a * a)
        H[:, 0, 1] = H[:, 1, 0] = -400 * a
        H[:, 1, 1] = 200
        return value(x), g, H

    starts = np.array([[-1.2, 1.0], [0.0, 0.0], [2.0, -1.0], [1.0, 1.0]])
    res = optim.newton(fun, starts, value)
    np.testing.assert_allclose(res.x, 1.0, atol=1e-9)
    assert res.iterations[3] == 1 and np.all(res.iterations < 100)


@pytest.mark.parametrize("seed", [0, 1])
def test_as_rng_accepts_seeds_and_generators(seed):
    g = np.random.default_rng(seed)
    assert optim.as_rng(g) is g
    assert optim.as_rng(seed).standard_normal() == np.random.default_rng(seed).standard_normal()


def test_robust_cost_weights_and_row_division_are_the_written_out_numbers():
    """optim.pseudo_huber, pseudo_huber_weights and divide_rows (one scratch array,
    a repeated divisor) give the plain expressions' numbers bit for bit."""
    rng = np.random.default_rng(5)
    r, w, c = rng.standard_normal(1001) * 0.3, rng.uniform(0, 1, 1001), 0.1
    assert optim.pseudo_huber(r, c, w * c * c) == float(
        np.sum(w * c * c * (np.sqrt(1.0 + (r / c) ** 2) - 1.0)))
    ref = w / np.sqrt(1.0 + (r / c) ** 2)
    assert optim.pseudo_huber_weights(r, c, w).tobytes() == ref.tobytes()
    out = np.ones(1200)
    optim.pseudo_huber_weights(r, c, w, out=out[:1001])
    assert out[:1001].tobytes() == ref.tobytes() and np.all(out[1001:] == 1.0)
    d = rng.uniform(0.5, 500.0, 1001)
    for J in (rng.standard_normal((1001, 7)), rng.standard_normal((7, 1001)).T):
        ref = J / d[:, None]
        got = optim.divide_rows(J, d)
        assert got is J and J.tobytes() == ref.tobytes()

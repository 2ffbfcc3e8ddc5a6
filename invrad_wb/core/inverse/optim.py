"""The optimisers of the inverse pipeline: Levenberg-Marquardt, (1+1)-ES, damped Newton.

All three work on a *batch* of ``N`` independent problems at once (``x`` is ``(N, n)``), which is
what the voting table's ellipse fits need (180 angles per level, see
:mod:`invrad_wb.core.inverse.tablefit`); the refinement of luminaire positions
(:mod:`invrad_wb.core.inverse.refine`) is a batch of one.

Why hand-written and not ``scipy.optimize.least_squares`` (measured on this 2-core machine,
numpy 1.26, scipy 1.10.1; the figures are in the commit that introduced this module):

* Ellipse fits of the table (thesis eq. 3.30, 180 problems of 5 parameters per level):
  ``least_squares(method="lm")`` problem by problem took 5-8x the batched LM below (583 vs
  76 ms at q = 0.5, 636 vs 129 ms at q = 0.01, same parameters to 3e-10); one block-sparse
  ``least_squares(method="trf", tr_solver="lsmr")`` call per level took 2-4x (one trust
  region for all problems: 74 evaluations where each problem alone needs 8-26) and agreed
  only to 3e-8.
* Refinement of luminaire positions: ``least_squares(method="trf", loss=<soft_l1 with the
  per-point area weights>, f_scale=robust_scale)`` minimises exactly the refinement's
  pseudo-Huber cost (the separation term as quadratic rows, the log-flux limits as bounds).
  It does not fit the rest: a luminaire's allowed region is a pixel mask of its faces (or
  the room's footprint), not a box, so it can only be checked after the fit (309 of 776
  fits ended with a luminaire outside and had to be reverted), and visibility is refreshed
  between steps, not inside every evaluation. Locating the scenarios' 12 scenes at rho 0.6
  (three with free fluxes), both optimisers in one process: least_squares took 170.4 s
  against the LM's 86.9 s when run first, 469.8 s against 284.4 s when run second (a scene's
  second run is faster); at rho 0 the order decides (fewer residual evaluations with one
  flux, two_ceiling 84 against 150, about as many Jacobians; with free fluxes up to 4x the
  Jacobians, wall_and_ceiling 1351 against 347). It gave one wrong answer in both orders
  (two_rooms_two_fluxes rho 0.6: 2 of 4 luminaires and a spurious one; LM 4 of 4), and
  two_ceiling rho 0 0.13 cm off (LM 0.07 cm). The LM below keeps the refinement's results.
* The maximum of the per-lumen distribution by Newton's method (:func:`newton`): scipy's
  ``minimize`` with the analytic gradient and Hessian missed the closed-form maximum by
  more than 1e-9 (relative) at 36 (``trust-exact``, up to 3e-5), 37 (``trust-ncg``) and 103
  (``Newton-CG``) of the 180 table angles, ``gtol`` down to 1e-20: near the optimum the
  function's values no longer resolve progress and its steps are refused. :func:`newton`
  takes a full undamped step that changes the value by no more than rounding and stops on
  the step length: 1e-9 at every angle (:func:`invrad_wb.core.inverse.tablefit.maximum_newton`).

Array conventions: ``x`` (N, n) float64; residuals ``r`` (N, m); Jacobians ``J`` (N, m, n).
"""
from collections import namedtuple

import numpy as np

#: (1+1)-ES step-size rule (Rechenberg's 1/5 success rule, thesis 3.1.2.2): the factor
#: applied to sigma and the success rate it aims at
ES_FACTOR = 0.85
ES_SUCCESS = 0.2

Result = namedtuple("Result", "x cost iterations evaluations")
Result.__doc__ = """What an optimiser returns, per problem of the batch.

x : (N, n) float64. The best parameters found.
cost : (N,) float64. The cost there.
iterations : (N,) int. LM trial steps, or ES generations.
evaluations : (N,) int. Residual (LM) or cost (ES) evaluations.
"""


def sum_of_squares(r):
    """Plain least-squares cost ``sum_i r_i^2`` of residuals ``r`` (N, m) -> (N,)."""
    return np.einsum("nk,nk->n", r, r)


def pseudo_huber(r, c, wcc):
    """``sum(wcc (sqrt(1 + (r / c)^2) - 1))`` (``wcc``: the weights times c^2), the robust
    cost: the written-out expression's operations on the same numbers, in one scratch
    array (a fifth of the temporaries; called at every optimiser trial)."""
    t = np.divide(r, c)
    if t.shape != np.shape(wcc):          # a residual broadcast over the points
        return float(np.sum(wcc * (np.sqrt(1.0 + t ** 2) - 1.0)))
    np.square(t, out=t)
    np.add(t, 1.0, out=t)
    np.sqrt(t, out=t)
    np.subtract(t, 1.0, out=t)
    return float(np.sum(np.multiply(wcc, t, out=t)))


def pseudo_huber_weights(r, c, w, out=None):
    """The IRLS weights of :func:`pseudo_huber`, ``w / sqrt(1 + (r / c)^2)``, in one
    array (``out``, else a new one): the written-out expression's numbers."""
    t = np.divide(r, c, out=out)
    np.square(t, out=t)
    np.add(t, 1.0, out=t)
    np.sqrt(t, out=t)
    return np.divide(w, t, out=t)


def divide_rows(J, d):
    """``J (k, n) / d[:, None]`` in place: where ``J`` is one block of memory, by ``d``
    repeated along each row (the same quotients; a broadcast over rows of a few columns
    is a loop of that few per row, twice as slow)."""
    if not J.flags.c_contiguous:
        return np.divide(J, d[:, None], out=J)
    flat = J.reshape(-1)
    np.divide(flat, np.repeat(d, J.shape[1]), out=flat)
    return J


def _solve(M, g):
    """``M^-1 g`` per problem ``(N, n, n), (N, n)``; ``ok`` False where ``M`` is singular."""
    try:
        return np.linalg.solve(M, g[..., None])[..., 0], np.ones(len(g), bool)
    except np.linalg.LinAlgError:
        out, ok = np.zeros_like(g), np.ones(len(g), bool)
        for i in range(len(g)):
            try:
                out[i] = np.linalg.solve(M[i], g[i])
            except np.linalg.LinAlgError:
                ok[i] = False
        return out, ok


def dense_step(J, r, lam, w=None, ridge=1e-15):
    """Marquardt step ``-(A + lam diag(A) + ridge I)^-1 J^T W r`` with ``A = J^T W J``.

    J : (N, m, n); r : (N, m); lam : (N,); w : (N, m) weights or None (1).
    Returns ``step (N, n)`` and ``ok (N,)`` (False where the system is singular).
    """
    JtW = np.swapaxes(J, 1, 2) if w is None else np.swapaxes(J * w[..., None], 1, 2)
    A = JtW @ J
    n = A.shape[-1]
    D = np.maximum(np.einsum("nii->ni", A), 1e-12) * lam[:, None]
    # the damping added to the diagonal in place (the same sums as A + D I + ridge I; a
    # zero ridge adds nothing: x + 0.0 is x)
    diag = np.einsum("nii->ni", A)
    diag += D
    if ridge:
        diag += ridge
    step, ok = _solve(A, np.einsum("nik,nk->ni", JtW, r))
    return -step, ok


def _take(J, idx):
    return tuple(j[idx] for j in J) if isinstance(J, tuple) else J[idx]


def _put(J, idx, new):
    for j, v in zip(J, new) if isinstance(J, tuple) else ((J, new),):
        j[idx] = v


def levenberg_marquardt(fun, x0, cost=sum_of_squares, step=dense_step, project=None,
                        max_iter=200, max_steps=None, max_tries=None, ftol=1e-14, xtol=1e-14,
                        lam0=1e-3, lam_up=4.0, lam_down=3.0, lam_min=1e-12, lam_max=1e12):
    """Levenberg-Marquardt with Marquardt's ``diag(J^T J)`` damping, a batch of problems.

    Each problem keeps its own damping ``lam``. A trial step (:func:`dense_step` or the
    caller's ``step``) is taken if it lowers the problem's cost strictly (``lam /=
    lam_down``, floored at ``lam_min``); otherwise ``lam *= lam_up``. A problem stops when a
    taken step gains less than ``ftol * max(cost, 1e-12)`` or is shorter than ``xtol``,
    after ``max_steps`` taken steps, ``max_tries`` failed trials in a row, when ``lam >
    lam_max``, or after ``max_iter`` trials (None: no such limit).

    Parameters
    ----------
    fun : callable(x (M, n), idx (M,) int, jac: bool) -> r (M, m) or (r, J)
        Residuals (and Jacobian, ``(M, m, n)`` or any tuple of arrays indexed by problem
        that ``step`` understands) of problems ``idx`` at ``x``. Called with ``jac=True``
        at the start and after every taken step (where a caller may refresh state, e.g.
        visibility), with ``jac=False`` at trial points.
    x0 : (N, n) array
    cost : callable(r (M, m)) -> (M,), the cost minimised (default: sum of squares)
    step : callable(J, r, lam (M,)) -> (step (M, n), ok (M,) bool)
        E.g. :func:`dense_step` with IRLS weights, which makes a robust cost descend with
        Gauss-Newton steps.
    project : callable(x_old (M, n), x_new (M, n), idx) -> (M, n), optional
        Moves a trial point into the allowed region.

    Returns
    -------
    Result
    """
    x = np.array(x0, dtype=np.float64)
    N = len(x)
    r, J = fun(x, np.arange(N), True)
    r = np.array(r, dtype=np.float64)      # updated in place: own copies
    J = tuple(np.array(j) for j in J) if isinstance(J, tuple) else np.array(J)
    c = cost(r)
    lam = np.full(N, float(lam0))
    it, nev, steps, fails = (np.zeros(N, dtype=np.int64) for _ in range(4))
    nev += 1
    active = np.ones(N, dtype=bool)
    every = np.arange(N)
    while active.any():
        ix = np.flatnonzero(active)
        if len(ix) == N:
            # every problem active (always so for a batch of one): views, not copies
            ix, Jx, rx, xx, lx = every, J, r, x, lam
        else:
            Jx, rx, xx, lx = _take(J, ix), r[ix], x[ix], lam[ix]
        dx, solved = step(Jx, rx, lx)
        xn = xx + dx
        if project is not None:
            xn = project(xx, xn, ix)
        with np.errstate(all="ignore"):
            cn = cost(fun(xn, ix, False))
        it[ix] += 1
        nev[ix] += 1
        ok = solved & np.isfinite(cn) & (cn < c[ix])
        acc = ix[ok]
        if len(acc):
            gain = c[acc] - cn[ok]
            x[acc] = xn[ok]
            r_acc, J_acc = fun(x[acc], acc, True)
            r[acc] = r_acc
            _put(J, acc, J_acc)
            c[acc] = cost(r_acc)
            nev[acc] += 1
            steps[acc] += 1
            done = (gain < ftol * np.maximum(c[acc], 1e-12)) \
                | (np.linalg.norm(dx[ok], axis=1) < xtol)
            if max_steps is not None:
                done |= steps[acc] >= max_steps
            active[acc[done]] = False
        lam[ix] = np.where(ok, np.maximum(lam[ix] / lam_down, lam_min), lam[ix] * lam_up)
        fails[ix] = np.where(ok, 0, fails[ix] + 1)
        stop = (lam[ix] > lam_max) | (False if max_iter is None else it[ix] >= max_iter) \
            | (False if max_tries is None else fails[ix] >= max_tries)
        active[ix[stop]] = False
    return Result(x, c, it, nev)


def newton(fun, x0, value, tol=1e-13, max_iter=100, step_cap=1.0):
    """Minimise by Newton's method with Levenberg-Marquardt damping and a line search, batched.

    Where the Hessian ``H`` is not positive definite a multiple of the identity is added
    (thesis eq. 3.10: ``-lambda_min + 1e-3 (|lambda_min| + |lambda_max|)``); the step is
    limited to ``step_cap (1 + |x|)`` and halved until the Armijo condition holds. A full,
    undamped Newton step that raises the value by no more than rounding is taken: near the
    optimum values stop resolving progress, the gradient still does.

    Parameters
    ----------
    fun : callable(x (N, n)) -> (f (N,), g (N, n), H (N, n, n)): value, gradient, Hessian
    x0 : (N, n) array
    value : callable(x (N, n)) -> f (N,)
    tol : float
        Stop a problem when its step is below ``tol (1 + |x|)``.
    max_iter : int
    step_cap : float

    Returns
    -------
    Result (``cost`` = the value at ``x``)
    """
    x = np.array(x0, dtype=np.float64)
    N, n = x.shape
    it = np.zeros(N, dtype=np.int64)
    nev = np.zeros(N, dtype=np.int64)
    active = np.ones(N, dtype=bool)
    for _ in range(max_iter):
        if not active.any():
            break
        f, g, H = fun(x)
        nev += active
        ev = np.linalg.eigvalsh(H)
        lo = ev[:, 0]
        scale = np.abs(lo) + np.abs(ev[:, -1]) + 1e-300
        lam = np.where(lo > 1e-8 * scale, 0.0, -lo + 1e-3 * scale)
        p = -np.linalg.solve(H + lam[:, None, None] * np.eye(n), g[..., None])[..., 0]
        plen = np.linalg.norm(p, axis=1)
        cap = step_cap * (1.0 + np.linalg.norm(x, axis=1))
        shrink = np.where(plen > cap, cap / np.maximum(plen, 1e-300), 1.0)
        p *= shrink[:, None]
        slope = np.einsum("ni,ni->n", g, p)  # < 0: descent direction
        pure = (lam == 0.0) & (shrink == 1.0)
        step = np.ones(N)
        for _ls in range(60):
            fn = value(x + step[:, None] * p)
            nev += active
            ok = (fn <= f + 1e-4 * step * slope) | (pure & (step == 1.0)
                                                     & (fn <= f + 1e-14 * np.abs(f)))
            if np.all(ok | ~active):
                break
            step = np.where(ok, step, 0.5 * step)
        dx = step[:, None] * p
        x = np.where(active[:, None], x + dx, x)
        it += active
        active &= np.linalg.norm(dx, axis=1) > tol * (1.0 + np.linalg.norm(x, axis=1))
    return Result(x, value(x), it, nev)


def as_rng(rng):
    """A numpy Generator from None, an int seed or a Generator."""
    if rng is None or isinstance(rng, (int, np.integer)):
        return np.random.default_rng(rng)
    return rng


def evolution_strategy(cost, x0, sigma0, rng=None, max_generations=20000, adapt_every=10,
                       xtol=1e-9, relative=False, project=None, refresh=None):
    """(1+1) evolution strategy with the 1/5 success rule (thesis 3.1.2.2), a batch.

    Each generation a descendant ``x + sigma N(0, I)`` replaces the parent when its cost is
    not higher (a tie is accepted but is no success). Every ``adapt_every`` generations
    ``sigma`` is multiplied by :data:`ES_FACTOR` when fewer than :data:`ES_SUCCESS` of the
    mutations succeeded and divided by it otherwise; a problem stops when
    ``sigma < xtol`` (``< xtol (1 + |x|)`` if ``relative``) or after ``max_generations``.

    Parameters
    ----------
    cost : callable(x (N, n)) -> (N,); non-finite = not allowed (never accepted)
    x0 : (N, n) array
    sigma0 : float or (N,) array. Initial step size, in the units of ``x``.
    rng : numpy.random.Generator or int seed, optional
    project : callable(x (N, n)) -> (N, n), optional
        Moves descendants into the allowed region (a row of NaN where impossible).
    refresh : callable(x (N, n)) -> (N,), optional
        The parents' cost again, called at each adaptation (e.g. after refreshing a
        visibility the cost depends on).

    Returns
    -------
    Result (``iterations`` = generations; ``evaluations`` = generations + 1)
    """
    rng = as_rng(rng)
    x = np.array(x0, dtype=np.float64)
    N = len(x)
    c = np.asarray(cost(x), dtype=np.float64)
    sigma = np.broadcast_to(np.asarray(sigma0, np.float64), (N,)).copy()
    succ = np.zeros(N, dtype=np.int64)
    gen = np.zeros(N, dtype=np.int64)
    active = np.ones(N, dtype=bool)
    for i in range(1, max_generations + 1):
        xn = x + sigma[:, None] * rng.standard_normal(x.shape)
        if project is not None:
            xn = project(xn)
        with np.errstate(all="ignore"):
            cn = np.asarray(cost(xn), dtype=np.float64)
        keep = active & np.isfinite(cn) & (cn <= c)
        succ += keep & (cn < c)
        x[keep], c[keep] = xn[keep], cn[keep]
        gen += active
        if i % adapt_every == 0:
            rate = succ / adapt_every
            sigma = np.where(active, np.where(rate < ES_SUCCESS, sigma * ES_FACTOR,
                                              sigma / ES_FACTOR), sigma)
            succ[:] = 0
            scale = 1.0 + np.linalg.norm(x, axis=1) if relative else 1.0
            active &= sigma >= xtol * scale
            if not active.any():
                break
            if refresh is not None:
                c = np.where(active, refresh(x), c)
    return Result(x, c, gen, gen + 1)

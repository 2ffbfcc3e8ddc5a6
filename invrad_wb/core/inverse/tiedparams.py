"""Parameters shared in a joint fit: luminaires of one kind with one flux.

A fit of K luminaires has their parameters in :meth:`~invrad_wb.core.inverse.refine.
RefineProblem._packing`'s order (each luminaire's position, its aim, its log flux last).
Luminaires of one :attr:`~invrad_wb.core.inverse.refine.Light.flux_group` share their log
flux: the fit's parameters are then x = T y, and a Levenberg-Marquardt step solves for y
(J T in place of J, T^T A T in place of the normal matrix A). Which luminaires share a
flux: :mod:`invrad_wb.core.inverse.locate_ties`.
"""
import numpy as np


def flux_ties(lights):
    """The (n, m) 0/1 matrix T of a joint fit of ``lights``' parameters (n, in
    :meth:`RefineProblem._packing`'s order) with tied fluxes: x = T y, y the m free
    parameters; every parameter its own column except the log fluxes of luminaires of one
    :attr:`Light.flux_group`, which share one. None when no two luminaires share a flux."""
    groups = [L.flux_group for L in lights if L.free_flux and L.flux_group >= 0]
    if len(groups) == len(set(groups)):
        return None
    col_of, group_col, n_cols = [], {}, 0
    for L in lights:
        m = L.n_params()
        tied = L.free_flux and L.flux_group >= 0
        col_of.extend(range(n_cols, n_cols + m - tied))
        n_cols += m - tied
        if tied:
            if L.flux_group not in group_col:
                group_col[L.flux_group] = n_cols
                n_cols += 1
            col_of.append(group_col[L.flux_group])
    T = np.zeros((len(col_of), n_cols))
    T[np.arange(len(col_of)), col_of] = 1.0
    return T


def tied_start(x0, T):
    """``x0`` with each tied group's log fluxes at their mean (T: :func:`flux_ties`)."""
    return T @ ((T.T @ x0) / T.sum(axis=0))


def tied_projection(project, T):
    """An optimiser's ``project(x_old, x_new, idx)`` that keeps the ties of ``T``: a
    luminaire that keeps its old place there keeps its group's new flux."""
    shared = np.flatnonzero(T[:, T.sum(axis=0) > 1].sum(axis=1))

    def tied(x_old, x_new, idx):
        out = project(x_old, x_new, idx)
        out[:, shared] = x_new[:, shared]
        return out
    return tied


def tied_fit(lights, x0, step, project, normal=False):
    """(x0, step, project) of a Levenberg-Marquardt fit of ``lights`` (its start, trial
    step and projection, :func:`invrad_wb.core.inverse.optim.levenberg_marquardt`'s)
    with their shared fluxes (:func:`flux_ties`): the start's groups at their mean, the
    step solved for the tied parameters y (``step`` given J T for J, or with ``normal``
    (T^T A T, T^T g) for the normal equations (A, g)) and mapped back, x = T y. As they
    are where no two luminaires share a flux."""
    T = flux_ties(lights)
    if T is None:
        return x0, step, project

    def tied_step(J, r, lam):
        if normal:
            A, g = J
            dy, ok = step((T.T @ A @ T, g @ T), r, lam)
        else:
            dy, ok = step(J @ T, r, lam)
        return dy @ T.T, ok
    return (tied_start(x0, T), tied_step,
            None if project is None else tied_projection(project, T))

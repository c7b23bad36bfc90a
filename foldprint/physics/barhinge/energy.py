"""The bar-and-hinge model's energy, its gradient and its Hessian (analytic, vectorised).

Two element kinds (Liu and Paulino 2017, Proc. R. Soc. A 473: 20170348; ``docs/mechanics.md``):

* **bars** a-b, rest length L, axial stiffness k = EA / L:  U = k (l - L)^2 / 2,
  l = |x_b - x_a|; gradient k (l - L) u on b (u the unit vector a -> b), Hessian block
  k u u^T + k (l - L) / l (I - u u^T).
* **rotational springs** on the edge j-k between the triangles (i, j, k) and (j, k, l):
  U = c (rho - rho0)^2 / 2 with rho the fold angle, 0 flat, signed as in FOLD (+ valley).
  With r_ij = x_i - x_j, r_kj = x_k - x_j, r_kl = x_k - x_l, m = r_ij x r_kj and
  n = r_kj x r_kl, Liu and Paulino's dihedral angle theta (pi when flat) has

      d theta / d x_i = |r_kj| / |m|^2 m,      d theta / d x_l = -|r_kj| / |n|^2 n,
      d theta / d x_j = (A - 1) d theta / d x_i - B d theta / d x_l,
      d theta / d x_k = (B - 1) d theta / d x_l - A d theta / d x_i,

  A = r_ij . r_kj / |r_kj|^2, B = r_kl . r_kj / |r_kj|^2, and the closed-form second
  derivatives of their Eq. (33)-(36) (:func:`dihedral`). Here rho = pi - theta, taken as
  atan2(|r_kj| (m . r_kl), -(m . n)), so it is continuous through the flat state and
  defined on (-pi, pi]; the model builder orders j and k so that + is a valley. The
  spring's stretch rho - rho0 is taken modulo 2 pi (:func:`stretch`, in (-pi, pi]): atan2's
  cut at +-pi is then not a cliff beside a rest angle of 180 deg (a flap folded flat).

Everything is assembled into one ``scipy.sparse`` matrix per call (COO, duplicates summed).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


def _outer(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return u[:, :, None] * v[:, None, :]


def _dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", u, v)


def fold_angles(x: np.ndarray, ijkl: np.ndarray) -> np.ndarray:
    """Fold angle rho (s,) of each spring (s, 4) at node positions ``x`` (n, 3)."""
    xi, xj, xk, xl = (x[ijkl[:, c]] for c in range(4))
    rij, rkj, rkl = xi - xj, xk - xj, xk - xl
    m, n = np.cross(rij, rkj), np.cross(rkj, rkl)
    return np.arctan2(np.linalg.norm(rkj, axis=1) * _dot(m, rkl), -_dot(m, n))


def stretch(rho: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """rho - rest modulo 2 pi, in (-pi, pi]: the spring's departure from its rest angle.
    Without the modulus a crease whose rest angle is 180 deg minus a hair sits a hair from
    atan2's cut at +-pi, where rho jumps by 2 pi and the energy by 2 pi^2 c: every Newton
    step that turns the crease by more than the hair is refused by the line search
    (docs/mechanics.md, "Flat folds")."""
    d = np.asarray(rho, float) - np.asarray(rest, float)
    return d - 2 * np.pi * np.round(d / (2 * np.pi))


def dihedral(x: np.ndarray, ijkl: np.ndarray, hessian: bool = True):
    """rho (s,), its gradient (s, 12) over (x_i, x_j, x_k, x_l) and, with ``hessian``,
    its Hessian (s, 12, 12)."""
    xi, xj, xk, xl = (x[ijkl[:, c]] for c in range(4))
    rij, e, rkl = xi - xj, xk - xj, xk - xl
    m, n = np.cross(rij, e), np.cross(e, rkl)
    m2, n2, e2 = _dot(m, m), _dot(n, n), _dot(e, e)
    el = np.sqrt(e2)
    rho = np.arctan2(el * _dot(m, rkl), -_dot(m, n))
    gi = (el / m2)[:, None] * m
    gl = -(el / n2)[:, None] * n
    A, B = _dot(rij, e) / e2, _dot(rkl, e) / e2
    gj = (A - 1)[:, None] * gi - B[:, None] * gl
    gk = (B - 1)[:, None] * gl - A[:, None] * gi
    grad = -np.concatenate([gi, gj, gk, gl], axis=1)  # rho = pi - theta
    if not hessian:
        return rho, grad, None
    s = len(rho)
    cm, cn = (el / m2**2)[:, None, None], (el / n2**2)[:, None, None]
    em, en = np.cross(e, m), np.cross(e, n)
    sym = lambda a, b: _outer(a, b) + _outer(b, a)  # noqa: E731
    em_m = _outer(e, m) / (m2 * el)[:, None, None]
    en_n = _outer(e, n) / (n2 * el)[:, None, None]
    Hii = -cm * sym(m, em)
    Hll = cn * sym(n, en)
    Hik = em_m + cm * sym(np.cross(rij, m), m)
    Hlj = en_n - cn * sym(np.cross(rkl, n), n)
    Hij = -em_m + cm * sym(np.cross(e - rij, m), m)
    Hlk = -en_n - cn * sym(np.cross(e - rkl, n), n)
    dAj = ((2 * A - 1)[:, None] * e - rij) / e2[:, None]
    dBj = ((2 * B)[:, None] * e - rkl) / e2[:, None]
    dAk = (-(2 * A)[:, None] * e + rij) / e2[:, None]
    dBk = ((1 - 2 * B)[:, None] * e + rkl) / e2[:, None]
    a1, b1 = (A - 1)[:, None, None], B[:, None, None]
    Hjj = _outer(dAj, gi) - _outer(dBj, gl) + a1 * Hij - b1 * Hlj
    Hjk = _outer(dAk, gi) - _outer(dBk, gl) + a1 * Hik - b1 * Hlk
    Hkk = _outer(dBk, gl) - _outer(dAk, gi) + (B - 1)[:, None, None] * Hlk - A[:, None, None] * Hik
    T = lambda a: a.transpose(0, 2, 1)  # noqa: E731
    z = np.zeros((s, 3, 3))
    rows = [[Hii, T(Hij), T(Hik), z],
            [Hij, Hjj, T(Hjk), Hlj],
            [Hik, Hjk, Hkk, Hlk],
            [z, T(Hlj), T(Hlk), Hll]]
    H = -np.concatenate([np.concatenate(r, axis=2) for r in rows], axis=1)
    return rho, grad, H


def _dofs(nodes: np.ndarray) -> np.ndarray:
    """(e, 3 c) global dof indices of element node lists (e, c)."""
    return (3 * nodes[:, :, None] + np.arange(3)[None, None, :]).reshape(len(nodes), -1)


def _scatter(n_dof: int, dofs: np.ndarray, g_loc: np.ndarray, H_loc: np.ndarray | None):
    g = np.bincount(dofs.ravel(), weights=g_loc.ravel(), minlength=n_dof)
    if H_loc is None:
        return g, None
    w = dofs.shape[1]
    r = np.repeat(dofs, w, axis=1).ravel()
    c = np.tile(dofs, (1, w)).ravel()
    return g, (r, c, H_loc.ravel())


def bar_terms(x: np.ndarray, bars: np.ndarray, rest: np.ndarray, k: np.ndarray, hessian: bool = True):
    """Energy, gradient (3n,) and the Hessian's COO triplets of the bars."""
    d = x[bars[:, 1]] - x[bars[:, 0]]
    ln = np.linalg.norm(d, axis=1)
    u = d / ln[:, None]
    f = k * (ln - rest)
    energy = 0.5 * float(np.dot(f, ln - rest))
    g_loc = np.concatenate([-f[:, None] * u, f[:, None] * u], axis=1)
    H_loc = None
    if hessian:
        uu = _outer(u, u)
        K = k[:, None, None] * uu + (f / ln)[:, None, None] * (np.eye(3)[None] - uu)
        H_loc = np.concatenate([np.concatenate([K, -K], axis=2), np.concatenate([-K, K], axis=2)], axis=1)
    g, trip = _scatter(3 * len(x), _dofs(bars), g_loc, H_loc)
    return energy, g, trip


def spring_terms(x: np.ndarray, ijkl: np.ndarray, rest: np.ndarray, k: np.ndarray, hessian: bool = True):
    """Energy, gradient (3n,) and the Hessian's COO triplets of the rotational springs."""
    rho, grad, H = dihedral(x, ijkl, hessian)
    dev = stretch(rho, rest)
    m = k * dev
    energy = 0.5 * float(np.dot(m, dev))
    H_loc = None
    if hessian:
        H_loc = k[:, None, None] * _outer(grad, grad) + m[:, None, None] * H
    g, trip = _scatter(3 * len(x), _dofs(ijkl), m[:, None] * grad, H_loc)
    return energy, g, trip


def total(x: np.ndarray, bars, bar_rest, bar_k, springs, spring_rest, spring_k, hessian: bool = True):
    """U(x), its gradient (3n,) and (with ``hessian``) its Hessian as a CSR matrix."""
    eb, gb, tb = bar_terms(x, bars, bar_rest, bar_k, hessian)
    es, gs, ts = spring_terms(x, springs, spring_rest, spring_k, hessian)
    if not hessian:
        return eb + es, gb + gs, None
    n = 3 * len(x)
    H = sp.coo_matrix((np.concatenate([tb[2], ts[2]]), (np.concatenate([tb[0], ts[0]]),
                                                        np.concatenate([tb[1], ts[1]]))), shape=(n, n)).tocsr()
    return eb + es, gb + gs, H

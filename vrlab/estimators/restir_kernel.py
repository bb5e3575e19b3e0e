"""Compiled reservoir streaming and ReSTIR's reuse weights (Numba): the estimator logic of
:mod:`vrlab.estimators.ris` and :mod:`vrlab.estimators.restir` run when a render's kernels
are ``"numba"`` (:mod:`vrlab.kernels`, vrlab issue 31).  The NumPy code of those modules is
the oracle; these loops do the same floating-point operations in the same order, so they
give the same selections and weights (the tests compare them).

``stream`` — weighted reservoir sampling (Chao 1982; ``Reservoir._stream``): per row r,
candidate j with weight w_j and uniform u_j replaces the kept sample where
``u_j (w_sum + w_1 + ... + w_j) < w_j``, the running sum added left to right as
``np.cumsum`` does; the last accepted candidate is kept (none accepted: the old sample).

``combine`` — one round of spatial reuse at the receiving pixel c (``ReSTIR._reuse`` and
``_mis_weights``; Lin et al. 2022, generalized RIS), given per contributor s = 0..S-1
(s = 0 the canonical sample) its visibility-aware target at its own pixel ``q_s``, the
shift's Jacobian ``J_s``, the target at c ``q_c(y_s)``, its UCW ``W_s`` and count ``M_s``
(0 for a missing neighbour):

    p̂_{<-s}(y_s) = q_s / J_s,   w_s = m_s(y_s) q_c(y_s) W_s J_s,
    pick s with u sum w in [cum_{s-1}, cum_s)  (the first s with cum_s > u sum w; at most S - 1)

with the MIS weights m_s of ``mode``: 0 ``"1/M"`` (M_s / sum M), 1 ``"pairwise"`` (Bitterli
2022; ``back[t-1]`` = p̂_{<-t}(y_0), neighbour t's target read at the canonical sample:
m_s = (M_s / C) p̂_{<-s} / (p̂_{<-s} + a q_c(y_s)) for s > 0, m_0 = sum_t (M_t / C) a q_c(y_0)
/ (p̂_{<-t}(y_0) + a q_c(y_0)), a = M_0 / C, C = sum_{t>0} M_t; m_0 = 1 where C = 0), 2
``"balance"`` (``P[s, t]`` = p̂_{<-t}(y_s), column 0 q_c: m_s = M_s P[s, s] / sum_t M_t P[s, t]).
Divisions are ``ratio``'s: 0 where the denominator is not > 0.  Sums over contributors use
NumPy's pairwise order (``_sum``), so that ``np.sum`` and these loops round alike.
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["stream", "combine", "SIGNATURES", "COMPILE_SECONDS", "MODES"]

#: the reuse modes of ``combine`` (ReSTIR's ``mis`` names, in code order)
MODES = ("1/M", "pairwise", "balance")

#: the signatures vrlab.kernels.load_kernels compiles
SIGNATURES = {
    "stream": ["void(float64[:, :, ::1], float64[:, ::1], float64[:, ::1], float64[:, ::1], "
               "float64[:, ::1], float64[::1], float64[::1])"],
    "combine": ["void(int64, float64[:, ::1], float64[:, ::1], float64[:, ::1], float64[:, ::1], "
                "float64[:, :, ::1], float64[:, ::1], float64[:, ::1], float64[::1], int64[::1], float64[::1])"],
}
#: cold compile time (seconds, measured on the development machine), for the notice
COMPILE_SECONDS = 2.0


@njit(cache=True, error_model="numpy")
def _ratio(a, b):
    """``a / b``, 0 where b is not > 0 (``vrlab.estimators.base.ratio``)."""
    return a / b if b > 0.0 else 0.0


@njit(cache=True, error_model="numpy")
def _sum(a, n):
    """``a[0] + ... + a[n-1]`` in NumPy's pairwise order (its float64 ``add.reduce`` over a
    contiguous axis): below 8 terms left to right from 0.0; up to 128 (ReSTIR has at most
    65 contributors), eight running sums combined as ((r0 + r1) + (r2 + r3)) + ((r4 + r5) +
    (r6 + r7)), then the remainder."""
    if n < 8:
        s = 0.0
        for i in range(n):
            s += a[i]
        return s
    r0, r1, r2, r3, r4, r5, r6, r7 = a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7]
    i = 8
    while i < n - n % 8:
        r0 += a[i]
        r1 += a[i + 1]
        r2 += a[i + 2]
        r3 += a[i + 3]
        r4 += a[i + 4]
        r5 += a[i + 5]
        r6 += a[i + 6]
        r7 += a[i + 7]
        i += 8
    s = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        s += a[i]
        i += 1
    return s


@njit(cache=True, error_model="numpy")
def stream(x, w, u, t, y, w_sum, target):
    """Stream candidates ``x (R, m, k)`` with weights ``w``, uniforms ``u`` and targets ``t``
    ``(R, m)`` into reservoirs ``y (R, k)``, ``w_sum (R,)``, ``target (R,)`` (in place)."""
    R, m = w.shape
    k = x.shape[2]
    for r in range(R):
        cum = w_sum[r]
        last = -1
        for j in range(m):
            cum = cum + w[r, j]
            if u[r, j] * cum < w[r, j]:
                last = j
        w_sum[r] = cum
        if last >= 0:
            for i in range(k):
                y[r, i] = x[r, last, i]
            target[r] = t[r, last]


@njit(cache=True, error_model="numpy")
def combine(mode, q_src, J, qc, back, P, Ms, W_src, us, pick, total):
    """One reuse round over rows r (receiving pixels): contributors ``(R, S)`` as in the module
    docstring (``back (R, S - 1)`` for pairwise, ``P (R, S, S)`` for balance, else empty);
    writes the picked contributor ``pick (R,)`` and ``total (R,)`` = sum_s w_s."""
    R, S = qc.shape
    m = np.empty(S)
    tmp = np.empty(max(S, 1))
    for r in range(R):
        if mode == 0 or S == 1:
            for s in range(S):
                tmp[s] = Ms[r, s]
            msum = _sum(tmp, S)
            for s in range(S):
                m[s] = _ratio(Ms[r, s], msum)
        elif mode == 1:
            for s in range(1, S):
                tmp[s - 1] = Ms[r, s]
            C = _sum(tmp, S - 1)
            a = _ratio(Ms[r, 0], C)
            aq = a * qc[r, 0]
            for s in range(1, S):
                share = _ratio(Ms[r, s], C)
                own = _ratio(q_src[r, s], J[r, s])
                m[s] = share * _ratio(own, own + a * qc[r, s])
                tmp[s - 1] = share * _ratio(aq, back[r, s - 1] + aq)
            m[0] = _sum(tmp, S - 1) if C > 0.0 else 1.0
        else:
            for s in range(S):
                for t in range(S):
                    tmp[t] = Ms[r, t] * P[r, s, t]
                m[s] = _ratio(Ms[r, s] * P[r, s, s], _sum(tmp, S))
        cum = 0.0
        for s in range(S):
            cum = cum + ((m[s] * qc[r, s]) * W_src[r, s]) * J[r, s]
            tmp[s] = cum
        tot = cum
        thr = us[r] * tot
        c = 0
        for s in range(S):
            c += tmp[s] <= thr
        pick[r] = min(c, S - 1)
        total[r] = tot

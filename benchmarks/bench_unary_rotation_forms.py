"""The unary engine's rotation kernel against two cheaper-looking forms of the same rotation.

A Givens rotation of two rows, ``z_i, z_j <- c z_i - s z_j, s z_i + c z_j``, is four
floating-point operations per column in the engine's kernel (a multiply and a fused
multiply-add per output). Two ways to do with fewer were measured here, on the tiled gate
order the engine runs (round-robin circuit, one work array of ``m`` columns, one thread):

* ``shears``: three shears, ``z_i -= t z_j; z_j += s z_i; z_i -= t z_j`` with ``t = tan(phi /
  2)``: three fused multiply-adds. To keep ``|t| <= 1`` (a shear near ``phi = pi`` loses
  digits), a gate whose cosine is negative runs ``phi - pi`` and both rows change sign; a
  sign per row (kept in the kernel, applied when the rows are stored) gives the rotation of
  ``-theta`` to a gate whose rows' signs differ. Same numbers as the kernel to ~1e-14.
* ``shears, no signs``: the three shears alone (wrong for ``|theta| > pi / 2``; timing only);
* ``pairs``: two consecutive gates that share one row (97-98% of the gates in the tiled order
  pair up) in one pass over the columns, the shared row kept in registers between them: three
  rows loaded and stored for two gates instead of four (the same arithmetic);
* ``copy``: a pass that reads both rows and writes them back (the loads and stores alone).

If the kernel were bound by its arithmetic, the shears would run up to 4/3 faster; if by its
loads and stores, the pairs would. Prints
microseconds per call (the best of several rounds, the forms called in turns) and each form's
time over the kernel's; the largest difference from the kernel's numbers of the shears and of
the pairs (0: the same bits).

    python benchmarks/bench_unary_rotation_forms.py [--n 256] [--columns 32 64]
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=256)
    ap.add_argument("--columns", type=int, nargs="*", default=[32, 64])
    ap.add_argument("--rounds", type=int, default=7)
    a = ap.parse_args(argv)
    os.environ["QDENSITY_NUM_THREADS"] = "1"
    import numba

    sys.path.insert(0, HERE)
    import _scale_unary as S

    from qdensity.execution.unary import UnaryCircuit, _kernels
    from qdensity.execution.unary._tiles import reorder, tile_order

    jit = numba.njit(nogil=True, fastmath={"contract"})

    @jit
    def shears(Z, first, second, tg, sg, fg, sign, use_signs):
        B = Z.shape[1]
        for g in range(first.shape[0]):
            i, j = first[g], second[g]
            t, s = tg[g], sg[g]
            if use_signs:
                m = sign[i] * sign[j]
                t, s = m * t, m * s
                sign[i] *= fg[g]
                sign[j] *= fg[g]
            zi, zj = Z[i], Z[j]
            for b in range(B):
                x = zi[b] - t * zj[b]
                y = zj[b] + s * x
                zi[b] = x - t * y
                zj[b] = y

    @jit
    def copy(Z, first, second):
        B = Z.shape[1]
        for g in range(first.shape[0]):
            zi, zj = Z[first[g]], Z[second[g]]
            for b in range(B):
                x, y = zi[b], zj[b]
                zi[b] = y
                zj[b] = x

    @jit
    def pairs(Z, kind, rx, ry, rw, c1, s1, c2, s2):
        B = Z.shape[1]
        for u in range(kind.shape[0]):
            zx, zy = Z[rx[u]], Z[ry[u]]
            a1, b1 = c1[u], s1[u]
            if kind[u] == 1:  # gates (x, y) then (y, w)
                zw = Z[rw[u]]
                a2, b2 = c2[u], s2[u]
                for b in range(B):
                    x, y, w = zx[b], zy[b], zw[b]
                    y1 = b1 * x + a1 * y
                    zx[b] = a1 * x - b1 * y
                    zy[b] = a2 * y1 - b2 * w
                    zw[b] = b2 * y1 + a2 * w
            else:
                for b in range(B):
                    x, y = zx[b], zy[b]
                    zx[b] = a1 * x - b1 * y
                    zy[b] = b1 * x + a1 * y

    def paired(first, second, cos, sin):
        """Consecutive gates sharing one row, as units (x, y, w): gate (x, y) then (y, w), each
        written first-row-first (a gate's rows swapped is the rotation by minus its angle)."""
        units, g, G = [], 0, len(first)
        while g < G:
            one, two = {first[g], second[g]}, ({first[g + 1], second[g + 1]} if g + 1 < G
                                                else set())
            if len(one & two) == 1:
                y = (one & two).pop()
                x, w = (one - {y}).pop(), (two - {y}).pop()
                units.append((1, x, y, w, cos[g], sin[g] if first[g] == x else -sin[g],
                              cos[g + 1], sin[g + 1] if first[g + 1] == y else -sin[g + 1]))
                g += 2
            else:
                units.append((0, first[g], second[g], 0, cos[g], sin[g], 0.0, 0.0))
                g += 1
        arr = np.array(units)
        return (arr[:, 0].astype(np.int64), *(arr[:, k].astype(np.int64) for k in (1, 2, 3)),
                *(np.ascontiguousarray(arr[:, k]) for k in range(4, 8)))

    n = a.n
    uc = UnaryCircuit.from_gates(n, S.rr_gate_list(n))
    rng = np.random.default_rng(0)
    theta = rng.uniform(-np.pi, np.pi, size=uc.num_parameters)
    print(f"load average {os.getloadavg()[0]:.1f}; round-robin n = {n}, {uc.num_gates} gates, "
          "tiled order, one thread")
    print(f"{'columns':>8} | {'kernel us':>10}{'shears':>10}{'no signs':>10}{'pairs':>10}"
          f"{'copy':>10} | {'shears/k':>9}{'no sg/k':>8}{'pairs/k':>8}{'copy/k':>7} | "
          f"{'max |diff|':>10}{'pairs |diff|':>13}")

    def one(m: int) -> None:
        tuc = reorder(uc, tile_order(uc, max(8, 32 * 1024 // (8 * m))))
        first, second = tuc._gate_rows
        cos, sin, _ = _kernels.trig_of(tuc, theta)
        flip = np.where(cos < 0, -1.0, 1.0)
        sg = flip * sin
        tg = sg / (1.0 + np.abs(cos))
        X = rng.normal(size=(n, m))
        Z = X.copy()
        _kernels._shared(Z, first, second, cos, sin)
        W, sign = X.copy(), np.ones(n)
        shears(W, first, second, tg, sg, flip, sign, True)
        diff = float(np.max(np.abs(W * sign[:, None] - Z)))
        units = paired(first, second, cos, sin)
        W = X.copy()
        pairs(W, *units)
        pair_diff = float(np.max(np.abs(W - Z)))  # 0: the kernel's bits
        work = X.copy()
        fns = {"kernel": lambda: _kernels._shared(work, first, second, cos, sin),
               "shears": lambda: shears(work, first, second, tg, sg, flip, np.ones(n), True),
               "no signs": lambda: shears(work, first, second, tg, sg, flip, sign, False),
               "pairs": lambda: pairs(work, *units),
               "copy": lambda: copy(work, first, second)}
        best = dict.fromkeys(fns, float("inf"))
        for _ in range(a.rounds):
            for key, fn in fns.items():
                for _ in range(20):
                    t = time.perf_counter()
                    fn()
                    best[key] = min(best[key], time.perf_counter() - t)
                work[:] = X  # the rows stay of order one
        us = {k: 1e6 * v for k, v in best.items()}
        k = us["kernel"]
        print(f"{m:>8} | {k:>10.1f}{us['shears']:>10.1f}{us['no signs']:>10.1f}"
              f"{us['pairs']:>10.1f}{us['copy']:>10.1f} | {us['shears'] / k:>9.2f}"
              f"{us['no signs'] / k:>8.2f}{us['pairs'] / k:>8.2f}{us['copy'] / k:>7.2f} | "
              f"{diff:>10.1e}{pair_diff:>13.1e}")

    for m in a.columns:
        one(m)


if __name__ == "__main__":
    main()

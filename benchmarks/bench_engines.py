"""qdensity's exact engines against compiled peers, interleaved in one process.

Two sections:

* **adjoint**: values and gradients of ``<Z_0>`` w.r.t. every circuit parameter, for every
  non-unary family (hardware-efficient, re-uploading, equivariant XX and non-commuting, QCNN),
  widths ``--widths`` and batches ``--batches``. qdensity: ``AdjointEngine.value_and_gradient``
  (one call for the batch). Peer: PennyLane ``lightning.qubit``'s C++ adjoint through its device
  API (``execute_and_compute_derivatives``, one tape per row, no autograd layer: the fastest way
  to call it). The peer's circuits are translated gate by gate from Qiskit's own transpilation
  of the same circuit to {rx, ry, rz, cx, cz, crx, cry, crz, rxx, ryy, rzz, x, h}, and its
  gate-angle derivatives are chained to the circuit parameters with Qiskit's own
  ``ParameterExpression.gradient``: nothing of qdensity's compiler is reused. Each row also
  gives qdensity's effective bandwidth (the bytes its passes over the state read and write,
  a fused block counting once, over its median wall time) beside a copy of as many bytes on
  the same number of threads (``numpy.copyto`` on one thread, a numba ``prange`` on more).
  The n = 20, batch 16 case: ``--widths 20 --batches 16``.
* **unary**: the round-robin orthogonal layer, batch 64, forward and reverse gradient, against
  a ``jax.jit`` Givens-rotation peer written from the paper's RBS definition
  (``benchmarks/_scale_unary.py``), with flop rates (6 flops per rotation and column).

Every timing is 50 calls (``--calls``; fewer where one call is long, ``--budget``), the
engines taking turns call by call; the table gives the median and the p95 of each, the ratio
``peer / qdensity`` of median wall times (above 1: qdensity is faster) and of median process
CPU times ("cpu": the fairer one on a loaded machine, where a peer running two threads gets
two shares of it), ``p95 / median`` (thread pathologies show there) and the largest
difference from the peer. The machine's load average
is printed at the start and the end.

Run::

    python benchmarks/bench_engines.py [--section adjoint,unary] [--widths 4,8,12,16,20]
        [--batches 1,16,64] [--families hea,reup,xx,noncomm,qcnn] [--calls 50]
        [--budget 20] [--min-calls 5]
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np
from qiskit import transpile
from qiskit.circuit import ParameterExpression
from qiskit.quantum_info import SparsePauliOp

from qdensity.circuits.ansatze import (
    angle_encoding,
    equivariant_commuting,
    equivariant_noncommuting,
    hardware_efficient,
    qcnn,
)
from qdensity.execution import _numba
from qdensity.execution.statevector.adjoint import AdjointEngine

sys.path.insert(0, os.path.dirname(__file__))

BASIS = ["rx", "ry", "rz", "cx", "cz", "crx", "cry", "crz", "rxx", "ryy", "rzz", "x", "h"]


def family(name: str, n: int):
    """The benchmark circuit of a family on ``n`` qubits (data as circuit parameters)."""
    if name == "hea":
        return angle_encoding(n).compose(hardware_efficient(n, 8, ("ry", "rz")))
    if name == "reup":  # the re-uploading layer of reuploading() on every qubit, CZ ladder
        from qiskit import QuantumCircuit
        from qiskit.circuit import ParameterVector

        x, t = ParameterVector("x", n), ParameterVector("t", 3 * n * 8)
        qc = QuantumCircuit(n)
        for layer in range(8):
            for q in range(n):
                b = 3 * (n * layer + q)
                qc.rx(x[q], q)
                qc.rz(t[b], q)
                qc.ry(t[b + 1], q)
                qc.rz(t[b + 2], q)
            for q in range(n - 1):
                qc.cz(q, q + 1)
        return qc
    if name == "xx":
        return angle_encoding(n).compose(equivariant_commuting(n, "X", 3))
    if name == "noncomm":
        return angle_encoding(n).compose(equivariant_noncommuting(n, 3))
    if name == "qcnn":
        return angle_encoding(n).compose(qcnn(n))
    raise ValueError(f"unknown family {name!r}")


# ---------------------------------------------------------------------- the lightning peer
def _angle(expr, index):
    """``(cols, coeffs, offset)`` of a linear gate angle, read with Qiskit's own algebra."""
    if not isinstance(expr, ParameterExpression) or not expr.parameters:
        return [], [], float(expr)
    cols, coeffs = [], []
    for p in expr.parameters:
        cols.append(index[p])
        coeffs.append(float(expr.gradient(p)))
    return cols, coeffs, float(expr.bind({p: 0.0 for p in expr.parameters}))


def lightning_peer(circuit, n: int):
    """``(run(values) -> (values (R,), jac (R, P)), device)`` on lightning.qubit."""
    import pennylane as qml
    from pennylane.devices import ExecutionConfig

    flat = transpile(circuit, basis_gates=BASIS, optimization_level=0)
    index = {p: i for i, p in enumerate(circuit.parameters)}
    gates = []
    for inst in flat.data:
        name = inst.operation.name
        qs = [flat.find_bit(q).index for q in inst.qubits]
        if name == "barrier":
            continue
        angle = _angle(inst.operation.params[0], index) if inst.operation.params else None
        gates.append((name, qs, angle))
    rots = {"rx": qml.RX, "ry": qml.RY, "rz": qml.RZ, "crx": qml.CRX, "cry": qml.CRY,
            "crz": qml.CRZ, "rxx": qml.IsingXX, "ryy": qml.IsingYY, "rzz": qml.IsingZZ}
    fixed = {"cx": qml.CNOT, "cz": qml.CZ, "x": qml.PauliX, "h": qml.Hadamard}
    dev = qml.device("lightning.qubit", wires=n)
    config = ExecutionConfig(gradient_method="adjoint")
    P = circuit.num_parameters

    def tapes(values):
        out, chains = [], []
        for row in values:
            ops, chain = [], []
            for name, qs, angle in gates:
                wires = qs if len(qs) > 1 else qs[0]
                if angle is None:
                    ops.append(fixed[name](wires=wires))
                    continue
                cols, coeffs, offset = angle
                a = offset + sum(c * row[j] for j, c in zip(cols, coeffs, strict=True))
                ops.append(rots[name](a, wires=wires))
                if cols:
                    chain.append((len(chain), cols, coeffs))
                else:
                    chain.append(None)
            trainable = [i for i, c in enumerate(chain) if c is not None]
            out.append(qml.tape.QuantumScript(ops, [qml.expval(qml.PauliZ(0))],
                                              trainable_params=trainable))
            chains.append([c for c in chain if c is not None])
        return out, chains

    def run(values):
        ts, chains = tapes(values)
        vals, derivs = dev.execute_and_compute_derivatives(ts, config)
        jac = np.zeros((len(ts), P))
        for r, (d, chain) in enumerate(zip(derivs, chains, strict=True)):
            d = np.atleast_1d(np.asarray(d, dtype=float))
            for t, (_, cols, coeffs) in enumerate(chain):
                for j, c in zip(cols, coeffs, strict=True):
                    jac[r, j] += c * d[t]
        return np.asarray(vals, dtype=float), jac

    return run


# ---------------------------------------------------------------------- timing
def interleaved(fns: dict, calls: int, budget: float, min_calls: int = 5) -> dict:
    """Wall times of each callable, taking turns call by call (one warm-up call each); stops
    early after ``budget`` seconds (at least ``min_calls`` each). Returns per callable the median
    and p95 wall time, the number of calls and the median process CPU time (all threads)."""
    for fn in fns.values():
        fn()
    times = {k: [] for k in fns}
    cpu = {k: [] for k in fns}
    start = time.perf_counter()
    for i in range(calls):
        for k, fn in fns.items():
            c, t = time.process_time(), time.perf_counter()
            fn()
            times[k].append(time.perf_counter() - t)
            cpu[k].append(time.process_time() - c)
        if i >= min_calls - 1 and time.perf_counter() - start > budget:
            break
    return {k: (float(np.median(v)), float(np.percentile(v, 95)), len(v),
                float(np.median(cpu[k]))) for k, v in times.items()}


def sweep_bytes(engine, circuit, observables: int, rows: int) -> tuple[int, int]:
    """``(bytes, threads)`` of one ``value_and_gradient`` call on the compiled kernels: every
    pass reads and writes a state of ``16 x 2**n`` bytes per row (the forward sweep one state,
    the backward sweep ``phi`` and every ``lam``; a fused block is one pass), and the threads
    the engine's rows run on."""
    from qdensity.execution.statevector import _kernels

    prog = engine.compile(circuit)
    tab = _kernels.tables(prog)
    if tab is None:
        return 0, 1
    passes = int(np.count_nonzero(tab.head < 0))  # top-level rows: a block is one pass
    state = 16 * 2**prog.num_qubits
    per_row = 2 * state * passes * (1 + (observables + 1)) + 4 * state * observables
    return per_row * rows, len(_kernels.row_blocks(rows, prog.num_qubits, tab.kind.size))


def copy_rate(rows: int, n: int, threads: int, repeats: int = 5) -> float:
    """Bytes per second (read + write) of copying ``rows`` states of ``2**n`` complex128 on
    ``threads`` threads: ``numpy.copyto`` on one, a numba ``prange`` over rows on more."""
    src = np.ones((rows, 2**n), dtype=complex)
    dst = np.empty_like(src)
    if threads > 1 and _numba.available():
        from numba import njit, prange

        @njit(parallel=True)
        def copy(d, s):
            for r in prange(s.shape[0]):
                d[r] = s[r]

        def run():
            copy(dst, src)
    else:
        def run():
            np.copyto(dst, src)
    run()
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        run()
        times.append(time.perf_counter() - t)
    return 2 * src.nbytes / float(np.median(times))


def _ms(t: float) -> str:
    return f"{1e3 * t:9.3f}"


def adjoint_section(families, widths, batches, calls, budget, min_calls=5) -> None:
    print("\n## adjoint: values and gradients of <Z_0> w.r.t. every parameter (ms per call)")
    print(f"kernels: {'numba' if _numba.available() else 'numpy'}")
    print("GB/s: bytes the engine's passes read and write / its median wall time; copy: the "
          "same bytes copied on the same threads (thr)")
    print(f"{'family':8} {'n':>3} {'B':>3} {'P':>4} | {'qd med':>9} {'qd p95':>9} "
          f"{'p95/med':>7} | {'light med':>9} {'light p95':>9} | {'light/qd':>8} {'cpu':>8} | "
          f"{'max diff':>8} {'calls':>5} | {'GB/s':>6} {'copy':>6} {'thr':>3}")
    obs = None
    for fam in families:
        for n in widths:
            qc = family(fam, n)
            obs = SparsePauliOp.from_sparse_list([("Z", [0], 1.0)], n)
            engine = AdjointEngine()
            peer = lightning_peer(qc, n)
            for B in batches:
                rng = np.random.default_rng(0)
                vals = rng.uniform(-np.pi, np.pi, size=(B, qc.num_parameters))
                v1, j1 = engine.value_and_gradient(qc, obs, vals)
                v2, j2 = peer(vals)
                diff = max(np.abs(v1[:, 0] - v2).max(), np.abs(j1[:, 0] - j2).max())
                res = interleaved({"qd": lambda e=engine, c=qc, o=obs, v=vals:
                                   e.value_and_gradient(c, o, v),
                                   "pl": lambda p=peer, v=vals: p(v)}, calls, budget,
                                  min_calls)
                (qm, q95, cnt, qc_cpu), (pm, p95, _, pc_cpu) = res["qd"], res["pl"]
                nbytes, threads = sweep_bytes(engine, qc, 1, B)
                copy = copy_rate(B, n, threads) / 1e9
                print(f"{fam:8} {n:3d} {B:3d} {qc.num_parameters:4d} | {_ms(qm)} {_ms(q95)} "
                      f"{q95 / qm:7.2f} | {_ms(pm)} {_ms(p95)} | {pm / qm:8.2f} "
                      f"{pc_cpu / qc_cpu:8.2f} | {diff:8.1e} {cnt:5d} | "
                      f"{nbytes / qm / 1e9:6.1f} {copy:6.1f} {threads:3d}", flush=True)


def unary_section(widths, batch, calls, budget) -> None:
    from _scale_unary import jax_calls, qdensity_calls

    print(f"\n## unary: round-robin layer, batch {batch} (ms per call; GF/s = 6 x gates x "
          "batch flops / median)")
    print(f"{'n':>5} {'gates':>7} | {'fwd med':>9} {'p95/med':>7} {'GF/s':>6} | {'jax fwd':>9} "
          f"{'jax/qd':>6} | {'grad med':>9} {'p95/med':>7} | {'jax grad':>9} {'jax/qd':>6} | "
          f"{'max diff':>8}")
    for n in widths:
        q = qdensity_calls(n, batch)
        j = jax_calls(n, batch)
        if j is None:
            print("JAX is not installed (the 'bench' extra)")
            return
        diff = max(np.abs(np.asarray(q["forward"]()) - np.asarray(j["forward"]())).max(),
                   np.abs(np.asarray(q["grad"]()) - np.asarray(j["grad"]())).max())
        res = interleaved({"qf": q["forward"], "jf": j["forward"], "qg": q["grad"],
                           "jg": j["grad"]}, calls, budget)
        gates = q["uc"].num_gates
        flops = 6.0 * gates * batch
        qf, jf, qg, jg = res["qf"], res["jf"], res["qg"], res["jg"]
        print(f"{n:5d} {gates:7d} | {_ms(qf[0])} {qf[1] / qf[0]:7.2f} {flops / qf[0] / 1e9:6.2f}"
              f" | {_ms(jf[0])} {jf[0] / qf[0]:6.2f} | {_ms(qg[0])} {qg[1] / qg[0]:7.2f} | "
              f"{_ms(jg[0])} {jg[0] / qg[0]:6.2f} | {diff:8.1e}", flush=True)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--section", default="adjoint,unary")
    ap.add_argument("--families", default="hea,reup,xx,noncomm,qcnn")
    ap.add_argument("--widths", default="4,8,12,16")
    ap.add_argument("--batches", default="1,16,64")
    ap.add_argument("--unary-widths", default="16,64,256,1024")
    ap.add_argument("--calls", type=int, default=50)
    ap.add_argument("--budget", type=float, default=20.0,
                    help="seconds per table row before fewer calls are taken")
    ap.add_argument("--min-calls", type=int, default=5,
                    help="calls per engine even past the budget (wide, large batches: fewer)")
    args = ap.parse_args(argv)
    ints = lambda s: [int(v) for v in s.split(",") if v]  # noqa: E731
    print(f"load average at start: {os.getloadavg()}")
    sections = args.section.split(",")
    if "adjoint" in sections:
        adjoint_section(args.families.split(","), ints(args.widths), ints(args.batches),
                        args.calls, args.budget, args.min_calls)
    if "unary" in sections:
        unary_section(ints(args.unary_widths), 64, args.calls, args.budget)
    print(f"\nload average at end: {os.getloadavg()}")


if __name__ == "__main__":
    main()

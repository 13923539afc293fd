"""RBS as ``RBSGate`` (our Python gate) against Qiskit's standard ``XXPlusYYGate(2 theta, pi/2)``
(the same matrix, stored in Qiskit's Rust core without a Python object per instruction).

What the representation saves and what it costs, on round-robin circuits (every pair of
qubits meets once; one Parameter a gate, the same ``ParameterVector`` for both):

Three forms: ``RBSGate(theta)``; ``XXPlusYYGate(2 * theta, pi/2)`` (the same Parameters,
each angle a ``ParameterExpression``); and ``XXPlusYYGate(phi, pi/2)`` whose Parameter is the
gate's own angle ``phi = 2 theta`` (no expression per gate; gradients then chain a factor 2).

* **build**: CPU seconds to append the ``n (n - 1) / 2`` gates and the resident memory the
  circuit adds (``ru_maxrss`` after building less before, in a fresh process per case, so Rust
  allocations count too: ``tracemalloc`` sees Python's allocator only), per gate;
* **copy**: CPU seconds of ``QuantumCircuit.copy()`` (what plans and views pay per
  sub-unitary);
* **transpile**: CPU seconds of ``qiskit.transpile`` to a CZ device basis
  (``cz, rz, sx, x``, optimisation level 1) and to ``AerSimulator()``, and the two-qubit gate
  count of the result (RBS needs 2 CZ; so does ``XXPlusYYGate``);
* **engines and samplers**: whether the unary engine and the Hamming-weight sampler accept the
  circuit as it is (they read RBS gates; an ``XXPlusYYGate`` circuit would need a translation
  to their tables first), and Aer: it has no ``xx_plus_yy`` instruction, so every run
  transpiles it (the ``transpile to Aer`` column).

Before anything is timed, the two gates are checked equal as matrices (``Operator.equiv``) at
random angles, and the two circuits as operators at n = 4.

    python benchmarks/bench_rbs_representation.py [--build-widths 256 512]
                                                  [--transpile-widths 8 16 24]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time

FORMS = {"rbs": "RBSGate(θ)", "xy": "XXPlusYYGate(2θ, π/2)", "xy-angle": "XXPlusYYGate(φ, π/2)"}


def _circuit(n: int, gate: str):
    from qiskit import QuantumCircuit
    from qiskit.circuit import ParameterVector
    from qiskit.circuit.library import XXPlusYYGate

    from qdensity import RBSGate
    from qdensity.circuits.ansatze.hamming import round_robin_pairs

    pairs = [p for layer in round_robin_pairs(n) for p in layer]
    theta = ParameterVector("θ", len(pairs))
    qc = QuantumCircuit(n)
    for t, (i, j) in zip(theta, pairs, strict=True):
        if gate == "rbs":
            qc.append(RBSGate(t), [i, j])
        elif gate == "xy":  # the same parameters: the angle is the expression 2 theta
            qc.append(XXPlusYYGate(2 * t, 1.5707963267948966), [i, j])
        else:  # "xy-angle": the Parameter is XXPlusYYGate's own angle (= 2 theta)
            qc.append(XXPlusYYGate(t, 1.5707963267948966), [i, j])
    return qc


def _build_case(n: int, gate: str) -> dict:
    """Run in a fresh process: build, measure, copy."""
    import gc
    import resource

    import qiskit  # noqa: F401 - imports before the baseline

    import qdensity  # noqa: F401

    _circuit(4, gate)  # warm every import and cache
    gc.collect()
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    t = time.process_time()
    qc = _circuit(n, gate)
    build = time.process_time() - t
    after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    t = time.process_time()
    copied = qc.copy()
    copy = time.process_time() - t
    del copied
    gates = qc.size()
    return {"n": n, "gate": gate, "gates": gates, "build_s": build, "copy_s": copy,
            "mb": (after - before) / 1024, "kb_per_gate": (after - before) / gates}


def _transpile_case(n: int, gate: str) -> dict:
    from qiskit import transpile
    from qiskit_aer import AerSimulator

    qc = _circuit(n, gate)
    qc = qc.assign_parameters([0.1 + 0.01 * k for k in range(qc.num_parameters)])
    aer = AerSimulator()
    transpile(_circuit(4, gate), basis_gates=["cz", "rz", "sx", "x"], optimization_level=1)
    out = {"n": n, "gate": gate}
    for key, call in (("device", lambda: transpile(qc, basis_gates=["cz", "rz", "sx", "x"],
                                                   optimization_level=1, seed_transpiler=0)),
                      ("aer", lambda: transpile(qc, aer, optimization_level=1,
                                                seed_transpiler=0))):
        best, result = float("inf"), None
        for _ in range(3):
            t = time.process_time()
            result = call()
            best = min(best, time.process_time() - t)
        out[f"{key}_s"] = best
        out[f"{key}_2q"] = sum(1 for inst in result.data if inst.operation.num_qubits == 2)
    return out


def _engines_accept(gate: str) -> dict:
    from qdensity.execution.samplers import HammingWeightSampler
    from qdensity.execution.unary import compile_unary

    qc = _circuit(6, gate)
    answers = {}
    for name, call in (("unary engine", lambda: compile_unary(qc)),
                       ("Hamming-weight sampler", lambda: HammingWeightSampler(seed=0).compile(
                           _measured(qc)))):
        try:
            call()
            answers[name] = "accepted"
        except (TypeError, ValueError) as exc:
            answers[name] = f"refused: {type(exc).__name__}: {str(exc)[:60]}"
    return answers


def _measured(qc):
    from qiskit import QuantumCircuit

    full = QuantumCircuit(qc.num_qubits)
    full.x(0)
    full.compose(qc, inplace=True)
    full.measure_all()
    return full


def _check_equal() -> None:
    import numpy as np
    from qiskit.circuit.library import XXPlusYYGate
    from qiskit.quantum_info import Operator

    from qdensity import RBSGate

    for theta in np.random.default_rng(0).uniform(-np.pi, np.pi, 8):
        assert Operator(RBSGate(theta)).equiv(Operator(XXPlusYYGate(2 * theta, np.pi / 2)))
    a, b, c = _circuit(4, "rbs"), _circuit(4, "xy"), _circuit(4, "xy-angle")
    values = np.random.default_rng(1).uniform(-np.pi, np.pi, a.num_parameters)
    assert Operator(a.assign_parameters(values)).equiv(Operator(b.assign_parameters(values)))
    assert Operator(a.assign_parameters(values)).equiv(Operator(c.assign_parameters(2 * values)))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build-widths", type=int, nargs="+", default=[256, 512])
    ap.add_argument("--transpile-widths", type=int, nargs="+", default=[8, 16, 24])
    ap.add_argument("--case", nargs=2, help=argparse.SUPPRESS)  # internal: one build case
    args = ap.parse_args(argv)
    if args.case:
        print(json.dumps(_build_case(int(args.case[0]), args.case[1])))
        return
    import os

    _check_equal()
    print(f"load average {os.getloadavg()}; RBSGate == XXPlusYYGate(2 theta, pi/2): checked")
    print("\n| n | gates | gate | build CPU s | copy CPU s | MB | KB a gate |\n"
          "|---|---|---|---|---|---|---|")
    for n in args.build_widths:
        for gate in FORMS:
            out = subprocess.run([sys.executable, __file__, "--case", str(n), gate],
                                 check=True, capture_output=True, text=True).stdout
            r = json.loads(out.strip().splitlines()[-1])
            name = FORMS[gate]
            print(f"| {n} | {r['gates']:,} | {name} | {r['build_s']:.2f} | {r['copy_s']:.3f} | "
                  f"{r['mb']:.0f} | {r['kb_per_gate']:.2f} |", flush=True)
    print("\n| n | gate | transpile to cz/rz/sx/x CPU s | 2q gates | transpile to Aer CPU s "
          "| 2q gates |\n|---|---|---|---|---|---|")
    for n in args.transpile_widths:
        for gate in FORMS:
            r = _transpile_case(n, gate)
            name = FORMS[gate]
            print(f"| {n} | {name} | {r['device_s']:.3f} | {r['device_2q']} | {r['aer_s']:.3f} "
                  f"| {r['aer_2q']} |", flush=True)
    print("\n| gate | unary engine | Hamming-weight sampler |\n|---|---|---|")
    for gate in FORMS:
        a = _engines_accept(gate)
        name = FORMS[gate]
        print(f"| {name} | {a['unary engine']} | {a['Hamming-weight sampler']} |")
    print(f"\nload average at end {os.getloadavg()}")


if __name__ == "__main__":
    main()

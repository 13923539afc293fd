"""Served noise: a target's simulator against plain ``AerSimulator.from_backend`` on a wide device.

Aer serialises the whole noise model it is given on every ``run``; a 27-qubit device's model
holds one depolarising and one thermal-relaxation channel per gate and qubit, so an 8-qubit
circuit pays for 27 qubits' errors per call. ``HardwareTarget.simulator`` hands Aer only the
errors of the qubits each job acts on (``qdensity.hardware._served_noise``). This script times,
per cell (device x Aer method), one ``run(...).result()`` of an 8-qubit circuit transpiled onto
the device, for

* ``served``: ``tgt.simulator(method=..., seed=...)``;
* ``plain``: ``AerSimulator.from_backend(tgt.backend, method=..., noise_model=tgt.noise_model,
  seed_simulator=...)``, the peer (the same channel, the whole model serialised per call).

Both on one thread (``max_parallel_threads=1``), in CPU seconds of the process. ``first`` is the
served simulator's first call (it builds the served model of the job's qubits, once per noise
model and set of qubits); the steady columns are the minimum over ``--repeat`` calls, taken in
turn (served, plain, served, ...) so a change of the machine's load falls on both. ``same``
says whether the two gave the same counts for the same seed (a sanity check, not the test: the
tests compare the channels exactly). The device's noise model is built before any timing.

    python benchmarks/bench_served_noise.py [--repeat 7] [--shots 256]
                                            [--methods statevector density_matrix
                                             matrix_product_state]
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # before qiskit_aer loads OpenMP

from qiskit import QuantumCircuit
from qiskit.providers.fake_provider import GenericBackendV2
from qiskit_aer import AerSimulator

from qdensity.hardware.targets import get_target

_WIDTH = 8


def _circuit() -> QuantumCircuit:
    """An 8-qubit entangling chain with rotations, measured (transpiled per device)."""
    qc = QuantumCircuit(_WIDTH, _WIDTH)
    for q in range(_WIDTH):
        qc.ry(0.3 + 0.1 * q, q)
    for q in range(_WIDTH - 1):
        qc.cx(q, q + 1)
    for q in range(_WIDTH):
        qc.rz(0.2 * q, q)
        qc.sx(q)
    qc.measure(range(_WIDTH), range(_WIDTH))
    return qc


def _cpu(run) -> tuple[float, object]:
    t = time.process_time()
    out = run()
    return time.process_time() - t, out


def _cell(tgt, circuit, method: str, shots: int, repeat: int) -> dict:
    served = tgt.simulator(method=method, seed=11)
    served.set_options(max_parallel_threads=1)
    plain = AerSimulator.from_backend(tgt.backend, method=method, noise_model=tgt.noise_model,
                                      seed_simulator=served.options.seed_simulator,
                                      max_parallel_threads=1)
    first, a = _cpu(lambda: served.run(circuit, shots=shots).result().get_counts())
    _, b = _cpu(lambda: plain.run(circuit, shots=shots).result().get_counts())
    ts: list[float] = []
    tp: list[float] = []
    for _ in range(repeat):
        ts.append(_cpu(lambda: served.run(circuit, shots=shots).result())[0])
        tp.append(_cpu(lambda: plain.run(circuit, shots=shots).result())[0])
    return {"first": first, "served": min(ts), "plain": min(tp), "same": a == b}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--shots", type=int, default=256)
    parser.add_argument("--methods", nargs="+",
                        default=["statevector", "density_matrix", "matrix_product_state"])
    args = parser.parse_args()
    devices = {"fake_kolkata": get_target("fake_kolkata", seed=1),
               "generic27": get_target(GenericBackendV2(27, seed=5), seed=1)}
    print(f"{_WIDTH}-qubit circuit, {args.shots} shots, one thread, CPU s per run "
          f"(min of {args.repeat}); load {os.getloadavg()[0]:.1f}")
    print(f"{'device':<13} {'method':<21} {'first':>7} {'served':>8} {'plain':>8} "
          f"{'served/plain':>12} {'same':>5}")
    for name, tgt in devices.items():
        assert tgt.is_noisy  # builds the noise model before any timing
        circuit = tgt.transpile(_circuit())
        for method in args.methods:
            r = _cell(tgt, circuit, method, args.shots, args.repeat)
            print(f"{name:<13} {method:<21} {r['first']:7.3f} {r['served']:8.3f} "
                  f"{r['plain']:8.3f} {r['served'] / r['plain']:12.2f} {str(r['same']):>5}")


if __name__ == "__main__":
    main()

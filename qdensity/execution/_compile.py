"""Compiling templates for engines: a structural fingerprint of a template (so a rebuilt,
identical template is transpiled once), the per-engine transpile cache, the parameter columns
that survive transpilation, the terminal-measurement map of the exact engine, and the two
transpilers a :class:`~qdensity.execution.engines.SamplerEngine` builds for itself (module-level
classes, so an engine pickles with its target and settings).
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable

import numpy as np
from qiskit import transpile
from qiskit.circuit import QuantumCircuit

from qdensity.hardware._basis import _ideal_basis

__all__ = ["circuit_fingerprint", "circuit_digest", "unroll_misbound", "AER_MISBOUND_GATES",
           "TranspileCache", "TargetTranspiler", "AerTranspiler"]


def circuit_fingerprint(circuit: QuantumCircuit) -> tuple:
    """A hashable description of a template's structure (gates, qubits, clbits, parameter
    expressions), so an identical template rebuilt later is recognised and not transpiled again."""
    qindex = {q: i for i, q in enumerate(circuit.qubits)}  # = find_bit(q).index, at once
    cindex = {c: i for i, c in enumerate(circuit.clbits)}
    data = tuple(
        (inst.operation.name,
         tuple([qindex[q] for q in inst.qubits]),
         tuple([cindex[c] for c in inst.clbits]),
         tuple(_param_key(p) for p in inst.operation.params),
         _operator_key(inst.operation))
        for inst in circuit.data
    )
    return (circuit.num_qubits, circuit.num_clbits, tuple(p.name for p in circuit.parameters),
            data)


def circuit_digest(circuit: QuantumCircuit) -> bytes:
    """:func:`circuit_fingerprint` as a 32-byte BLAKE2b digest, for keys kept long.

    The same records as the fingerprint (each instruction's name, qubit and clbit indices,
    parameter keys and operator key; then the widths and parameter names), each hashed as its
    ``repr`` (self-delimiting: quoted strings, bracketed tuples) one at a time, so neither the
    key nor the fingerprint's tuples are held: a fingerprint of a 512-gate ``U_k`` is about
    15,000 small Python objects, 250 MB of cache keys over the round-robin model at
    ``n = 1024``, and the small objects it leaves scattered keep the allocator's memory
    from being returned. Equal fingerprints give equal digests; different ones collide with
    probability about ``2**-256``.

    Parameters
    ----------
    circuit : QuantumCircuit

    Returns
    -------
    bytes
    """
    h = hashlib.blake2b(digest_size=32)
    qindex = {q: i for i, q in enumerate(circuit.qubits)}
    cindex = {c: i for i, c in enumerate(circuit.clbits)}
    for inst in circuit.data:
        h.update(repr((inst.operation.name,
                       tuple([qindex[q] for q in inst.qubits]),
                       tuple([cindex[c] for c in inst.clbits]),
                       tuple(_param_key(p) for p in inst.operation.params),
                       _operator_key(inst.operation))).encode())
    h.update(repr(("end", circuit.num_qubits, circuit.num_clbits,
                   tuple(p.name for p in circuit.parameters))).encode())
    return h.digest()


#: Parameterised gates that qiskit-aer 0.18 binds wrongly from parameter arrays (its results
#: differ from bound circuits by up to 0.15 in probability): unrolled before running on Aer.
AER_MISBOUND_GATES = ("crx", "cry", "crz", "cp", "cu1", "cu", "cu3")


def unroll_misbound(circuit: QuantumCircuit) -> QuantumCircuit:
    """Replace parameterised controlled rotations by their definitions (see
    :data:`AER_MISBOUND_GATES`), recursively until none is left."""
    for _ in range(4):
        names = {inst.operation.name for inst in circuit.data
                 if inst.operation.name in AER_MISBOUND_GATES
                 and any(getattr(p, "parameters", None) for p in inst.operation.params)}
        if not names:
            return circuit
        circuit = circuit.decompose(gates_to_decompose=sorted(names))
    return circuit


def _param_key(p):
    if isinstance(p, np.ndarray):  # a matrix (UnitaryGate): str() would abbreviate it
        return (p.shape, p.tobytes())
    return str(p)


def _operator_key(op) -> tuple:
    """What a gate's name and angles leave out: a Pauli evolution's operator (XX and YY
    evolutions share name and angle)."""
    operator = getattr(op, "operator", None)
    if operator is None:
        return ()
    ops = operator if isinstance(operator, list) else [operator]
    out: list[object] = []
    for o in ops:
        if hasattr(o, "paulis"):
            out.append((tuple(o.paulis.to_labels()), tuple(complex(c) for c in o.coeffs)))
        else:
            out.append(str(o))
    return tuple(out)


class TranspileCache:
    """Transpile each distinct template once, recognised by :func:`circuit_fingerprint`."""

    def __init__(self, transpiler: Callable[[QuantumCircuit], QuantumCircuit]):
        self._transpiler = transpiler
        self._store: dict[tuple, QuantumCircuit] = {}
        self.misses = 0

    def __getstate__(self) -> dict:
        """A copy or an unpickled cache starts empty: transpiled circuits are rebuilt on use,
        never carried."""
        return {"_transpiler": self._transpiler, "_store": {}, "misses": 0}

    def __call__(self, circuit: QuantumCircuit) -> QuantumCircuit:
        key = circuit_fingerprint(circuit)
        hit = self._store.get(key)
        if hit is not None:
            return hit
        self.misses += 1
        out = self._transpiler(circuit)
        self._store[key] = out
        return out


def _columns_for(template: QuantumCircuit, compiled: QuantumCircuit) -> np.ndarray:
    """Indices of ``template.parameters`` that survive in ``compiled`` (by name), in its order."""
    index = {p.name: i for i, p in enumerate(template.parameters)}
    return np.array([index[p.name] for p in compiled.parameters], dtype=int)


def _measurement_map(circuit: QuantumCircuit) -> tuple[QuantumCircuit, list[int]]:
    """Strip terminal measurements; return the bare circuit and the qubit of each clbit."""
    bare = circuit.copy_empty_like()
    qubit_of: dict[int, int] = {}
    measured_qubits: set[int] = set()
    for inst in circuit.data:
        qs = [circuit.find_bit(q).index for q in inst.qubits]
        if inst.operation.name == "measure":
            c = circuit.find_bit(inst.clbits[0]).index
            if c in qubit_of:
                raise ValueError(f"clbit {c} is measured twice; the exact engine needs one final "
                                 "measurement per clbit")
            qubit_of[c] = qs[0]
            measured_qubits.add(qs[0])
            continue
        if measured_qubits.intersection(qs) and inst.operation.name != "barrier":
            raise ValueError("the exact engine supports terminal measurements only (gate "
                             f"{inst.operation.name!r} acts after a measurement)")
        bare.append(inst)
    missing = [c for c in range(circuit.num_clbits) if c not in qubit_of]
    if missing:
        raise ValueError(f"clbits {missing} are never measured")
    return bare, [qubit_of[c] for c in range(circuit.num_clbits)]


class TargetTranspiler:
    """``target.transpile(circuit, optimization_level=level, seed=seed)``, picklable."""

    def __init__(self, target, level: int, seed: int | None):
        self.target, self.level, self.seed = target, level, seed

    def __call__(self, circuit: QuantumCircuit) -> QuantumCircuit:
        return self.target.transpile(circuit, optimization_level=self.level, seed=self.seed)


class AerTranspiler:
    """Transpile for a plain ``AerSimulator`` (basis only) as a picklable callable."""

    def __init__(self, level: int, seed: int | None):
        self.level, self.seed = level, seed

    def __call__(self, circuit: QuantumCircuit) -> QuantumCircuit:
        from qiskit_aer import AerSimulator

        sim = AerSimulator()
        # AerSimulator's Target stops at the width a statevector fits in this machine's memory;
        # wider circuits (matrix-product states) are compiled to its gates without it
        where = ({"backend": sim} if circuit.num_qubits <= sim.num_qubits
                 else {"basis_gates": list(_ideal_basis()) + ["measure", "reset", "delay"]})
        return unroll_misbound(transpile(circuit, optimization_level=self.level,
                                         seed_transpiler=self.seed, **where))


class MarkedTranspiler:
    """Transpile with ``transpiler`` and record, in the compiled circuit's ``metadata``, the
    fixed Hamming weight of the template's ideal outcomes (None when it has none), which the
    Aer method choice and post-selection read (a module-level class, so engines pickle)."""

    def __init__(self, transpiler: Callable[[QuantumCircuit], QuantumCircuit]):
        self.transpiler = transpiler

    def __call__(self, circuit: QuantumCircuit) -> QuantumCircuit:
        from qdensity.hardware.aer_sampling import HAMMING_WEIGHT_KEY
        from qdensity.hardware.mitigation import fixed_hamming_weight

        try:
            weight = fixed_hamming_weight(circuit)
        except ValueError:
            weight = None
        compiled = self.transpiler(circuit)
        compiled.metadata = {**(compiled.metadata or {}), HAMMING_WEIGHT_KEY: weight}
        return compiled

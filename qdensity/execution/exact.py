"""Exact engine: outcome probabilities from an Aer simulator (``save_probabilities``), no shots.

One simulator run per template carries every parameter row. The probabilities are dense
``(rows, 2**num_clbits)`` arrays indexed by the integer ``sum_j b_j 2^j`` of the clbits, so the
engine refuses circuits wider than :data:`~qdensity.validation.MAX_DENSE_QUBITS` (24) qubits;
:class:`~qdensity.execution.sampler.SamplerEngine` keeps measured bits instead and has no such
limit.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from qiskit import transpile
from qiskit.circuit import QuantumCircuit

from qdensity.execution._compile import (
    TranspileCache,
    _columns_for,
    _measurement_map,
    unroll_misbound,
)
from qdensity.execution.plans import CircuitJob, JobResult
from qdensity.validation import MAX_DENSE_QUBITS, Instance, Options, check_sequence_of, validates
from qdensity.validation import check_width as check_dense_width

__all__ = ["ExactEngine"]


@validates(
    method=Options(('statevector', 'density_matrix')),
    noise_model=[Instance('qiskit_aer.noise:NoiseModel'), None], device=Options(('CPU', 'GPU')),
)
class ExactEngine:
    """Exact outcome probabilities from an Aer simulator (no shots).

    Parameters
    ----------
    method : str
        Aer method: ``"statevector"`` (default) or ``"density_matrix"`` (use with a noise
        model for exact noisy probabilities; readout errors are not applied by
        ``save_probabilities``).
    noise_model : qiskit_aer.noise.NoiseModel, optional
    device : {"CPU", "GPU"}
        ``"GPU"`` needs ``qiskit-aer-gpu``.

    Examples
    --------
    >>> from qiskit.quantum_info import SparsePauliOp
    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.execution.plans import expectation_plan
    >>> qc = round_robin(4)
    >>> qc.x(0)  # doctest: +ELLIPSIS
    <...>
    >>> est = expectation_plan(qc, SparsePauliOp("IIIZ"), [0.0] * 6).run(ExactEngine())
    """

    def __init__(self, method: str = "statevector", noise_model=None, device: str = "CPU"):
        from qiskit_aer import AerSimulator

        if device == "GPU" and "GPU" not in AerSimulator().available_devices():
            raise ValueError("device='GPU' needs qiskit-aer-gpu and a CUDA GPU; none is available")
        self.simulator = AerSimulator(method=method, noise_model=noise_model, device=device)
        self._cache = TranspileCache(self._prepare)

    @property
    def transpile_count(self) -> int:
        """How many templates have been transpiled (each once per engine)."""
        return self._cache.misses

    #: Widest circuit accepted with ``method="statevector"`` (a 2**n complex vector).
    max_qubits_statevector = MAX_DENSE_QUBITS
    #: Widest circuit accepted with ``method="density_matrix"`` (a 4**n complex matrix).
    max_qubits_density_matrix = MAX_DENSE_QUBITS // 2

    @property
    def max_qubits(self) -> int:
        """Widest circuit this engine accepts (``n`` qubits hold ``2**n`` or ``4**n`` numbers)."""
        method = self.simulator.options.method
        return (self.max_qubits_density_matrix if method == "density_matrix"
                else self.max_qubits_statevector)

    def _check_width(self, job: CircuitJob) -> None:
        alternative = ("SamplerEngine (shots), the unary engine for RBS circuits, or "
                       "AerSimulator(method='matrix_product_state') as a SamplerV2")
        check_dense_width(job.circuit.num_qubits, limit=self.max_qubits,
                    engine=f"ExactEngine(method={self.simulator.options.method!r})",
                    alternative=alternative)
        check_dense_width(job.circuit.num_clbits, limit=self.max_qubits, engine="ExactEngine",
                    alternative=alternative, rows=job.rows)

    def _prepare(self, circuit: QuantumCircuit) -> QuantumCircuit:
        bare, qubits = _measurement_map(circuit)
        bare.save_probabilities(qubits)
        return unroll_misbound(transpile(bare, self.simulator, optimization_level=0))

    def run(self, jobs: Sequence[CircuitJob]) -> list[JobResult]:
        """Exact probabilities for every row of every job (shots are ignored)."""
        results = []
        for job in check_sequence_of(jobs, "jobs", CircuitJob, "CircuitJob"):
            self._check_width(job)
            compiled = self._cache(job.circuit)
            cols = _columns_for(job.circuit, compiled)
            binds = (
                [{p: job.values[:, c].tolist() for p, c in zip(compiled.parameters, cols,
                                                              strict=True)}]
                if compiled.num_parameters
                else None
            )
            reps = 1 if binds is None else job.rows
            raw = self.simulator.run(compiled, parameter_binds=binds).result()
            probs = np.array([np.asarray(raw.data(i)["probabilities"]) for i in range(reps)])
            if binds is None and job.rows > 1:
                probs = np.repeat(probs, job.rows, axis=0)
            results.append(JobResult(probs, None, job))
        return results

"""Engines execute plans: exact probabilities, or shots through any ``BaseSamplerV2``.

* :class:`ExactEngine`: exact outcome probabilities from Aer (``save_probabilities``), one
  simulator run per template carrying every parameter row.
* :class:`SamplerEngine`: honest shots through any ``BaseSamplerV2`` (qiskit-aer's by default,
  a hardware provider's primitive plugs in unchanged). One PUB per template with a parameter
  array, never one job per row; each template is transpiled once and reused; every run is
  written to a :class:`ShotLedger`.

Both return, per job, a :class:`qdensity.plans.JobResult`. The exact engine's
``probabilities`` are dense ``(rows, 2**num_clbits)`` arrays indexed by the integer
``sum_j b_j 2^j`` of the clbits, so it refuses circuits wider than
:data:`~qdensity.validation.MAX_DENSE_QUBITS` (24) qubits. The sampler engine keeps the
measured bits (``JobResult.bits``, ``(rows, shots, num_clbits)``): estimates come from parities
and observed outcomes with memory ``O(rows x shots)`` whatever the width.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from qiskit import transpile
from qiskit.circuit import QuantumCircuit
from qiskit.primitives import BaseSamplerV2

from qdensity.execution._device import check_for_device, check_width, device_of
from qdensity.execution._independent import run_independent
from qdensity.execution.plans import CircuitJob, JobResult, bits_to_probabilities
from qdensity.progress import progress_bar, wait_for
from qdensity.validation import (
    MAX_DENSE_QUBITS,
    SeedLike,
    check_callable,
    check_positive_int,
    check_sequence_of,
    check_target,
    check_type,
    seed_int,
)
from qdensity.validation import check_width as check_dense_width

__all__ = [
    "ExactEngine",
    "SamplerEngine",
    "ShotLedger",
    "LedgerEntry",
    "bitarray_to_probabilities",
    "bitarray_to_bits",
]


@dataclass
class LedgerEntry:
    """One sampled job: what it was for, how many circuits (rows) and shots it spent."""

    label: str
    circuits: int
    shots: int


@dataclass
class ShotLedger:
    """Running account of every sampled execution.

    Attributes
    ----------
    entries : list of LedgerEntry
    """

    entries: list[LedgerEntry] = field(default_factory=list)

    def record(self, label: str, circuits: int, shots: int) -> None:
        """Add an entry: ``circuits`` rows, ``shots`` in total over them (ints >= 0)."""
        self.entries.append(LedgerEntry(check_type(label, "label", str, "a str"),
                                        check_positive_int(circuits, "circuits", minimum=0),
                                        check_positive_int(shots, "shots", minimum=0)))

    @property
    def total_shots(self) -> int:
        """Shots spent so far."""
        return sum(e.shots for e in self.entries)

    @property
    def total_circuits(self) -> int:
        """Circuit executions (parameter rows) so far."""
        return sum(e.circuits for e in self.entries)

    def by_label(self) -> dict[str, tuple[int, int]]:
        """``{label prefix: (circuits, shots)}``, labels cut at the first ``[``."""
        out: dict[str, tuple[int, int]] = {}
        for e in self.entries:
            key = e.label.split("[", 1)[0]
            c, s = out.get(key, (0, 0))
            out[key] = (c + e.circuits, s + e.shots)
        return out

    def summary(self) -> str:
        """A short text table of circuits and shots per label."""
        lines = [f"{'label':<28}{'circuits':>10}{'shots':>12}"]
        for key, (c, s) in self.by_label().items():
            lines.append(f"{key:<28}{c:>10}{s:>12}")
        lines.append(f"{'total':<28}{self.total_circuits:>10}{self.total_shots:>12}")
        return "\n".join(lines)


def circuit_fingerprint(circuit: QuantumCircuit) -> tuple:
    """A hashable description of a template's structure (gates, qubits, clbits, parameter
    expressions), so an identical template rebuilt later is recognised and not transpiled again."""
    data = tuple(
        (inst.operation.name,
         tuple(circuit.find_bit(q).index for q in inst.qubits),
         tuple(circuit.find_bit(c).index for c in inst.clbits),
         tuple(_param_key(p) for p in inst.operation.params),
         _operator_key(inst.operation))
        for inst in circuit.data
    )
    return (circuit.num_qubits, circuit.num_clbits, tuple(p.name for p in circuit.parameters),
            data)


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
    out = []
    for o in ops:
        if hasattr(o, "paulis"):
            out.append((tuple(o.paulis.to_labels()), tuple(complex(c) for c in o.coeffs)))
        else:
            out.append(str(o))
    return tuple(out)


class _TranspileCache:
    """Transpile each distinct template once, recognised by :func:`circuit_fingerprint`."""

    def __init__(self, transpiler: Callable[[QuantumCircuit], QuantumCircuit]):
        self._transpiler = transpiler
        self._store: dict[tuple, QuantumCircuit] = {}
        self.misses = 0

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
    >>> from qdensity.ansatze import round_robin
    >>> from qdensity.plans import expectation_plan
    >>> qc = round_robin(4)
    >>> qc.x(0)  # doctest: +ELLIPSIS
    <...>
    >>> est = expectation_plan(qc, SparsePauliOp("IIIZ"), [0.0] * 6).run(ExactEngine())
    """

    def __init__(self, method: str = "statevector", noise_model=None, device: str = "CPU"):
        from qiskit_aer import AerSimulator

        if method not in ("statevector", "density_matrix"):
            raise ValueError(f"method must be 'statevector' or 'density_matrix', got {method!r}")
        if device not in ("CPU", "GPU"):
            raise ValueError(f"device must be 'CPU' or 'GPU', got {device!r}")
        if device == "GPU" and "GPU" not in AerSimulator().available_devices():
            raise ValueError("device='GPU' needs qiskit-aer-gpu and a CUDA GPU; none is available")
        self.simulator = AerSimulator(method=method, noise_model=noise_model, device=device)
        self._cache = _TranspileCache(self._prepare)

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


def bitarray_to_bits(bitarray, rows: int, shots: int | None = None) -> np.ndarray:
    """The measured bits of a ``BitArray`` holding ``rows * shots`` samples.

    Parameters
    ----------
    bitarray : qiskit.primitives.BitArray
        Shape ``(rows,)`` with ``shots`` each, or shape ``()`` with ``rows * shots`` samples
        (consecutive blocks of ``shots`` form the rows).
    rows : int
    shots : int, optional
        Shots per row (default ``bitarray.num_shots``).

    Returns
    -------
    numpy.ndarray of bool, shape (rows, shots, num_bits)
        Column ``j`` is clbit ``j``; ``rows * shots * num_bits`` bytes, never ``2**num_bits``.
    """
    shots = bitarray.num_shots if shots is None else int(shots)
    arr = np.asarray(bitarray.array).reshape(rows, shots, -1)
    # BitArray bytes are big-endian: the last byte holds clbits 0..7, its lowest bit clbit 0
    bits = np.unpackbits(arr[..., ::-1], axis=-1, bitorder="little")
    return bits[..., : bitarray.num_bits].astype(bool)


def bitarray_to_probabilities(bitarray, rows: int, shots: int | None = None) -> np.ndarray:
    """Empirical outcome frequencies from a ``BitArray`` holding ``rows * shots`` samples.

    Parameters
    ----------
    bitarray : qiskit.primitives.BitArray
        Shape ``(rows,)`` with ``shots`` each, or shape ``()`` with ``rows * shots`` samples
        (consecutive blocks of ``shots`` form the rows).
    rows : int
    shots : int, optional
        Shots per row (default ``bitarray.num_shots``).

    Returns
    -------
    numpy.ndarray, shape (rows, 2**num_bits)

    Raises
    ------
    ValueError
        Above ``MAX_DENSE_QUBITS`` (24) bits; use :func:`bitarray_to_bits`.
    """
    return bits_to_probabilities(bitarray_to_bits(bitarray, rows, shots))


class SamplerEngine:
    """Shots through a ``BaseSamplerV2``, one PUB per template, transpiled once.

    Parameters
    ----------
    sampler : BaseSamplerV2, optional
        Any V2 sampler (a hardware provider's included). Default: qiskit-aer's ``SamplerV2``
        seeded with ``seed`` (noiseless unless a ``target`` is given).
    target : qdensity.targets.HardwareTarget, optional
        Where circuits are transpiled and, when ``sampler`` is None, whose noisy simulator
        samples.
    transpiler : callable, optional
        ``QuantumCircuit -> QuantumCircuit``; overrides ``target``'s transpilation. With neither,
        circuits are transpiled for ``AerSimulator``.
    seed : int or numpy.random.Generator, optional
        Seeds the default sampler and the transpiler so runs repeat exactly.
    ledger : ShotLedger, optional
        Written on every run; a fresh one is made if not given.
    default_shots : int
        Shots per row for jobs that do not say (exact jobs are sampled with this many).
    progress : bool
        On a terminal, a run that lasts longer than :attr:`progress_delay` seconds shows one
        bar per phase: ``transpile`` (templates) and ``sample`` (circuits, shots in the
        postfix). The sampler gets one call, so the ``sample`` bar's clock runs while it waits
        and the bar fills when the call returns. False (or no terminal): silent.

    Examples
    --------
    Passing a hardware provider's primitive instead of Aer's::

        engine = SamplerEngine(sampler=provider_sampler, transpiler=pass_manager.run)
    """

    def __init__(
        self,
        sampler: BaseSamplerV2 | None = None,
        *,
        target=None,
        transpiler: Callable[[QuantumCircuit], QuantumCircuit] | None = None,
        seed: SeedLike = None,
        ledger: ShotLedger | None = None,
        default_shots: int = 1024,
        optimization_level: int = 1,
        progress: bool = True,
    ):
        if (isinstance(optimization_level, bool) or not isinstance(optimization_level, int)
                or optimization_level not in (0, 1, 2, 3)):
            raise ValueError(f"optimization_level must be 0, 1, 2 or 3 (Qiskit's transpiler "
                             f"levels), got {optimization_level!r}")
        seed = seed_int(seed)
        check_target(target)
        if transpiler is not None:
            check_callable(transpiler, "transpiler", "a callable QuantumCircuit -> QuantumCircuit")
        check_type(ledger, "ledger", ShotLedger, "a ShotLedger", allow_none=True)
        check_type(progress, "progress", (bool, np.bool_), "a bool")
        if sampler is None:
            if target is not None:
                sampler = target.sampler(seed=seed)
            else:
                from qiskit_aer.primitives import SamplerV2

                sampler = SamplerV2(seed=seed)
        if not isinstance(sampler, BaseSamplerV2):
            raise TypeError(f"sampler must be a BaseSamplerV2, got {type(sampler).__name__}")
        self.sampler = sampler
        self._device = device_of(sampler)  # a provider's backend: circuits are checked against it
        if transpiler is None:
            if target is not None:
                def transpiler(c: QuantumCircuit) -> QuantumCircuit:
                    return target.transpile(c, optimization_level=optimization_level, seed=seed)
            else:
                from qiskit_aer import AerSimulator

                backend = AerSimulator()

                def transpiler(c: QuantumCircuit) -> QuantumCircuit:
                    return unroll_misbound(transpile(c, backend,
                                                     optimization_level=optimization_level,
                                                     seed_transpiler=seed))
        self._cache = _TranspileCache(transpiler)
        self.ledger = ledger if ledger is not None else ShotLedger()
        self.default_shots = check_positive_int(default_shots, "default_shots")
        self.progress = bool(progress)

    #: Seconds a phase must last before its progress bar draws.
    progress_delay: float = 1.0

    def _bar(self, total: int, desc: str, unit: str):
        return progress_bar(total, desc=desc, unit=unit, verbose=self.progress,
                            delay=self.progress_delay, leave=True)

    @property
    def transpile_count(self) -> int:
        """How many templates have been transpiled (each once)."""
        return self._cache.misses

    def compiled(self, circuit: QuantumCircuit) -> QuantumCircuit:
        """The transpiled form of a template (transpiled once, then cached), as submitted."""
        return self._cache(circuit)

    def run(self, jobs: Sequence[CircuitJob]) -> list[JobResult]:
        """Sample every job: one PUB each, all in one sampler call (progress: see the class).

        On a seeded Aer ``SamplerV2`` PUBs of different shot counts go in one call per count,
        each with its own seed (:mod:`qdensity.execution._independent`: Aer would give them
        the same random stream, correlating their shots).

        When the sampler names its device (a provider's primitive), every template is checked
        against it first: a job wider than the device or holding an instruction it cannot run
        raises ``ValueError`` before anything is submitted. The ledger is written only once
        the sampler's results are back, so a failed job leaves it unchanged.
        """
        jobs = check_sequence_of(jobs, "jobs", CircuitJob, "CircuitJob")
        pubs, metas = [], []
        bar = self._bar(len(jobs), "transpile", "template")
        for job in jobs:
            if self._device is not None:
                check_width(job.circuit, self._device, job.label or job.circuit.name)
            compiled = self._cache(job.circuit)
            if self._device is not None:
                check_for_device(compiled, self._device, job.label or job.circuit.name)
            cols = _columns_for(job.circuit, compiled)
            shots = job.shots if job.shots is not None else self.default_shots
            if compiled.num_parameters:
                pubs.append((compiled, job.values[:, cols], shots))
            else:
                # Aer samples only one row of a parameter-free PUB with a (rows, 0) array:
                # sample rows * shots at once and split them into rows below.
                pubs.append((compiled, None, shots * job.rows))
            metas.append((job, shots))
            bar.update()
        bar.close()
        if not pubs:
            return []
        rows = sum(job.rows for job, _ in metas)
        with self._bar(rows, "sample", "circuit") as bar:
            bar.set_postfix(shots=sum(job.rows * shots for job, shots in metas), refresh=False)
            raw = run_independent(self.sampler, pubs, lambda job: wait_for(job, bar))
            bar.update(rows)
        results = []
        for (job, shots), pub_result in zip(metas, raw, strict=True):
            bits = bitarray_to_bits(pub_result.join_data(), job.rows, shots)
            self.ledger.record(job.label or job.circuit.name, job.rows, job.rows * shots)
            results.append(JobResult(None, shots, job, bits=bits))
        return results

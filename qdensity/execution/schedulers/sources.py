"""Shot sources: where a scheduler's shots come from (paper Fig. 1c, Supp. I).

A source is ``source(shots_per_k, rng) -> list of K arrays`` of per-shot values.
:func:`discrete_source` samples a synthetic distribution; :func:`sampler_source` runs the ``K``
sub-unitary circuits through any qiskit ``BaseSamplerV2`` (qiskit-aer by default, or hardware).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from qiskit.circuit import QuantumCircuit
from qiskit.primitives import BaseSamplerV2

from qdensity.execution.samplers.reseed import run_independent
from qdensity.execution.schedulers._common import _check_shots
from qdensity.execution.schedulers.base import ShotSource
from qdensity.validation import (
    MAX_DENSE_ENTRIES,
    MAX_SUBUNITARIES,
    Array,
    CallableC,
    Circuit,
    Instance,
    Seed,
    SeedLike,
    SequenceOf,
    Unchecked,
    as_rng,
    check_distribution,
    check_parameter_values,
    seed_int,
    validates,
)

__all__ = ["discrete_source", "sampler_source"]

_MAX_CLBITS = 63  # outcomes are packed into int64


@validates(
    probabilities=Array(ndim=2, max_size=MAX_DENSE_ENTRIES),
    values=Array(ndim=(1, 2), max_size=MAX_DENSE_ENTRIES), seed=Seed(),
)
def discrete_source(probabilities, values, seed: SeedLike = None) -> ShotSource:
    """A synthetic shot source: sub-unitary ``k`` yields ``values[j]`` with ``probabilities[k, j]``.

    Typical use: ``probabilities[k]`` are the exact outcome probabilities of circuit ``k``
    (``Statevector.probabilities()``) and ``values[j]`` the observable's eigenvalue on
    bitstring ``j``; then the source samples what a noiseless device would.

    Parameters
    ----------
    probabilities : array_like, shape (K, M)
        Row ``k`` is a distribution over ``M`` outcomes.
    values : array_like, shape (M,) or (K, M)
        Value of each outcome (shared, or per sub-unitary).
    seed : int, numpy.random.Generator or None
        Used only when the source is called with ``rng=None``.

    Returns
    -------
    callable
        ``source(shots_per_k, rng=None) -> list of K arrays``.

    Examples
    --------
    >>> src = discrete_source([[1.0, 0.0], [0.5, 0.5]], [1.0, -1.0])
    >>> [v.shape for v in src([3, 0], None)]
    [(3,), (0,)]
    """
    probs = np.asarray(probabilities, dtype=float)
    for k in range(probs.shape[0]):
        check_distribution(probs[k], f"probabilities[{k}]")
    vals = np.asarray(values, dtype=float)
    if vals.shape == (probs.shape[1],):
        vals = np.broadcast_to(vals, probs.shape)
    if vals.shape != probs.shape:
        raise ValueError(
            f"values must have shape ({probs.shape[1]},) or {probs.shape}, "
            f"got shape {np.shape(values)}"
        )
    cdf = np.cumsum(probs, axis=1)
    cdf[:, -1] = np.inf  # rows sum to 1 within 1e-9: never index past the last outcome
    own = as_rng(seed)
    num = probs.shape[0]

    def source(shots_per_k, rng: np.random.Generator | None = None) -> list[np.ndarray]:
        shots = _check_shots(shots_per_k, num)
        gen = own if rng is None else rng
        out = []
        for k in range(num):
            idx = np.searchsorted(cdf[k], gen.random(shots[k]), side="right")
            out.append(vals[k, idx])
        return out

    return source


def _outcome_ints(pub_result, circuit: QuantumCircuit) -> np.ndarray:
    """Per-shot outcomes as integers in which bit ``j`` is clbit ``j`` of ``circuit``."""
    data = pub_result.data
    ints = None
    for creg in circuit.cregs:
        bits = getattr(data, creg.name).to_bool_array(order="little")  # (shots, len(creg))
        weights = np.array([1 << circuit.find_bit(b).index for b in creg], dtype=np.int64)
        part = bits.astype(np.int64) @ weights
        ints = part if ints is None else ints | part
    if ints is None:
        raise ValueError(f"circuit {circuit.name!r} has no classical register to read outcomes "
                         "from; measure into a register (e.g. measure_all)")
    return ints


@validates(
    circuits=SequenceOf(Circuit(min_qubits=1), max_len=MAX_SUBUNITARIES),
    values_fn=CallableC('a callable outcomes -> values'),
    sampler=[Instance('qiskit.primitives:BaseSamplerV2'), None], seed=Seed(),
    parameter_values=[SequenceOf(Unchecked('rows checked against each circuit in the body'),
                                 min_len=0), None],
)
def sampler_source(
    circuits: Sequence[QuantumCircuit],
    values_fn: Callable[[np.ndarray], np.ndarray],
    sampler: BaseSamplerV2 | None = None,
    seed: SeedLike = None,
    parameter_values: Sequence | None = None,
) -> ShotSource:
    """A shot source that runs the ``K`` sub-unitary circuits through a ``SamplerV2``.

    Each call submits one PUB ``(circuit_k, values_k, n_k)`` per sub-unitary that is asked for
    ``n_k > 0`` shots (PUBs with no shots are left out), one ``sampler.run`` job per distinct
    shot count, all submitted before any is waited on (independent shots across counts on a
    seeded Aer sampler; one shot count per job as qiskit-ibm-runtime asks), and turns each
    PUB's bit array into per-shot values: the outcome of every shot, as an integer whose
    bit ``j`` is clbit ``j`` of the circuit, goes through ``values_fn``. So every value comes
    from a shot that was really taken.

    Parameters
    ----------
    circuits : sequence of QuantumCircuit, length K
        Measured circuits, one per sub-unitary (1 to 63 clbits, all in classical registers).
        They must already be in a form the sampler accepts: plain circuits for the default
        Aer sampler, transpiled ones for a hardware primitive.
    values_fn : callable
        ``values_fn(outcomes (shots,) int64) -> values (shots,)``, e.g. the eigenvalue of a
        diagonal observable: ``lambda b: 1.0 - 2.0 * (b & 1)`` for ``Z`` on clbit 0.
    sampler : BaseSamplerV2 or None
        ``None``: a fresh ``qiskit_aer.primitives.SamplerV2`` for each call, seeded from the
        call's generator, so calls are independent and a seed reproduces them. A sampler you
        pass is used as it is; note that an Aer ``SamplerV2`` built with a fixed ``seed``
        returns the same shots on every call, which makes a pilot and a main phase correlated.
    seed : int, numpy.random.Generator or None
        Seeds the default sampler when the source is called with ``rng=None``; schedulers pass
        their own generator, which then governs reproducibility.
    parameter_values : sequence of length K, or None
        ``parameter_values[k]``: values (P_k,) for ``circuits[k].parameters`` (``None`` for a
        circuit without parameters).

    Returns
    -------
    callable
        ``source(shots_per_k (K,) ints, rng=None) -> list of K arrays of per-shot values``.

    Examples
    --------
    >>> import numpy as np
    >>> from qiskit import QuantumCircuit
    >>> circuits = []
    >>> for theta in (0.3, 1.2, 2.0):
    ...     qc = QuantumCircuit(1, 1)
    ...     _ = qc.ry(theta, 0)
    ...     _ = qc.measure(0, 0)
    ...     circuits.append(qc)
    >>> from qdensity.execution.schedulers import proportional
    >>> src = sampler_source(circuits, lambda b: 1.0 - 2.0 * (b & 1))  # Z eigenvalue
    >>> res = proportional([0.5, 0.3, 0.2], 3000, src, seed=7)
    >>> exact = 0.5 * np.cos(0.3) + 0.3 * np.cos(1.2) + 0.2 * np.cos(2.0)
    >>> bool(abs(res.estimate - exact) < 5 * res.standard_error)
    True
    """
    circuits = list(circuits)
    for k, qc in enumerate(circuits):
        if not 1 <= qc.num_clbits <= _MAX_CLBITS:
            raise ValueError(
                f"circuits[{k}] must have 1 to {_MAX_CLBITS} classical bits (measured outcomes), "
                f"got {qc.num_clbits}"
            )
        loose = [b for b in qc.clbits if not qc.find_bit(b).registers]
        if loose:
            raise ValueError(
                f"circuits[{k}] has {len(loose)} classical bits outside any ClassicalRegister; "
                "samplers only return registers"
            )
    num = len(circuits)
    if parameter_values is None:
        parameter_values = [None] * num
    parameter_values = list(parameter_values)
    if len(parameter_values) != num:
        raise ValueError(
            f"parameter_values must have one entry per circuit ({num}), got {len(parameter_values)}"
        )
    bound: list[np.ndarray | None] = []
    for k, (qc, pv) in enumerate(zip(circuits, parameter_values, strict=True)):
        if pv is None:
            if qc.num_parameters:
                raise ValueError(
                    f"parameter_values[{k}] is None but circuits[{k}] has "
                    f"{qc.num_parameters} parameters"
                )
            bound.append(None)
            continue
        arr = check_parameter_values(pv, qc.num_parameters, f"parameter_values[{k}]")
        if arr.ndim != 1:
            raise ValueError(
                f"parameter_values[{k}] must be one row of shape ({qc.num_parameters},), "
                f"got shape {arr.shape}"
            )
        bound.append(arr)
    own = as_rng(seed)

    def source(shots_per_k, rng: np.random.Generator | None = None) -> list[np.ndarray]:
        shots = _check_shots(shots_per_k, num)
        gen = own if rng is None else rng
        out = [np.zeros(0) for _ in range(num)]
        active = np.flatnonzero(shots > 0)
        if active.size == 0:
            return out
        if sampler is None:
            from qiskit_aer.primitives import SamplerV2

            runner = SamplerV2(seed=seed_int(gen))
        else:
            runner = sampler
        pubs = [(circuits[k], bound[k], int(shots[k])) for k in active]
        result = run_independent(runner, pubs)  # Aer would correlate PUBs of different shots
        if len(result) != len(pubs):
            raise ValueError(f"sampler returned {len(result)} PUB results for {len(pubs)} PUBs")
        for k, pub_result in zip(active, result, strict=True):
            outcomes = _outcome_ints(pub_result, circuits[k])
            if outcomes.shape != (shots[k],):
                raise ValueError(
                    f"sampler returned {outcomes.shape} outcomes for circuits[{k}], "
                    f"asked for {shots[k]} shots"
                )
            vals = np.asarray(values_fn(outcomes), dtype=float)
            if vals.shape != outcomes.shape:
                raise ValueError(
                    f"values_fn must map outcomes of shape {outcomes.shape} to values of the same "
                    f"shape, got {vals.shape}"
                )
            out[k] = vals
        return out

    return source

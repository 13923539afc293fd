"""Aer simulation method and options chosen per PUB, by the qubits it uses and its shots.

:func:`qdensity.execution.samplers.target_sampler` returns an
:class:`~qdensity.execution.samplers.aer.AdaptiveSampler` by default: a ``BaseSamplerV2`` that
looks at every PUB before it runs, picks the Aer method with :func:`aer_options` and runs each
group of PUBs on qiskit-aer's public ``SamplerV2``. Aer simulates only the qubits a circuit
acts on (its truncation; a 6-qubit model transpiled onto a 19-qubit heavy-hex device is a 6-qubit
simulation), so the choice goes by :func:`active_qubits`, not the device's width.

Measured on a 2-core machine (qiskit-aer 0.18, ``heavy_hex`` and ``fake_kolkata`` noise, a
density round-robin template, 16 parameter rows per call, CPU time on one thread, the noise
served per active qubits by :class:`~qdensity.hardware._served_noise.ServedNoiseSimulator`; a
call also pays ~10 ms whatever the method):

==========  =======================  ==========================  =================
active      density matrix, per row  statevector trajectories,   crossover (shots)
qubits                               per shot
==========  =======================  ==========================  =================
4           ~0.6-1.3 ms              ~0.17 ms                    ~4-8
5           ~3.6 ms                  ~0.29 ms                    ~12
6           ~17 ms                   ~0.45 ms                    ~35-40
7           ~87 ms                   ~0.85 ms                    ~100
8           ~85-90 ms                ~1.8-2.0 ms                 ~45-60
10          ~1.1 s                   ~5.8 ms                     ~190
12          ~22-34 s                 ~24-42 ms                   ~800-920
==========  =======================  ==========================  =================

Both costs grow with the qubits (the density matrix as ``4 ** a``, a trajectory as
``2 ** a``), so the crossover roughly doubles per qubit; the density matrix pays from
:func:`density_matrix_from` shots on ``a`` active qubits (8 up to 4, then 16, 32, 96 and 64 at 5
to 8, then ``2 ** (a - 2)``: 128, 256, 512 and 1024 at 9 to 12). Hence, for a noisy target:

* ``density_matrix``, one thread, when ``a <= 12`` and ``shots >= density_matrix_from(a)``:
  exact noise, one simulation per row whatever the shots (``16 * 4 ** a`` bytes: 256 MB at 12);
* otherwise ``statevector`` trajectories, one per shot, on one thread; spread over all
  threads (``max_parallel_shots``, each shot on one thread) only for large calls, from 8 active
  qubits and :data:`PARALLEL_TRAJECTORIES` trajectories per call (rows x shots; or from 14
  active qubits whatever the shots), and only while the machine has an idle core
  (:func:`qdensity.cluster.idle_core`). Measured at 8 and 10 active qubits (heavy-hex, 2 cores,
  load ~1): on two threads a call of 16 to 256 trajectories cost 1.08-1.58x the CPU of one
  thread for 1.2-1.8x less wall time, one of 4,096 trajectories 1.03-1.04x the CPU for
  1.7-1.9x less wall time. Small calls stay on one thread, where their CPU is the best fixed
  method's.

``benchmarks/bench_noisy.py`` times this choice against each fixed method and plain Aer on the
same circuits: on heavy-hex and fake_kolkata at 4 to 12 active qubits, 1 and 16 rows, 16 to 4000
shots, it took 0.80-1.09x the CPU of the best fixed method (one thread) and 0.03-0.99x plain
Aer's.

Shot branching (``shot_branching_enable``, the previous default) is off: at 6 active qubits it
cost 2x the plain trajectories at 16 and at 1000 shots (the errors of these devices are frequent
enough that the branches rarely merge), and with noise it samples wrong distributions in
qiskit-aer 0.18.2 (see ``FAST_SAMPLER_OPTIONS``). Noiseless PUBs use Aer's ``automatic``
method (one statevector per row, then sampled), one thread below 14 active qubits (where
Aer's parallel state update starts), all threads above. Every choice binds parameter rows inside Aer
(``runtime_parameter_bind_enable``).

Device widths. A circuit that keeps Hamming weight 1 (a unary loader and RBS/FBS gates: the
engine marks its compiled form with :data:`HAMMING_WEIGHT_KEY` in ``metadata``) has Schmidt
rank at most 2 across every cut, so from :data:`MPS_FROM_QUBITS` active qubits it runs as
``matrix_product_state`` (noise by trajectories, one per shot), at any width. Any other PUB
whose statevector (``16 * 2 ** a`` bytes) or density matrix would not fit in
:func:`memory_budget` runs as ``matrix_product_state`` when its entanglement is bounded by
construction (:func:`mps_bond_bound`: two-qubit gates only between neighbours on the line of
its active qubits, few enough across every cut that the bond dimension stays at most
:data:`MPS_MAX_BOND`), and is refused otherwise, before Aer allocates anything
(:func:`check_memory`), with a ``ValueError`` that names the engine, the width and the
alternatives. The bound is a proof, not a guess: a state built from ``|0...0>`` by gates of
operator Schmidt rank ``r`` has, across a cut, Schmidt rank at most the product of the ``r`` of
the gates that cross it (and ``2 ** min(left, right)``); Aer keeps neighbour gates in place, so
no swap raises an intermediate bond. Trajectory noise (Pauli or single-qubit Kraus operators,
one sampled per gate) does not raise it either. Circuits outside the rule are refused rather
than guessed at: a matrix-product state of a highly entangled circuit is exponential again
(in memory and time), and Aer would find out only while allocating.
"""

from __future__ import annotations

import os

import numpy as np
from qiskit.circuit import QuantumCircuit

from qdensity.cluster import idle_core
from qdensity.hardware._served_noise import _NOT_QUBIT_WORK, active_indices

__all__ = ["aer_options", "active_qubits", "density_matrix_from",
           "DENSITY_MATRIX_MAX_QUBITS", "FAST_SAMPLER_OPTIONS", "MPS_FROM_QUBITS",
           "HAMMING_WEIGHT_KEY", "memory_budget", "check_memory",
           "MPS_MAX_BOND", "mps_bond_bound", "aer_seed", "PARALLEL_TRAJECTORIES"]

#: ``metadata`` key of a compiled circuit whose ideal outcomes all have this Hamming weight.
HAMMING_WEIGHT_KEY = "qdensity_hamming_weight"

#: Active qubits from which Hamming-weight-1 circuits run as matrix-product states.
MPS_FROM_QUBITS = 14

#: Largest proven bond dimension with which a PUB too wide for a dense state runs as
#: ``matrix_product_state`` (a tensor holds ``2 * chi**2`` amplitudes: 2 MB at 256).
MPS_MAX_BOND = 256

#: Two-qubit gates of operator Schmidt rank 2 (controlled single-qubit gates and ECR, which is
#: CX up to single-qubit gates); any other two-qubit instruction counts as rank 4.
_RANK_TWO = frozenset({"cx", "cy", "cz", "ch", "cp", "crx", "cry", "crz", "cs", "csdg", "csx",
                       "cu", "cu1", "cu3", "ecr"})

#: Widest circuit (active qubits) the default sampler simulates with the density matrix.
DENSITY_MATRIX_MAX_QUBITS = 12

#: Options of ``target_sampler(target, method=..., fast=True)`` with an explicit method:
#: parameter rows bound inside Aer, all cores. Shot branching stays off: with noise it gives
#: wrong counts in qiskit-aer 0.18.2. A 4-qubit noisy GHZ-like circuit, two parameter rows,
#: 2000 shots, one run per seed from 100: with runtime binding, row 0 got another row's
#: distribution in 4 of 300 runs; without it, P(0000) of row 0 came out 0.47 instead of 0.96
#: in 8 of 145 runs; with branching off, 0 of 500 runs were wrong.
FAST_SAMPLER_OPTIONS = {"shot_branching_enable": False, "runtime_parameter_bind_enable": True,
                        "max_parallel_threads": 0, "max_parallel_shots": 0}

_PARALLEL_STATE_QUBITS = 14
#: Measured crossovers (shots per row) up to 8 active qubits (the module's table; 8 up to
#: 4 qubits); above, ``2 ** (a - 2)``.
_DENSITY_MATRIX_FROM = {5: 16, 6: 32, 7: 96, 8: 64}
_DENSITY_MATRIX_MIN_SHOTS = 8
_PARALLEL_SHOT_QUBITS = 8
#: Trajectories per call (rows x shots) from which noisy statevector trajectories on 8 to 13
#: active qubits spread over the threads of an idle machine (the module's measurement).
PARALLEL_TRAJECTORIES = 2048
#: Whether threads depend on the load (:func:`qdensity.cluster.idle_core`); tests turn it off.
LOAD_AWARE = True


def active_qubits(circuit: QuantumCircuit) -> int:
    """Number of qubits an instruction of ``circuit`` acts on (what Aer simulates).

    Parameters
    ----------
    circuit : QuantumCircuit

    Returns
    -------
    int
        Qubits touched by any instruction other than ``barrier``.

    Examples
    --------
    >>> qc = QuantumCircuit(19, 2)
    >>> _ = qc.cx(3, 7)
    >>> _ = qc.measure([3, 7], [0, 1])
    >>> active_qubits(qc)
    2
    """
    if not isinstance(circuit, QuantumCircuit):
        raise TypeError(f"circuit must be a QuantumCircuit, got {type(circuit).__name__}")
    return len(active_indices(circuit))


def density_matrix_from(num_active: int) -> int:
    """Shots per row from which the density matrix is cheaper than trajectories (measured).

    Parameters
    ----------
    num_active : int
        Active qubits ``a``.

    Returns
    -------
    int
        8 up to 4 active qubits, 16, 32, 96 and 64 at 5 to 8, ``2 ** (a - 2)`` above (the
        module's table).

    Examples
    --------
    >>> [density_matrix_from(a) for a in (2, 4, 5, 6, 7, 8, 10, 12)]
    [8, 8, 16, 32, 96, 64, 256, 1024]
    """
    a = int(num_active)
    if a <= 4:
        return _DENSITY_MATRIX_MIN_SHOTS
    return _DENSITY_MATRIX_FROM.get(a, 2 ** (a - 2))


def mps_bond_bound(circuit: QuantumCircuit) -> int | None:
    """A proven bound on the bond dimension of ``circuit``'s state as a matrix-product state.

    The line is the circuit's active qubits in index order (what Aer simulates). Across the cut
    after position ``c`` the Schmidt rank is at most the product of the operator Schmidt ranks
    of the two-qubit gates acting on positions ``c`` and ``c + 1`` (2 for controlled gates and
    ECR, 4 otherwise), and at most ``2 ** min(c + 1, a - c - 1)``.

    Parameters
    ----------
    circuit : QuantumCircuit
        Starting from ``|0...0>``; ``measure``, ``reset`` and ``barrier`` add nothing.

    Returns
    -------
    int or None
        The largest bound over all cuts (1 for a product state); None when a two-qubit gate
        acts on qubits that are not neighbours on the line, or an instruction on three or more
        qubits (no bound is claimed).

    Examples
    --------
    >>> qc = QuantumCircuit(5)
    >>> _ = qc.ry(0.3, 0)
    >>> for q in range(4):
    ...     _ = qc.cx(q, q + 1)
    >>> mps_bond_bound(qc)
    2
    >>> _ = qc.cx(0, 4)
    >>> mps_bond_bound(qc) is None
    True
    """
    if not isinstance(circuit, QuantumCircuit):
        raise TypeError(f"circuit must be a QuantumCircuit, got {type(circuit).__name__}")
    used = sorted(active_indices(circuit))
    where = {q: i for i, q in enumerate(used)}
    log2 = [0.0] * max(len(used) - 1, 0)  # log2 of the bound across each cut
    for inst in circuit.data:
        k = len(inst.qubits)
        if inst.name in _NOT_QUBIT_WORK or k == 1:
            continue
        if k > 2:
            return None
        i, j = sorted(where[circuit.find_bit(q).index] for q in inst.qubits)
        if j != i + 1:
            return None
        log2[i] += 1.0 if inst.operation.name in _RANK_TWO else 2.0
    a = len(used)
    worst = max((min(b, c + 1, a - c - 1) for c, b in enumerate(log2)), default=0.0)
    return int(2 ** worst)


def memory_budget() -> int:
    """Bytes a simulation may take: half of this machine's physical memory.

    Returns
    -------
    int

    Examples
    --------
    >>> import os
    >>> memory_budget() <= os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    True
    """
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
        total = 8 * 2**30
    return int(total) // 2


def _gib(n: float) -> str:
    return f"{n / 2**30:.3g} GiB"


def _dense_bytes(num_active: int, method: str) -> float | None:
    return {"statevector": 16 * 2.0**num_active, "automatic": 16 * 2.0**num_active,
            "density_matrix": 16 * 4.0**num_active}.get(method)


def _fits(num_active: int, method: str) -> bool:
    per = _dense_bytes(num_active, method)
    return per is None or per <= memory_budget()


def check_memory(num_active: int, method: str, engine: str = "SamplerEngine",
                 circuit: QuantumCircuit | None = None) -> None:
    """Refuse a simulation whose state would not fit in :func:`memory_budget`.

    Parameters
    ----------
    num_active : int
        Active qubits.
    method : str
        Aer method (``automatic`` is taken as ``statevector``; matrix-product states and
        stabilizers are not dense and always pass).
    engine : str
        Named in the message.
    circuit : QuantumCircuit, optional
        The circuit itself: a ``matrix_product_state`` run (forced by the caller) too wide
        for a dense state must then be Hamming-weight 1 or of proven bond dimension at most
        :data:`MPS_MAX_BOND` (:func:`mps_bond_bound`); a matrix-product state of a highly
        entangled circuit is exponential again, and Aer would run for hours.

    Raises
    ------
    ValueError
        Naming the engine, the width, the bytes needed and the alternatives.

    Examples
    --------
    A dense 60-qubit state is refused before Aer allocates anything; a matrix-product state is not:

    >>> check_memory(60, "statevector")
    Traceback (most recent call last):
        ...
    ValueError: SamplerEngine: Aer's statevector method on 60 active qubits needs ...
    >>> check_memory(60, "matrix_product_state")
    """
    if method == "matrix_product_state" and circuit is not None and not _fits(
            num_active, "statevector"):
        weight = (circuit.metadata or {}).get(HAMMING_WEIGHT_KEY)
        bond = None if weight == 1 else mps_bond_bound(circuit)
        if weight != 1 and (bond is None or bond > MPS_MAX_BOND):
            raise ValueError(
                f"{engine}: Aer's matrix_product_state method on {num_active} active qubits "
                f"needs a circuit of bounded entanglement, and this one has no proven bond "
                f"bound (two-qubit gates between qubits that are not neighbours on the line of "
                f"its active qubits{'' if bond is None else f', or a bond bound of {bond}'}; "
                f"at most {MPS_MAX_BOND} runs); alternatives: Hamming-weight-1 circuits (a "
                f"unary loader and RBS/FBS gates), the unary engine for RBS circuits at any "
                f"width, or fewer qubits")
    if _fits(num_active, method):
        return
    per = _dense_bytes(num_active, method)
    assert per is not None  # _fits is True for a method without a dense size
    raise ValueError(
        f"{engine}: Aer's {method} method on {num_active} active qubits needs {_gib(per)}, more "
        f"than the {_gib(memory_budget())} this machine allows (half its memory); "
        f"alternatives: Hamming-weight-1 circuits (a unary loader and RBS/FBS gates), and "
        f"circuits whose two-qubit gates act only on neighbours of the line of their qubits "
        f"with a bond dimension provably at most {MPS_MAX_BOND} (mps_bond_bound), run as "
        f"matrix-product states automatically; another circuit can be sampled with "
        f"sampler=target_sampler(target, method='matrix_product_state'); the unary engine computes "
        f"RBS circuits exactly at any width; or use fewer qubits")


def aer_options(num_active: int, shots: int, noisy: bool, hamming_weight: int | None = None,
                rows: int = 1) -> dict:
    """Aer options for a circuit on ``num_active`` qubits sampled ``shots`` times (see module).

    Parameters
    ----------
    num_active : int
        Active qubits (:func:`active_qubits`).
    shots : int
        Shots per parameter row.
    noisy : bool
        Whether the simulator carries a (non-ideal) noise model.
    hamming_weight : int or None
        The fixed Hamming weight of the circuit's ideal outcomes when known: weight 1 runs as
        ``matrix_product_state`` from :data:`MPS_FROM_QUBITS` active qubits.
    rows : int
        Parameter rows of the call (trajectories per call are ``rows * shots``).

    Returns
    -------
    dict
        ``AerSimulator`` options, ``method`` included.

    Examples
    --------
    >>> aer_options(6, 1000, noisy=True)["method"]
    'density_matrix'
    >>> aer_options(10, 100, noisy=True)["method"]
    'statevector'
    >>> aer_options(6, 1000, noisy=False)["method"]
    'automatic'
    """
    a, s, r = int(num_active), int(shots), int(rows)
    if a < 0 or s < 1 or r < 1:
        raise ValueError(f"num_active must be >= 0, shots and rows >= 1, got {num_active}, "
                         f"{shots}, {rows}")
    options = {"runtime_parameter_bind_enable": True, "shot_branching_enable": False}
    if hamming_weight == 1 and a >= MPS_FROM_QUBITS:
        return {**options, "method": "matrix_product_state", "max_parallel_threads": 1}
    if not noisy:
        return {**options, "method": "automatic",
                "max_parallel_threads": 1 if a < _PARALLEL_STATE_QUBITS else 0}
    if a <= DENSITY_MATRIX_MAX_QUBITS and s >= density_matrix_from(a):
        return {**options, "method": "density_matrix", "max_parallel_threads": 1}
    large = a >= _PARALLEL_STATE_QUBITS or (a >= _PARALLEL_SHOT_QUBITS
                                            and r * s >= PARALLEL_TRAJECTORIES)
    if not large or (LOAD_AWARE and not idle_core()):
        return {**options, "method": "statevector", "max_parallel_threads": 1}
    return {**options, "method": "statevector", "max_parallel_threads": 0,
            "max_parallel_shots": 0}


def aer_seed(seed: int | None) -> int | None:
    """The ``seed_simulator`` qiskit-aer gets for a user's integer ``seed``: a hash of it.

    Aer seeds shot ``i`` of a trajectory run (noisy statevector or MPS) with
    ``seed_simulator + i``, so runs seeded ``s`` and ``s + 1`` would draw the same shots shifted
    by one: five "independent" seeds 0..4 of an experiment would be one sample. Hashed seeds
    (:class:`numpy.random.SeedSequence`) lie far apart: two of them share a shot with
    probability about ``2 * shots / 2**31``.

    Parameters
    ----------
    seed : int or None
        A checked integer seed (:func:`~qdensity.validation.seed_int`); None stays None
        (Aer draws its own).

    Returns
    -------
    int or None
        In ``[0, 2**31 - 1]``; the same for the same ``seed``.

    Examples
    --------
    Neighbouring seeds land far apart, and the same seed gives the same value:

    >>> abs(aer_seed(1) - aer_seed(0)) > 1000, aer_seed(0) == aer_seed(0), aer_seed(None)
    (True, True, None)
    """
    if seed is None:
        return None
    state = np.random.SeedSequence([int(seed) % 2**63, 0xAE5]).generate_state(1, np.uint32)
    return int(state[0] >> 1)

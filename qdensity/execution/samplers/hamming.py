"""An exact sampler for Hamming-weight-preserving circuits, in the subspace's own dimension.

A circuit that starts from ``|0...0>``, sets ``k`` qubits with X gates and then applies only
gates that commute with the number operator (RBS, FBS, ``XXPlusYY``, phases, RZ, CZ, SWAP, ...)
keeps its state in the Hamming-weight-``k`` subspace, of dimension ``C(n, k)``: ``n`` for the
paper's unary circuits (Methods, "Hamming weight preserving QNNs"; Supp. D eq. 8), ``C(n, 2)``
for the matrix loader's two registers. :class:`HammingWeightSampler` computes that state
exactly for every parameter row, draws each row's shots from its probabilities (one
multinomial per row) and applies readout errors to the drawn bits as the classical channel
they are; it never allocates ``2**n`` amplitudes. Weight-1 circuits of RBS / FBS gates run on
the unary engine (:mod:`qdensity.execution.unary`, compiled Givens layers); any other
weight-preserving template is compiled once into index tables of its subspace
(:mod:`._hamming_subspace`) and its gates are applied to all rows at once.
"""

from __future__ import annotations

import math
import threading
import warnings
import weakref
from collections.abc import Iterable
from functools import partial
from typing import Any, NamedTuple

import numpy as np
from qiskit.circuit import QuantumCircuit
from qiskit.primitives import (
    BasePrimitiveJob,
    BaseSamplerV2,
    BitArray,
    DataBin,
    PrimitiveResult,
    SamplerPubResult,
)
from qiskit.primitives.containers.sampler_pub import SamplerPub
from qiskit.providers import JobStatus

from qdensity.execution.samplers._hamming_compile import (
    HammingTemplate,
    UnsupportedInstructionError,
    compile_template,
)
from qdensity.execution.samplers._hamming_draw import DeferredSamples, Draw
from qdensity.execution.samplers._hamming_program import _Compiled
from qdensity.execution.samplers._hamming_readout import ReadoutChannel, readout_channel
from qdensity.validation import (
    MAX_SHOTS,
    Interval,
    Seed,
    SeedLike,
    Unchecked,
    check_positive_int,
    validates,
)

__all__ = ["HammingWeightSampler", "DeferredSamples", "UnsupportedInstructionError",
           "MAX_DIMENSION", "NO_REGISTERS_WARNING"]

#: Largest subspace (amplitudes per row) the sampler computes: ``2**26`` (1 GiB complex).
MAX_DIMENSION = 2**26
#: The warning of a PUB whose circuit has no classical register (qiskit's samplers' own words).
NO_REGISTERS_WARNING = ("One of your circuits has no output classical registers and so the "
                        "result will be empty. Did you mean to add measurement instructions?")
#: Compiled templates kept (oldest dropped first).
_CACHE_TEMPLATES = 4096


class _DoneJob(BasePrimitiveJob):
    """A job whose result was computed when it was submitted."""

    def __init__(self, result: PrimitiveResult):
        super().__init__(job_id=f"hamming-{id(result):x}")
        self._result = result

    def result(self) -> PrimitiveResult:
        return self._result

    def status(self) -> JobStatus:
        return JobStatus.DONE

    def done(self) -> bool:
        return True

    def running(self) -> bool:
        return False

    def cancelled(self) -> bool:
        return False

    def in_final_state(self) -> bool:
        return True

    def cancel(self) -> None:
        return None


class ProgramItem(NamedTuple):
    """A precompiled job for :meth:`HammingWeightSampler.defer_programs`: its program, its
    rows ``(rows, P)`` in the program's parameter order (an array, or a
    :class:`~qdensity.execution._lazy_jobs.SharedRows` placed only when drawn), and its shots
    per row."""

    program: Any
    values: Any
    shots: int


def _values_of(bindings, params: tuple) -> np.ndarray:
    """A PUB's parameter rows (rows, P) in the template's parameter order (``params``:
    ``circuit.parameters``, read once at compile time)."""
    rows = int(np.prod(bindings.shape, dtype=int))
    if not params:
        return np.zeros((rows, 0))
    return bindings.as_array(list(params)).reshape(rows, len(params))


class _TemplateCache:
    """Compiled templates by circuit, each kept while its circuit lives (a weak reference:
    plans rebuilt every training step would otherwise keep every old circuit alive), at most
    :data:`_CACHE_TEMPLATES` (oldest dropped first).

    A cache, not state: it pickles and deep-copies as an empty cache (rebuilt on use), so a
    sampler never pickles a weak reference nor iterates a dict that a weak-reference callback
    (any garbage collection, in any thread) may change while it is copied. Every change goes
    through single dict operations under a re-entrant lock (a callback that fires inside a
    locked section, in the same thread, only drops an entry).
    """

    __slots__ = ("_entries", "_lock", "__weakref__")

    def __init__(self) -> None:
        self._entries: dict[int, tuple[weakref.ref, _Compiled]] = {}
        self._lock = threading.RLock()

    def __reduce__(self):
        return (_TemplateCache, ())

    def __deepcopy__(self, memo) -> _TemplateCache:
        return _TemplateCache()

    def __len__(self) -> int:
        return len(self._entries)

    def get(self, circuit: QuantumCircuit) -> _Compiled | None:
        """The circuit's compiled template, or None."""
        hit = self._entries.get(id(circuit))
        if hit is not None and hit[0]() is circuit:
            return hit[1]
        return None

    def put(self, circuit: QuantumCircuit, compiled: _Compiled) -> None:
        """Keep ``compiled`` while ``circuit`` lives."""
        key = id(circuit)
        ref = weakref.ref(circuit, partial(_forget, weakref.ref(self), key))
        with self._lock:
            while len(self._entries) >= _CACHE_TEMPLATES:  # bounded: plans rebuilt per step
                try:
                    oldest = next(iter(self._entries))
                except (StopIteration, RuntimeError):  # emptied meanwhile
                    break
                self._entries.pop(oldest, None)
            self._entries[key] = (ref, compiled)

    def forget(self, key: int, ref: weakref.ref) -> None:
        """Drop entry ``key`` if it is still the one of ``ref`` (not a newer circuit's)."""
        with self._lock:
            hit = self._entries.get(key)
            if hit is not None and hit[0] is ref:
                self._entries.pop(key, None)


def _forget(cache_ref: weakref.ref, key: int, ref: weakref.ref) -> None:
    """A circuit is gone: drop its compiled template (the cache itself may be gone too)."""
    cache = cache_ref()
    if cache is not None:
        cache.forget(key, ref)


def _stream_for(seed: int, index: int) -> np.random.SeedSequence:
    """PUB ``index``'s stream under an integer ``seed``."""
    return np.random.SeedSequence([int(seed) % 2**63, 0x4A3, index])


def _rng_for(seed, index: int) -> np.random.Generator:
    if isinstance(seed, np.random.Generator):
        return seed
    return np.random.default_rng(_stream_for(seed, index))


@validates(
    default_shots=Interval(int, 1, MAX_SHOTS), seed=Seed(),
    readout_error=Unchecked("None, a probability, a (p(1|0), p(0|1)) pair, an (n, 2) array, "
                            "a NoiseModel or a target; read by readout_channel"),
    max_dimension=Interval(int, 1, 2**34),
)
class HammingWeightSampler(BaseSamplerV2):
    """A qiskit ``BaseSamplerV2`` for Hamming-weight-preserving circuits, exact in ``C(n, k)``.

    Each PUB's circuit must start from ``|0...0>``, set ``k`` qubits with X gates, apply only
    gates that commute with the number operator on their qubits (RBS, FBS, ``XXPlusYY``, P,
    RZ, RZZ, CZ, CP, CRZ, SWAP, iSWAP, S, T, Z, and any other gate judged by its matrix;
    composite gates such as loaders are followed through their definitions) and measure in the
    Z basis at the end; a final bit flip (X, Y, or any fixed one-qubit gate whose matrix is X
    up to phases) with nothing but its measurement after it is a relabelling, applied to that
    clbit of the drawn shots. The state after the gates lies in the weight-``k`` subspace
    (dimension ``D = C(n, k)``); the sampler computes it exactly for every parameter row, draws
    each row's shots from its ``D`` probabilities with one multinomial draw (then shuffles them
    into shot order), and flips the drawn bits with the readout channel. Results have
    qiskit-aer ``SamplerV2``'s shapes: one ``BitArray`` per classical register, of the PUB's
    parameter-array shape, ``num_shots`` shots each. As qiskit's samplers, :meth:`run` takes an
    iterable of PUBs (``run([circuit])``; a bare circuit is refused by qiskit's own coercion)
    and warns for a circuit without classical registers (whose result holds no data).

    Parameters
    ----------
    default_shots : int
        Shots of a PUB that does not say.
    seed : int, numpy.random.Generator or None
        An integer gives every ``run`` the same numbers (PUB ``i`` draws from a stream derived
        from ``(seed, i)``); a Generator is drawn from in turn; None: fresh entropy per run.
    readout_error : None, float, array_like, NoiseModel, HardwareTarget, BackendV2 or Target
        Readout errors applied to the drawn bits: a probability ``p(1|0) = p(0|1)`` for every
        qubit; a pair ``(p(1|0), p(0|1))`` for every qubit; an array of shape
        ``(num_qubits, 2)`` with one pair per qubit; a qiskit-aer ``NoiseModel`` holding only
        readout errors; a ``HardwareTarget`` (its noise model), a ``BackendV2`` or a
        ``Target`` (the ``measure`` instruction's calibrated error, symmetric, as qiskit-aer
        reads it). Gate noise is refused with a ``ValueError`` naming the instruction.
    max_dimension : int
        Largest subspace (amplitudes per row) accepted; a PUB beyond it is refused before
        anything is allocated (default :data:`MAX_DIMENSION`).

    Notes
    -----
    Circuits act on their own qubit indices: readout errors are those of the circuit's qubits
    (for a device, of the physical qubits with the same index).

    Examples
    --------
    >>> from qiskit import QuantumCircuit
    >>> from qdensity.circuits.gates import RBSGate
    >>> qc = QuantumCircuit(3)
    >>> _ = qc.x(0)
    >>> _ = qc.append(RBSGate(0.4), [0, 1])
    >>> _ = qc.measure_all()
    >>> result = HammingWeightSampler(seed=1).run([qc], shots=100).result()
    >>> result[0].data.meas.num_shots, result[0].data.meas.shape
    (100, ())
    """

    def __init__(self, *, default_shots: int = 1024, seed: SeedLike = None,
                 readout_error=None, max_dimension: int = MAX_DIMENSION):
        self._default_shots = int(default_shots)
        if seed is not None and not isinstance(seed, np.random.Generator):
            seed = int(seed)
        self._seed = seed
        self._readout: ReadoutChannel | None = readout_channel(readout_error)
        self.max_dimension = int(max_dimension)
        self._compiled = _TemplateCache()  # rebuilt, never pickled

    @property
    def default_shots(self) -> int:
        """Shots of a PUB that does not say."""
        return self._default_shots

    @property
    def seed(self) -> int | np.random.Generator | None:
        """The seed given (int, Generator or None)."""
        return self._seed

    def with_seed(self, seed: SeedLike) -> HammingWeightSampler:
        """The same sampler (settings, readout channel and compiled templates) drawing from
        ``seed`` (the reseeding protocol of :mod:`qdensity.execution.samplers.reseed`).

        Parameters
        ----------
        seed : int, numpy.random.Generator or None

        Returns
        -------
        HammingWeightSampler
        """
        out = HammingWeightSampler(default_shots=self._default_shots, seed=seed,
                                   readout_error=self._readout,
                                   max_dimension=self.max_dimension)
        out._compiled = self._compiled
        return out

    @property
    def readout(self) -> ReadoutChannel | None:
        """The readout channel applied to the drawn bits (None: none)."""
        return self._readout

    def compile(self, circuit: QuantumCircuit, label: str | None = None) -> HammingTemplate:
        """Check and compile ``circuit`` (kept for later runs of the same object).

        Raises
        ------
        ValueError
            A gate outside the sampler's scope (named, with the alternative), or a subspace
            larger than ``max_dimension``.
        """
        return self._compile(circuit, label).template

    def _compile(self, circuit: QuantumCircuit, label: str | None = None) -> _Compiled:
        hit = self._compiled.get(circuit)
        if hit is not None:
            return hit
        template = compile_template(circuit, label)
        n, k = template.num_qubits, template.weight
        dim = math.comb(n, k)
        if dim > self.max_dimension:
            raise ValueError(
                f"HammingWeightSampler cannot sample {template.name!r}: its weight-{k} subspace "
                f"of {n} qubits has C({n}, {k}) = {dim} states, more than max_dimension = "
                f"{self.max_dimension}; use fewer qubits or a smaller Hamming weight")
        compiled = _Compiled(template)
        self._compiled.put(circuit, compiled)
        return compiled

    def run(self, pubs: Iterable, *, shots: int | None = None) -> BasePrimitiveJob:
        """Sample PUBs ``(circuit, parameter_values, shots)``; see the class.

        Raises
        ------
        UnsupportedInstructionError
            A circuit outside the sampler's scope, naming the instruction (a ``QiskitError``,
            as qiskit's samplers raise, and a ``ValueError``).
        ValueError
            Shots not a positive int, a parameter array of the wrong shape (naming the PUB), a
            subspace beyond ``max_dimension``, or a bare circuit for ``pubs``: all before
            anything is computed.
        TypeError
            Shots not an int.
        """
        coerced, compiled = self._checked(pubs, shots)
        seed = self._seed
        if seed is None:
            seed = np.random.default_rng()
        results = [self._run_pub(pub, comp, _rng_for(seed, i))
                   for i, (pub, comp) in enumerate(zip(coerced, compiled, strict=True))]
        return _DoneJob(PrimitiveResult(results, metadata={"version": 2}))

    def defer(self, pubs: Iterable, *, shots: int | None = None) -> list[DeferredSamples]:
        """Check and compile PUBs as :meth:`run` does, and draw each one's shots when read.

        Each PUB gets a random stream of its own (for an integer seed the one :meth:`run`
        gives PUB ``i``, so the shots are :meth:`run`'s; else a seed drawn in turn from the
        sampler's Generator or from fresh entropy), so its shots do not depend on the order or
        the number of reads: every read of a :class:`DeferredSamples` gives the same shots,
        drawn by the code that draws :meth:`run`'s, with the same law. Nothing but each
        PUB's parameter rows and compiled program is held until then (at ``n = 256`` a
        density gradient's 510 jobs of 16 rows x 1,000 shots would hold 0.26 GB of packed
        shots).

        Parameters
        ----------
        pubs : iterable of PUBs
            As :meth:`run`.
        shots : int, optional
            As :meth:`run`.

        Returns
        -------
        list of DeferredSamples
            One per PUB, in order.

        Raises
        ------
        ValueError, TypeError
            As :meth:`run`, before anything is drawn.
        """
        coerced, compiled = self._checked(pubs, shots)
        # the rows read on each draw from the PUB's own bindings (no reordered copy held)
        return self._deferred([(comp, partial(_values_of, pub.parameter_values,
                                              comp.template.parameters),
                                pub.parameter_values.shape, pub.shots)
                               for pub, comp in zip(coerced, compiled, strict=True)])

    def defer_programs(self, items: list) -> list[DeferredSamples]:
        """:meth:`defer` of PUBs and precompiled jobs together: each item a PUB, or a
        :class:`ProgramItem` (a job's :class:`~qdensity.execution._lazy_jobs.UnaryProgram`,
        its rows in the program's parameter order and its shots), sampled without a circuit.
        Item ``i`` draws from the stream :meth:`defer` gives PUB ``i``: a program draws the
        shots its circuit would."""
        at = [i for i, item in enumerate(items) if not isinstance(item, ProgramItem)]
        coerced, compiled = self._checked([items[i] for i in at], None)
        entries: list = [None] * len(items)
        for i, pub, comp in zip(at, coerced, compiled, strict=True):
            entries[i] = (comp, partial(_values_of, pub.parameter_values,
                                        comp.template.parameters),
                          pub.parameter_values.shape, pub.shots)
        from qdensity.execution._lazy_jobs import SharedRows  # (it imports this package)

        for i, item in enumerate(items):
            if entries[i] is None:  # SharedRows are placed when drawn (Draw calls full)
                values = (item.values.full if isinstance(item.values, SharedRows)
                          else np.asarray(item.values, dtype=float))
                entries[i] = (_Compiled.from_program(item.program), values,
                              item.values.shape[:1], check_positive_int(item.shots, "shots"))
        return self._deferred(entries)

    def _deferred(self, entries: list) -> list[DeferredSamples]:
        """One :class:`DeferredSamples` per ``(compiled, values, shape, shots)``, each from
        its own stream (see :meth:`defer`)."""
        seed = self._seed
        if seed is None:
            seed = np.random.default_rng()
        out = []
        for i, (comp, values, shape, shots) in enumerate(entries):
            # an integer seed: run's stream for PUB i itself (the same shots as run's)
            stream = (np.random.SeedSequence(int(seed.integers(2**63)))
                      if isinstance(seed, np.random.Generator) else _stream_for(seed, i))
            rows = int(np.prod(shape, dtype=int))
            out.append(DeferredSamples(Draw(comp, values, rows, shots, self._readout),
                                       stream, shape))
        return out

    def _checked(self, pubs, shots) -> tuple[list[SamplerPub], list[_Compiled]]:
        """The PUBs coerced and compiled, every one checked (see :meth:`run`)."""
        if shots is None:
            shots = self._default_shots
        else:
            shots = check_positive_int(shots, "shots")
        # as qiskit's samplers: ``pubs`` is iterated as given (a bare circuit is refused by
        # SamplerPub.coerce, naming the fix), and a circuit without classical registers warns
        coerced = []
        for i, pub in enumerate(pubs):
            if isinstance(pub, tuple) and len(pub) == 3 and pub[2] is not None:
                check_positive_int(pub[2], f"shots of pub {i}")
            try:
                coerced.append(SamplerPub.coerce(pub, shots))
            except (ValueError, TypeError) as exc:
                raise type(exc)(f"pub {i}: {exc}") from exc
        if any(len(pub.circuit.cregs) == 0 for pub in coerced):
            warnings.warn(NO_REGISTERS_WARNING, UserWarning, stacklevel=3)
        compiled = []
        for i, pub in enumerate(coerced):
            try:
                compiled.append(self._compile(pub.circuit))
            except UnsupportedInstructionError as exc:
                raise UnsupportedInstructionError(f"pub {i}: {exc}") from exc
            except ValueError as exc:
                raise ValueError(f"pub {i}: {exc}") from exc
            p = len(compiled[-1].template.parameters)
            held = pub.parameter_values.num_parameters
            if held != p:
                raise ValueError(f"pub {i}: parameter values hold {held} parameters per row, "
                                 f"the circuit has {p}")
        return coerced, compiled

    def _run_pub(self, pub: SamplerPub, comp: _Compiled, rng: np.random.Generator
                 ) -> SamplerPubResult:
        circuit, shots, shape = pub.circuit, pub.shots, pub.parameter_values.shape
        template = comp.template
        values = _values_of(pub.parameter_values, template.parameters)
        draw = Draw(comp, values, values.shape[0], shots, self._readout)
        packed, nclbits, nbytes = draw.packed(rng), draw.num_clbits, draw.num_bytes
        data = {}
        cregs = circuit.cregs  # a list built on each read of the property
        # clbit indices from a dict of our own: find_bit would keep one per circuit
        index = {b: i for i, b in enumerate(circuit.clbits)}
        whole = [index[b] for b in cregs[0]] if len(cregs) == 1 else None
        if whole == list(range(nclbits)):  # one register of every clbit, in order
            arr = packed[:, ::-1].reshape(shape + (shots, nbytes))
            data[cregs[0].name] = BitArray(np.ascontiguousarray(arr), nclbits)
        else:
            bits = np.unpackbits(packed, axis=-1, bitorder="little")[:, :nclbits].astype(bool)
            for creg in cregs:
                idx = [index[b] for b in creg]
                arr = bits[:, idx].reshape(shape + (shots, len(idx)))
                # BitArray bytes are big-endian: clbit 0 is the lowest bit of the last byte
                out = np.packbits(arr, axis=-1, bitorder="little")[..., ::-1]
                data[creg.name] = BitArray(np.ascontiguousarray(out), len(idx))
        meta = {"shots": shots, "circuit_metadata": circuit.metadata,
                "simulator_metadata": {"sampler": "hamming_weight",
                                       "hamming_weight": template.weight,
                                       "dimension": math.comb(template.num_qubits,
                                                              template.weight),
                                       "engine": "unary" if comp.unary is not None
                                       else "subspace",
                                       "readout_error": self._readout is not None}}
        return SamplerPubResult(DataBin(**data, shape=shape), metadata=meta)

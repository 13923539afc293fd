"""The sampler engine: honest shots through any ``BaseSamplerV2``.

:class:`SamplerEngine` runs a plan's jobs through qiskit-aer's sampler by default, or a
hardware provider's primitive unchanged: one PUB per template with a parameter array, never
one job per row; each template is transpiled once and reused; every run is written to a
:class:`ShotLedger`. It keeps the measured bits (``JobResult.bits``, ``(rows, shots,
num_clbits)``): estimates come from parities and outcomes, memory ``O(rows x shots)``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from qiskit.circuit import QuantumCircuit
from qiskit.primitives import BaseSamplerV2

from qdensity.execution._compile import (
    AerTranspiler,
    MarkedTranspiler,
    TargetTranspiler,
    TranspileCache,
    _columns_for,
)
from qdensity.execution.plans import CircuitJob, JobResult
from qdensity.execution.sampler._correction import ReadoutCorrection
from qdensity.execution.sampler._jobs import PendingJob, assemble, sample_pending
from qdensity.execution.sampler._packed_result import bitarray_to_bits, bitarray_to_probabilities
from qdensity.execution.samplers._hamming_readout import readout_channel
from qdensity.execution.samplers.aer import sampler_method
from qdensity.execution.samplers.hamming import HammingWeightSampler, ProgramItem
from qdensity.execution.samplers.reseed import check_reseedable, reseeded
from qdensity.execution.samplers.target import engine_sampler
from qdensity.hardware._device import check_for_device, check_width, device_of
from qdensity.hardware.aer_sampling import HAMMING_WEIGHT_KEY, active_qubits, check_memory
from qdensity.hardware.mitigation import MITIGATIONS, POSTSELECTIONS
from qdensity.hardware.targets import as_target
from qdensity.progress import progress_bar, wait_for
from qdensity.validation import (
    MAX_SHOTS,
    CallableC,
    Instance,
    Interval,
    Options,
    Seed,
    SeedLike,
    SequenceOf,
    TargetLike,
    check_positive_int,
    check_sequence_of,
    check_type,
    seed_int,
    validates,
)

__all__ = [
    "SamplerEngine", "ShotLedger", "LedgerEntry", "bitarray_to_probabilities", "bitarray_to_bits",
]


def _hamming_stream(seed: int | None) -> np.random.Generator | None:
    """The Hamming-weight sampler's stream under the engine's ``seed``: a stream, not an int,
    so successive runs draw independent shots and an engine built with the same seed repeats
    the whole sequence."""
    if seed is None:
        return None
    return np.random.default_rng(np.random.SeedSequence([seed % 2**63, 0x4A5]))


@validates(label=Instance(str), circuits=Interval(int, 0), shots=Interval(int, 0),
           sampler=Instance(str))
@dataclass
class LedgerEntry:
    """One sampled job: what it was for, how many circuits (rows) and shots it spent, and
    which sampler drew them (``"hamming_weight"`` for :class:`HammingWeightSampler`, else the
    sampler's class name; empty when not recorded).

    Examples
    --------
    >>> from qdensity.execution.engines import LedgerEntry
    >>> LedgerEntry("forward", circuits=2, shots=-1)
    Traceback (most recent call last):
    ValueError: LedgerEntry: shots must be an int >= 0, got -1
    """

    label: str
    circuits: int
    shots: int
    sampler: str = ""


@validates(entries=SequenceOf(Instance(LedgerEntry), min_len=0))
@dataclass
class ShotLedger:
    """Running account of every sampled execution.

    Attributes
    ----------
    entries : list of LedgerEntry

    Examples
    --------
    >>> from qdensity.execution.engines import ShotLedger
    >>> ledger = ShotLedger(); ledger.record("grad[0]", 4, 400); ledger.record("grad[1]", 4, 400)
    >>> ledger.by_label(), ledger.total_shots  # labels grouped at their first "["
    ({'grad': (8, 800)}, 800)
    """

    entries: list[LedgerEntry] = field(default_factory=list)

    def record(self, label: str, circuits: int, shots: int, sampler: str = "") -> None:
        """Add an entry: ``circuits`` rows, ``shots`` in total over them (ints >= 0), drawn
        by ``sampler`` (a name)."""
        self.entries.append(LedgerEntry(check_type(label, "label", str, "a str"),
                                        check_positive_int(circuits, "circuits", minimum=0),
                                        check_positive_int(shots, "shots", minimum=0),
                                        check_type(sampler, "sampler", str, "a str")))

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


@validates(
    sampler=[Instance('qiskit.primitives:BaseSamplerV2'), None], target=[TargetLike(), None],
    transpiler=[CallableC('a callable QuantumCircuit -> QuantumCircuit'), None], seed=Seed(),
    ledger=[Instance(ShotLedger), None], default_shots=Interval(int, 1, MAX_SHOTS),
    optimization_level=Options((0, 1, 2, 3)), progress=Instance((bool, np.bool_), 'bool'),
    mitigation=[Options(MITIGATIONS), None], postselect=[Options(POSTSELECTIONS), None],
    calibration_shots=Interval(int, 1, MAX_SHOTS),
    hamming_weight=Options(("auto", "never", "always")),
)
class SamplerEngine:
    """Shots through a ``BaseSamplerV2``, one PUB per template, transpiled once.

    Parameters
    ----------
    sampler : BaseSamplerV2, optional
        Any V2 sampler (a hardware provider's included). Default: qiskit-aer's, seeded with
        ``seed``, choosing Aer's method per PUB
        (:class:`~qdensity.execution.samplers.aer.AdaptiveSampler`: matrix-product states for
        wide Hamming-weight-1 circuits; a PUB whose state would not fit in memory is refused
        before Aer allocates it), noiseless unless a ``target`` is given. Templates that keep
        a fixed Hamming weight are sampled exactly in their subspace instead (see
        ``hamming_weight``).
    target : HardwareTarget, str, os.PathLike, BackendV2 or qiskit.transpiler.Target, optional
        Where circuits are transpiled and, when ``sampler`` is None, whose (noisy) simulator
        samples: anything :func:`~qdensity.hardware.targets.get_target` accepts (a fake or real
        backend, ``AerSimulator.from_backend(...)``, a ``Target``, a snapshot file, a name;
        a name without a size gets the device's, so pass a ``HardwareTarget`` for sized ones).
        A template wider than the device is refused before transpiling, naming both widths.
    transpiler : callable, optional
        ``QuantumCircuit -> QuantumCircuit``; overrides ``target``'s transpilation. With neither,
        circuits are transpiled for ``AerSimulator``.
    seed : int or numpy.random.Generator, optional
        Seeds the default sampler and the transpiler so runs repeat exactly.
    ledger : ShotLedger, optional
        Written on every run; a fresh one is made if not given.
    default_shots : int
        Shots per row for jobs that do not say (exact jobs are sampled with this many).
    optimization_level : int
        Of the transpiler, 0 to 3.
    progress : bool
        On a terminal, a run that lasts longer than :attr:`progress_delay` seconds shows one
        bar per phase: ``transpile`` (templates) and ``sample`` (circuits, shots in the
        postfix). The sampler gets one call, so the ``sample`` bar's clock runs while it waits
        and the bar fills when the call returns. False (or no terminal): silent.
    mitigation : {"m3"} or None
        Readout-error mitigation of every job (mthree's M3, calibrated on ``target``'s
        simulator or the provider sampler's backend; calibration shots go on the ledger as
        ``"readout calibration"``, once per physical qubit).
    postselect : {"hamming_weight"} or None
        Keep only the shots whose Hamming weight is the one the ideal circuit keeps (read off
        its gates: X gates on ``|0...0>`` then Hamming-weight-preserving gates, e.g. a unary
        loader and RBS/FBS sub-unitaries); other readouts are refused with a ``ValueError``.
    calibration_shots : int
        Shots per M3 calibration circuit.
    hamming_weight : {"auto", "never", "always"}
        Whether templates that keep a fixed Hamming weight (X gates on ``|0...0>``, then
        weight-preserving gates such as a unary loader and RBS / FBS sub-unitaries, measured in
        the Z basis) are sampled by :class:`~.hamming.HammingWeightSampler`,
        exactly in their ``C(n, k)``-dimensional subspace, instead of transpiled and run on Aer.
        ``"auto"`` (default): wherever that is exact, i.e. with the engine's own sampler (no
        ``sampler`` given), a target that is noiseless or whose noise is readout errors only
        (applied to the drawn bits, of the qubits with the circuit's own indices), and no
        ``mitigation``; other templates go to Aer. ``"always"``: every template, refusing one
        outside its scope with a ``ValueError``. ``"never"``: Aer (or ``sampler``) only. The
        choice is recorded per job in the ledger (``LedgerEntry.sampler``). Its shots come from
        one stream seeded by ``seed``: an engine built with the same seed repeats the same
        sequence of runs exactly, and successive runs draw independent shots.

    Notes
    -----
    With ``mitigation`` or ``postselect`` every result carries per-shot weights
    (``JobResult.weights``, mean 1 per row) so that every plan the engine runs (expectations,
    unary probabilities, gradient plans, schedulers) estimates ``sum_b q(b) f(b)`` over the
    corrected distribution ``q``. Standard errors include the mitigation's own uncertainty:
    with ``mitigation`` they are the delta method over the row's shots and the calibration's
    shots (``JobResult.readout``); with post-selection alone, those of ``kappa N`` shots
    (``kappa`` the kept fraction) with the variance taken over ``q``
    (:func:`~qdensity.execution.intervals.shot_mean`). The delta method is exact for
    mthree's solve on a row's observed outcomes (its reduced matrix: correction distance 3,
    columns renormalised) up to 2048 distinct outcomes per row; above, the error is that of
    ``N_eff = kappa N / M`` shots (``M`` mthree's overhead), conservative where measured.
    M3 corrects on the observed outcomes only: where many outcomes go unseen (wide registers,
    few shots) it keeps a bias that no error bar from the row's own shots carries (measured:
    0.6-0.9 of a standard error at 14 qubits and 4,000 shots, ``bench_mitigation_errors.py``).

    An engine pickles with its target, sampler and settings (standard ``pickle``); an
    unpickled engine with ``mitigation`` calibrates again on first use.

    Examples
    --------
    A loader then an RBS keep Hamming weight 1: sampled exactly in that subspace, not on Aer.

    >>> from qiskit import QuantumCircuit
    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.execution.engines import SamplerEngine
    >>> from qdensity.execution.plans import probabilities_plan
    >>> qc = QuantumCircuit(2); _ = qc.x(0); qc = qc.compose(round_robin(2))
    >>> engine = SamplerEngine(seed=7, progress=False)
    >>> result = probabilities_plan(qc, [[0.3], [1.2]], shots=100).run(engine)
    >>> result.bits_shape, set(result.bits.sum(axis=2).ravel().tolist()), engine.ledger.entries
    ((2, 100, 2), {1}, [LedgerEntry(label='probabilities', circuits=2, shots=200,
                                    sampler='hamming_weight')])

    Passing a hardware provider's primitive instead of Aer's::

        engine = SamplerEngine(sampler=provider_sampler, transpiler=pass_manager.run)

    A device given as an object, with mitigation::

        engine = SamplerEngine(target=FakeManilaV2(), mitigation="m3",
                               postselect="hamming_weight", seed=1)
    """

    def __init__(
        self, sampler: BaseSamplerV2 | None = None, *, target=None,
        transpiler: Callable[[QuantumCircuit], QuantumCircuit] | None = None,
        seed: SeedLike = None, ledger: ShotLedger | None = None, default_shots: int = 1024,
        optimization_level: int = 1, progress: bool = True, mitigation: str | None = None,
        postselect: str | None = None, calibration_shots: int = 4000, hamming_weight: str = "auto",
    ):
        if hamming_weight == "always" and mitigation is not None:
            raise ValueError(f"hamming_weight='always' cannot be combined with mitigation="
                             f"{mitigation!r} (M3 calibrates the transpiled circuit's physical "
                             f"qubits on Aer); use hamming_weight='auto' or 'never'")
        own_sampler = sampler is None
        seed = seed_int(seed)
        if target is not None:
            target = as_target(target, seed=0 if seed is None else seed)
        if sampler is None:
            sampler = engine_sampler(target, seed)
        else:
            check_reseedable(sampler)
        self.sampler = sampler
        self.target = target
        self._device = device_of(sampler)  # a provider's backend: circuits are checked against it
        if transpiler is None:
            transpiler = (TargetTranspiler(target, optimization_level, seed)
                          if target is not None else AerTranspiler(optimization_level, seed))
        self._transpiler = MarkedTranspiler(transpiler)
        self._cache = TranspileCache(self._transpiler)  # rebuilt, never pickled
        self.ledger = ledger if ledger is not None else ShotLedger()
        self.default_shots = int(default_shots)
        self.progress = bool(progress)
        self.hamming_weight = hamming_weight
        self._seed = seed
        self._own_sampler = own_sampler
        self._hamming_sampler: HammingWeightSampler | None = None  # first use: reads the noise
        self._hamming_why: str | None = None
        self._correction = None
        if mitigation is not None or postselect is not None:
            self._correction = ReadoutCorrection(
                mitigation, postselect, target if target is not None else self._device,
                calibration_shots, seed)

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        del state["_cache"]  # a cache: rebuilt on use, not pickled
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._cache = TranspileCache(self._transpiler)

    def with_seed(self, seed: SeedLike) -> SamplerEngine:
        """The same engine drawing from ``seed``: same sampler settings, target, transpiled
        templates, readout calibration and ledger (its shots are counted here too), with the
        sampler and the Hamming-weight stream reseeded (the reseeding protocol of
        :mod:`qdensity.execution.samplers.reseed`). An estimator fitted with a sampler engine
        draws from ``engine.with_seed(...)`` seeded by its own ``seed``, so a refit repeats.

        Parameters
        ----------
        seed : int or numpy.random.Generator

        Returns
        -------
        SamplerEngine
            The engine itself when its sampler is a provider's without a seed (its shots
            cannot repeat).
        """
        seed = seed_int(seed)
        if seed is None:
            raise ValueError("seed must be an int or a numpy.random.Generator, got None")
        if self._own_sampler:
            sampler = engine_sampler(self.target, seed)
        else:
            sampler = reseeded(self.sampler, seed)
            if sampler is None:
                return self
        hamming = (None if self._hamming_sampler is None  # its compiled templates are kept
                   else self._hamming_sampler.with_seed(_hamming_stream(seed)))
        out = object.__new__(type(self))
        out.__dict__.update(self.__dict__)  # shares the ledger, the cache and the correction
        out._adopt(sampler, seed, hamming)
        return out

    def _adopt(self, sampler, seed: int, hamming: HammingWeightSampler | None) -> None:
        """Take ``sampler``, ``seed`` and the Hamming-weight sampler (:meth:`with_seed`)."""
        self.sampler, self._seed, self._hamming_sampler = sampler, seed, hamming

    @property
    def seed(self) -> int | None:
        """The engine's seed (an int, or None: fresh entropy)."""
        return self._seed

    @property
    def mitigation(self) -> str | None:
        """The readout mitigation applied to every job (None: raw counts)."""
        return None if self._correction is None else self._correction.mitigation

    @property
    def postselect(self) -> str | None:
        """The post-selection applied to every job (None: every shot kept)."""
        return None if self._correction is None else self._correction.postselect

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

    def _check_plain_aer(self, compiled: QuantumCircuit) -> None:
        """A fixed-method Aer sampler (not adaptive): refuse a state that would not fit."""
        method = sampler_method(self.sampler)
        if method is not None:
            check_memory(active_qubits(compiled), method, "SamplerEngine (Aer SamplerV2)")

    def _hamming(self) -> HammingWeightSampler | None:
        """The engine's Hamming-weight sampler, or None where it would not be exact."""
        if self.hamming_weight == "never":
            return None
        if self._hamming_sampler is None and self._hamming_why is None:
            why = None
            if self.hamming_weight == "auto" and not self._own_sampler:
                why = "a sampler was given"
            elif self.hamming_weight == "auto" and self.mitigation is not None:
                why = "mitigation"
            if why is None:
                try:
                    readout = readout_channel(self.target)
                except ValueError:
                    if self.hamming_weight == "always":
                        raise
                    readout, why = None, "gate noise"
            if why is None:
                self._hamming_sampler = HammingWeightSampler(seed=_hamming_stream(self._seed),
                                                             readout_error=readout)
            self._hamming_why = why
        return self._hamming_sampler

    def _hamming_template(self, circuit: QuantumCircuit, label: str):
        """The template compiled for the Hamming-weight sampler, or None (go to Aer)."""
        sampler = self._hamming()
        if sampler is None:
            return None
        try:
            template = sampler.compile(circuit, label)
        except ValueError:
            if self.hamming_weight == "always":
                raise
            return None
        if template.flipped and self.postselect is not None:
            # a final bit flip moves outcomes off weight k: post-selection reads the circuit
            if self.hamming_weight == "always":
                raise ValueError(f"job {label!r} ends with a bit flip before a measurement: "
                                 f"its outcomes leave Hamming weight {template.weight}, which "
                                 f"postselect='hamming_weight' keeps; drop the flip or the "
                                 f"post-selection")
            return None
        return template

    def run(self, jobs: Sequence[CircuitJob]) -> list[JobResult]:
        """Sample every job: one PUB each, all in one sampler call (progress: see the class).

        On a seeded Aer ``SamplerV2`` PUBs of different shot counts go in one call per count,
        each with its own seed (:mod:`qdensity.execution.samplers.reseed`: Aer would give
        them the same random stream, correlating their shots).

        Every template is checked first, before anything is submitted: against the device
        when the sampler names one (a job wider than the device or holding an instruction it
        cannot run), against the memory an Aer simulation would need, and against the
        engine's mitigation and post-selection (a readout they cannot correct); each raises
        ``ValueError``. The ledger is written only once the sampler's results are back, so a
        failed job leaves it unchanged (readout calibrations excepted: they are spent).
        """
        jobs = check_sequence_of(jobs, "jobs", CircuitJob, "CircuitJob")
        pending = self._prepare(jobs)
        if not pending:
            return []
        rows = sum(p.job.rows for p in pending)
        with self._bar(rows, "sample", "circuit") as bar:
            bar.set_postfix(shots=sum(p.job.rows * p.shots for p in pending), refresh=False)
            raw = sample_pending(pending, self._hamming_sampler, self.sampler,
                                 lambda job: wait_for(job, bar))
            bar.update(rows)
        return assemble(pending, raw, self._correction, self.ledger, type(self.sampler).__name__)

    def _prepare(self, jobs: list[CircuitJob]) -> list[PendingJob]:
        """Check every job and build its PUB: the Hamming-weight sampler's where it is exact,
        else the transpiled template's (preparation: nothing is submitted)."""
        out: list[PendingJob] = []
        with self._bar(len(jobs), "transpile", "template") as bar:
            for job in jobs:
                label = job.label or job.circuit.name
                if self._device is not None:
                    check_width(job.circuit, self._device, label)
                if self.target is not None and job.num_qubits > self.target.num_qubits:
                    raise ValueError(
                        f"job {label!r} needs {job.num_qubits} qubits but target "
                        f"{self.target.name!r} has {self.target.num_qubits}; use a wider "
                        f"device or a smaller model")
                shots = job.shots if job.shots is not None else self.default_shots
                out.append(self._prepared_job(job, label, shots))
                bar.update()
        return out

    def _prepared_job(self, job: CircuitJob, label: str, shots: int) -> PendingJob:
        item = ProgramItem(getattr(job, "program", None), getattr(job, "held_rows", None), shots)
        if item.program is not None and self._correction is None and self._hamming() is not None:
            return PendingJob(job, label, shots, item, None, True)  # sampled without a circuit
        circuit = job.circuit  # read once: a LazyCircuitJob builds it on each read
        template = self._hamming_template(circuit, label)
        if template is not None:  # exact in the weight-k subspace: no transpilation, no Aer
            marker = None  # what the correction reads of a compiled circuit: its weight
            if self._correction is not None:
                marker = QuantumCircuit(metadata={HAMMING_WEIGHT_KEY: template.weight})
                self._correction.check(circuit, marker, label)
            pub = ((circuit, job.values, shots) if circuit.num_parameters
                   else (circuit, None, shots * job.rows))
            return PendingJob(job, label, shots, pub, marker, True)
        compiled = self._cache(circuit)
        if self._device is not None:
            check_for_device(compiled, self._device, label)
        self._check_plain_aer(compiled)
        if self._correction is not None:
            self._correction.check(circuit, compiled, label)
        if compiled.num_parameters:
            pub = (compiled, job.values[:, _columns_for(circuit, compiled)], shots)
        else:
            # Aer samples only one row of a parameter-free PUB with a (rows, 0) array:
            # sample rows * shots at once and split them into rows below.
            pub = (compiled, None, shots * job.rows)
        return PendingJob(job, label, shots, pub, compiled, False)

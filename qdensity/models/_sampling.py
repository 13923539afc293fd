"""Sampling a density QNN's output from shots (Supp. I): the body of :meth:`DensityQNN.sample`.

Train mode runs the randomised preparation (Fig. 1c, the budget split over the sub-unitaries
by a scheduler); eval mode measures the deterministic state (Fig. 1b) with every shot.

A mitigated or post-selected :class:`~qdensity.execution.engines.SamplerEngine` weights every
shot (``JobResult.weights``, mean 1 per row): the per-shot value ``h(b_s) w_s`` has the
corrected mean. With readout mitigation the schedulers get instead each shot's influence value
(``Linearisation.influence``: the corrected mean plus the shot's term of the delta method), whose
mean is the same and whose spread is the estimate's spread over the shots; the calibration's
share of the error, common to every sub-unitary, is added to the scheduler's standard error at
the end. Per-shot values range over the observable's range widened by :data:`WEIGHT_BOUND`;
a larger one is refused rather than clipped.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from qdensity.models.decompositions import trainable_parameters
from qdensity.validation import MAX_DENSE_ENTRIES, as_rng, check_target, check_type

__all__ = ["WEIGHT_BOUND", "shot_values", "corrected_range", "sample"]

#: Largest per-shot weight of a corrected run the schedulers accept.
WEIGHT_BOUND = 4.0


def corrected_range(lo: float, hi: float) -> tuple[float, float]:
    """The range of ``h(b) w`` for ``h`` in ``[lo, hi]`` and ``|w| <= WEIGHT_BOUND``."""
    bound = WEIGHT_BOUND * max(abs(lo), abs(hi))
    return -bound, bound


def shot_values(result, values: np.ndarray, shots: int, k: int) -> np.ndarray:
    """Per-shot values ``h(b_s)`` (times the shot weights of a corrected run, or a mitigated
    run's influence values) of one job's first row; exact probabilities are turned into
    ``shots`` values by rounding counts."""
    if result.bits is None:
        counts = np.rint(result.probabilities[0] * shots).astype(int)
        return values[np.repeat(np.arange(counts.size), counts)]
    return corrected_values(result, values[result.bits[0] @ (1 << np.arange(
        result.bits.shape[-1]))], float(np.abs(values).max()), k)


def corrected_values(result, out: np.ndarray, largest: float, k: int) -> np.ndarray:
    """Per-shot values ``out`` (shots,) of one job's first row, corrected as
    :func:`shot_values` says (``largest``: the largest ``|h|`` a shot can take)."""
    if result.weights is None:
        return out
    w = result.weights[0]
    lin = None if result.readout is None else result.readout[0]
    if lin is not None:
        psi = lin.influence(out, float(np.mean(out * w)))
        bound = WEIGHT_BOUND * largest
        if np.abs(psi).max() > bound:
            raise ValueError(f"a mitigated shot of sub-unitary {k} has influence "
                             f"{np.abs(psi).max():.3g} beyond {bound:.3g} ({WEIGHT_BOUND} x the "
                             f"observable's largest value); spend more shots")
        return psi
    if np.abs(w).max() > WEIGHT_BOUND:
        raise ValueError(f"a corrected shot of sub-unitary {k} has weight "
                         f"{np.abs(w).max():.3g} > {WEIGHT_BOUND} (a kept fraction or a "
                         f"mitigated frequency far below the raw one); spend more shots")
    return out * w


def _calibration_variance(parts: dict, alpha: np.ndarray) -> float:
    """Variance of ``sum_k alpha_k V_k`` from the calibration every sub-unitary shares:
    ``parts[k] = (linearisation, per-shot h, corrected mean)`` of its last job."""
    total: dict = {}
    for k, (lin, f, mean) in parts.items():
        for key, (dv, e, n) in lin.calibration_gradient(f, mean).items():
            acc = total.setdefault(key, [0.0, e, n])
            acc[0] += alpha[k] * float(dv)
    return float(sum(d**2 * e * (1 - e) / n for d, e, n in total.values()))


@dataclasses.dataclass
class _Call:
    """One :func:`sample` call, prepared: its checked arguments, the observable's values on
    the outcomes (None for unary readout) and range, and where its engines come from."""

    x: np.ndarray
    budget: int
    scheduler: str
    rng: np.random.Generator
    unary: bool
    values: np.ndarray | None
    lo: float
    hi: float
    engines: _CallEngines
    corrected: bool


class _CallEngines:
    """The engine of every phase of one call: the caller's, or one fresh engine (one readout
    calibration, its shots on the ledger once) whose sampler is reseeded from the call's
    stream for every later phase (independent shots), through the sampler's ``with_seed``."""

    def __init__(self, engine, target, rng, ledger, mitigation, postselect):
        self.engine, self.target, self.rng = engine, target, rng
        self.ledger = engine.ledger if engine is not None else ledger
        self.mitigation, self.postselect = mitigation, postselect
        self.fresh = None

    def __call__(self):
        from qdensity.execution.sampler.engine import SamplerEngine
        from qdensity.hardware.aer_sampling import aer_seed
        from qdensity.validation import seed_int

        if self.engine is not None:
            return self.engine
        if self.fresh is None:
            self.fresh = SamplerEngine(target=self.target, seed=self.rng, ledger=self.ledger,
                                       mitigation=self.mitigation, postselect=self.postselect)
        else:
            self.fresh.sampler = self.fresh.sampler.with_seed(aer_seed(seed_int(self.rng)))
        return self.fresh


def sample(model, x, budget: int, *, scheduler: str = "per_shot", engine=None, target=None,
           seed=None, mitigation: str | None = None, postselect: str | None = None,
           ledger=None):
    """Estimate ``f(x)`` from shots; see :meth:`DensityQNN.sample` (parameters and returns).

    Preparation (:func:`_prepare`: every check before any shot), then running and assembly
    by mode: the deterministic state (eval) or the randomised preparation (train).
    """
    call = _prepare(model, x, budget, scheduler, engine, target, seed, mitigation, postselect,
                    ledger)
    if not model.training:
        return _deterministic(model, call)
    if call.unary:
        return _randomised_unary(model, call.x, call.budget, call.scheduler, call.engines,
                                 call.rng, call.corrected)
    return _randomised(model, call)


def _prepare(model, x, budget, scheduler, engine, target, seed, mitigation, postselect,
             ledger) -> _Call:
    """Check every argument (before any shot) and read the observable's values."""
    from qdensity.execution.observables import diagonal_values
    from qdensity.execution.sampler.engine import SamplerEngine, ShotLedger
    from qdensity.validation import check_positive_int

    budget = check_positive_int(budget, "budget", maximum=MAX_DENSE_ENTRIES,
                                why="every shot's measured bits are held in memory")
    check_type(engine, "engine", SamplerEngine, "a SamplerEngine", allow_none=True)
    check_type(ledger, "ledger", ShotLedger, "a ShotLedger", allow_none=True)
    if engine is not None and ledger is not None:
        raise ValueError("ledger is for the fresh engines sample() makes; with engine=..., "
                         "read engine.ledger")
    check_target(target)
    if target is not None:  # one device for the whole call: every fresh engine samples it
        from qdensity.hardware.targets import as_target

        target = as_target(target, model.num_qubits, seed=seed if isinstance(seed, int) else 0)
    if engine is not None and (mitigation is not None or postselect is not None):
        raise ValueError("mitigation and postselect are options of the fresh engines "
                         "sample() makes; with engine=..., set them on that engine")
    if not isinstance(scheduler, str) or scheduler not in ("per_shot", "proportional",
                                                           "neyman"):
        raise ValueError(f"scheduler must be one of ('per_shot', 'proportional', 'neyman'), "
                         f"got {scheduler!r}")
    rng = as_rng(seed)
    if model.readout == "unary_amplitudes":
        raise ValueError("sample() cannot estimate readout='unary_amplitudes' (shots see "
                         "|y_j|^2, never the sign of y_j); build the model with "
                         "readout='unary_probabilities', or use predict() (exact)")
    if model.readout == "observable" and np.any(model.observable.paulis.x):
        raise ValueError("sample() needs a diagonal (I/Z) observable; rotate the measurement "
                         "basis into the sub-unitaries (qdensity.execution.plans."
                         "basis_rotation), or use readout='unary_probabilities'")
    unary = model.readout == "unary_probabilities"
    if unary and scheduler == "neyman":
        raise ValueError("scheduler='neyman' allocates shots for one scalar output; "
                         "readout='unary_probabilities' has one output per qubit: use "
                         "scheduler='per_shot' or 'proportional'")
    x = model._check_X(x, "x")
    if x.shape[0] != 1:
        raise ValueError(f"x must be one data point, got {x.shape[0]} rows")
    if unary:
        values, lo, hi = None, 0.0, 1.0
    else:
        values = diagonal_values(model.observable.paulis, np.real(model.observable.coeffs),
                                 model.num_qubits)
        lo, hi = float(values.min()), float(values.max())
    corrected = (mitigation is not None or postselect is not None
                 or (engine is not None
                     and (engine.mitigation is not None or engine.postselect is not None)))
    if engine is None and ledger is None:
        ledger = ShotLedger()
    engines = _CallEngines(engine, target, rng, ledger, mitigation, postselect)
    return _Call(x, budget, scheduler, rng, unary, values, lo, hi, engines, corrected)


def _deterministic(model, call: _Call):
    """Eval mode: the deterministic state (Fig. 1b) measured with every shot."""
    from qdensity.circuits.preparation import deterministic_circuit
    from qdensity.execution.intervals import wilson_standard_error
    from qdensity.execution.plans import CircuitJob, measured
    from qdensity.execution.schedulers import ScheduleResult

    x, budget, n = call.x, call.budget, model.num_qubits
    alpha = model.alpha(x)[0]
    subs = [c.assign_parameters(dict(zip(trainable_parameters(c), model._sub_theta(k, None),
                                         strict=True)))
            for k, c in enumerate(model.sub_unitaries)]
    loader = (model.encoding.circuit.assign_parameters(model.encoding.values(x)[0])
              if model.encoding is not None else None)
    circ = measured(deterministic_circuit(subs, alpha, loader=loader))
    res = call.engines().run([CircuitJob(circ, np.zeros((1, 0)), budget,
                                         "deterministic")])[0]
    K = model.num_subunitaries
    if call.unary:
        return _deterministic_unary(res, K, n, budget)
    assert call.values is not None  # set whenever the readout is not unary
    probs = res.probabilities[0].reshape(2**n, 2**K).sum(axis=1)  # trace out mix
    mean = float(probs @ call.values)
    var = float(probs @ call.values**2) - mean**2
    return ScheduleResult(name="deterministic", estimate=mean,
                          standard_error=float(wilson_standard_error(var, budget,
                                                                     call.hi - call.lo)),
                          allocation=np.array([budget]), per_subunitary=np.array([mean]),
                          shots_used=budget, pilot_allocation=None, info={})


def _randomised(model, call: _Call):
    """Train mode of an observable: the randomised preparation (Fig. 1c), the budget split
    over the sub-unitaries by the scheduler, each phase's jobs run as the scheduler asks."""
    from qdensity.execution.plans import CircuitJob, measured
    from qdensity.execution.schedulers import neyman, per_shot, proportional

    values, x = call.values, call.x
    assert values is not None  # set whenever the readout is not unary
    circuits = [measured(model.circuit(k)) for k in range(model.num_subunitaries)]
    rows = [model.rows(k, x) for k in range(model.num_subunitaries)]
    calibration: dict = {}

    def source(shots_per_k, rng_inner, phase: str = "main"):
        label = "pilot" if phase == "pilot" else "randomised"
        jobs = [CircuitJob(circuits[k], rows[k], int(s), f"{label}_k{k}")
                for k, s in enumerate(shots_per_k) if s > 0]
        results = iter(call.engines().run(jobs))
        out = []
        for s in shots_per_k:
            if s == 0:
                out.append(np.zeros(0))
                continue
            res = next(results)
            out.append(shot_values(res, values, s, len(out)))
            lin = None if res.readout is None else res.readout[0]
            if lin is not None:
                f = values[res.bits[0] @ (1 << np.arange(res.bits.shape[-1]))]
                calibration[len(out) - 1] = (lin, f, float(np.mean(f * res.weights[0])))
        return out

    lo, hi = corrected_range(call.lo, call.hi) if call.corrected else (call.lo, call.hi)
    runners = {"per_shot": per_shot, "proportional": proportional, "neyman": neyman}
    alpha = model.alpha(x)[0]
    res = runners[call.scheduler](alpha, call.budget, source, seed=call.rng,
                                  value_range=(lo, hi))
    if calibration:  # assembly: the calibration's share of the error, common to every k
        se = float(np.sqrt(res.standard_error**2 + _calibration_variance(calibration, alpha)))
        res = dataclasses.replace(res, standard_error=se)
    return res


def _deterministic_unary(res, K: int, n: int, budget: int):
    """Eval mode of a unary-probability model: the data register's unary frequencies."""
    from qdensity.execution.job_results import JobResult, unary_frequencies
    from qdensity.execution.schedulers import ScheduleResult

    if res.bits is not None:  # the data register is clbits K .. K + n - 1; mix is traced out
        data = JobResult(None, res.shots, res.job, bits=res.bits[..., K:], weights=res.weights,
                         effective_shots=res.effective_shots, readout=res.readout)
    else:
        probs = res.probabilities.reshape(-1, 2**n, 2**K).sum(axis=2)
        data = JobResult(probs, res.shots, res.job)
    p, _, se = unary_frequencies(data, return_std=True)
    return ScheduleResult(name="deterministic", estimate=p[0], standard_error=se[0],
                          allocation=np.array([budget]), per_subunitary=p, shots_used=budget,
                          pilot_allocation=None, info={"readout": "unary_probabilities"})


def _unary_hits(result, j: int, shots: int) -> np.ndarray:
    """Per-shot indicator of outcome ``e_j`` (only bit ``j`` set) of one job's first row."""
    if result.bits is None:
        count = int(np.rint(result.probabilities[0, 1 << j] * shots))
        return np.concatenate([np.ones(count), np.zeros(shots - count)])
    b = result.bits[0]
    return (b[:, j] & (b.sum(axis=-1) == 1)).astype(float)


def _randomised_unary(model, x, budget, scheduler, engine_for_call, rng, corrected: bool):
    """Train mode of a unary-probability model: the scheduler's allocation (one draw, shared
    by every output ``j``), its estimate and standard error of each ``p_j`` (Fig. 1c)."""
    from qdensity.execution.plans import CircuitJob, measured
    from qdensity.execution.schedulers import ScheduleResult, per_shot, proportional

    K, n = model.num_subunitaries, model.num_qubits
    circuits = [measured(model.circuit(k)) for k in range(K)]
    rows = [model.rows(k, x) for k in range(K)]
    runs: dict = {}  # allocation -> results, so every output j reads the same shots

    def results_for(shots_per_k):
        key = tuple(int(v) for v in shots_per_k)
        if key not in runs:
            jobs = [CircuitJob(circuits[k], rows[k], s, f"randomised_k{k}")
                    for k, s in enumerate(key) if s > 0]
            done = iter(engine_for_call().run(jobs))
            runs[key] = [next(done) if s > 0 else None for s in key]
        return key, runs[key]

    lo, hi = corrected_range(0.0, 1.0) if corrected else (0.0, 1.0)
    alpha = model.alpha(x)[0]
    runner = {"per_shot": per_shot, "proportional": proportional}[scheduler]
    draw = int(rng.integers(2**63))
    parts = []
    for j in range(n):
        calibration: dict = {}

        def source(shots_per_k, _rng=None, j=j, calibration=calibration):
            key, results = results_for(shots_per_k)
            out = []
            for k, (s, res) in enumerate(zip(key, results, strict=True)):
                if s == 0:
                    out.append(np.zeros(0))
                    continue
                h = _unary_hits(res, j, s)
                out.append(corrected_values(res, h, 1.0, k))
                lin = None if res.readout is None else res.readout[0]
                if lin is not None:
                    calibration[k] = (lin, h, float(np.mean(h * res.weights[0])))
            return out

        res = runner(alpha, budget, source, seed=draw, value_range=(lo, hi))
        if calibration:
            se = float(np.sqrt(res.standard_error**2 + _calibration_variance(calibration,
                                                                             alpha)))
            res = dataclasses.replace(res, standard_error=se)
        parts.append(res)
    first = parts[0]
    return ScheduleResult(name=first.name, estimate=np.array([r.estimate for r in parts]),
                          standard_error=np.array([r.standard_error for r in parts]),
                          allocation=first.allocation,
                          per_subunitary=np.stack([r.per_subunitary for r in parts], axis=1),
                          shots_used=first.shots_used, pilot_allocation=None,
                          info={"readout": "unary_probabilities"})

"""Sampling a density QNN's output from shots (Supp. I): the body of :meth:`DensityQNN.sample`.

Train mode runs the randomised preparation (Fig. 1c, the budget split over the sub-unitaries
by a scheduler); eval mode measures the deterministic state (Fig. 1b) with every shot.
"""

from __future__ import annotations

import numpy as np

from qdensity.models.decompositions import trainable_parameters
from qdensity.validation import MAX_DENSE_ENTRIES, as_rng, check_target, check_type


def sample(model, x, budget: int, *, scheduler: str = "per_shot", engine=None, target=None,
           seed=None):
    """Estimate ``f(x)`` from shots; see :meth:`DensityQNN.sample` (parameters and returns)."""
    from qdensity.execution.engines import SamplerEngine
    from qdensity.execution.intervals import wilson_standard_error
    from qdensity.execution.plans import CircuitJob, diagonal_values, measured
    from qdensity.execution.schedulers import ScheduleResult, neyman, per_shot, proportional
    from qdensity.validation import check_positive_int

    budget = check_positive_int(budget, "budget", maximum=MAX_DENSE_ENTRIES,
                                why="every shot's measured bits are held in memory")
    check_type(engine, "engine", SamplerEngine, "a SamplerEngine", allow_none=True)
    check_target(target)
    if not isinstance(scheduler, str) or scheduler not in ("per_shot", "proportional",
                                                           "neyman"):
        raise ValueError(f"scheduler must be one of ('per_shot', 'proportional', 'neyman'), "
                         f"got {scheduler!r}")
    rng = as_rng(seed)
    if model.readout != "observable" or np.any(model.observable.paulis.x):
        raise ValueError("sample() needs a diagonal (Z-type) observable readout")
    x = model._check_X(x, "x")
    if x.shape[0] != 1:
        raise ValueError(f"x must be one data point, got {x.shape[0]} rows")
    n = model.num_qubits
    values = diagonal_values(model.observable.paulis, np.real(model.observable.coeffs), n)
    lo, hi = float(values.min()), float(values.max())
    ledger = engine.ledger if engine is not None else None

    def engine_for_call():
        nonlocal ledger
        if engine is not None:
            return engine
        fresh = SamplerEngine(target=target, seed=rng, ledger=ledger)
        ledger = fresh.ledger
        return fresh

    if not model.training:
        from qdensity.circuits.preparation import deterministic_circuit

        alpha = model.alpha(x)[0]
        subs = [c.assign_parameters(dict(zip(trainable_parameters(c), model._sub_theta(k, None),
                                             strict=True)))
                for k, c in enumerate(model.sub_unitaries)]
        loader = (model.encoding.circuit.assign_parameters(model.encoding.values(x)[0])
                  if model.encoding is not None else None)
        circ = measured(deterministic_circuit(subs, alpha, loader=loader))
        res = engine_for_call().run([CircuitJob(circ, None, budget, "deterministic")])[0]
        K = model.num_subunitaries
        probs = res.probabilities[0].reshape(2**n, 2**K).sum(axis=1)  # trace out mix
        mean = float(probs @ values)
        var = float(probs @ values**2) - mean**2
        return ScheduleResult(name="deterministic", estimate=mean,
                              standard_error=float(wilson_standard_error(var, budget,
                                                                         hi - lo)),
                              allocation=np.array([budget]), per_subunitary=np.array([mean]),
                              shots_used=budget, pilot_allocation=None, info={})
    circuits = [measured(model.circuit(k)) for k in range(model.num_subunitaries)]
    rows = [model.rows(k, x) for k in range(model.num_subunitaries)]

    def source(shots_per_k, rng_inner, phase: str = "main"):
        label = "pilot" if phase == "pilot" else "randomised"
        jobs = [CircuitJob(circuits[k], rows[k], int(s), f"{label}_k{k}")
                for k, s in enumerate(shots_per_k) if s > 0]
        results = iter(engine_for_call().run(jobs))
        out = []
        for s in shots_per_k:
            if s == 0:
                out.append(np.zeros(0))
                continue
            counts = np.rint(next(results).probabilities[0] * s).astype(int)
            out.append(values[np.repeat(np.arange(counts.size), counts)])
        return out

    runners = {"per_shot": per_shot, "proportional": proportional, "neyman": neyman}
    alpha = model.alpha(x)[0]
    return runners[scheduler](alpha, budget, source, seed=rng, value_range=(lo, hi))

# ------------------------------------------------------------------ parameters I/O

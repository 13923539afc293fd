"""target_sampler: the Aer sampler of a hardware target, against exact probabilities and
independence bounds; its arguments checked before anything is built."""

from __future__ import annotations

import math

import numpy as np
import pytest
from qiskit import QuantumCircuit
from qiskit.primitives import BaseSamplerV2
from qiskit.quantum_info import Statevector

from qdensity.circuits.gates import RBSGate
from qdensity.execution.samplers import AdaptiveSampler, AerSampler, target_sampler
from qdensity.hardware.aer_sampling import FAST_SAMPLER_OPTIONS, aer_seed
from qdensity.hardware.targets import get_target


def test_rbs_native_sampler_matches_exact_probabilities():
    n = 3
    qc = QuantumCircuit(n)
    qc.x(0)
    qc.append(RBSGate(0.9), [0, 1])
    qc.append(RBSGate(-1.3), [1, 2])
    qc.append(RBSGate(0.4), [0, 2])
    exact = Statevector(qc).probabilities_dict()
    meas = qc.copy()
    meas.measure_all()
    tgt = get_target("rbs_native", n, noise=False)
    shots = 20000
    result = target_sampler(tgt, seed=4, shots=shots).run([tgt.transpile(meas)]).result()
    counts = result[0].data.meas.get_counts()
    for key in set(exact) | set(counts):
        p = exact.get(key, 0.0)
        se = math.sqrt(max(p * (1 - p), 1e-12) / shots)
        assert abs(counts.get(key, 0) / shots - p) <= 5 * se + 1e-9


def test_nearby_seeds_give_independent_noisy_trajectories():
    """Aer seeds shot i of a trajectory run with ``seed_simulator + i``: unhashed, seeds 8 and
    9 drew the same shots shifted by one (every one of 2000 agreed). Hashed, at every shift
    the fraction of equal outcomes is what two independent draws give, ``sum_x p(x)**2``."""
    tgt = get_target("heavy_hex", 4, seed=5)
    qc = QuantumCircuit(4)
    for q in range(4):
        qc.ry(0.4 + 0.5 * q, q)
    for q in range(3):
        qc.cx(q, q + 1)
    qc.measure_all()
    compiled = tgt.transpile(qc)
    shots = 2000
    runs = []
    for seed in (8, 9):
        sampler = target_sampler(tgt, seed=seed, method="statevector", shots=shots)
        runs.append(sampler.run([compiled]).result()[0].data.meas.array[:, 0])
    a, b = runs
    p = np.bincount(np.concatenate([a, b]), minlength=16) / (2 * shots)
    collide = float(np.sum(p**2))
    for shift in range(4):
        m = shots - shift
        agree = float(np.mean(a[shift:] == b[:m]))
        # Bernoulli(collide) mean of m pairs within 6 standard errors: false failure
        # < 4 x 2e-9 (normal approximation at m ~ 2000); 0.01 for collide's own estimate
        assert abs(agree - collide) <= 6 * np.sqrt(collide * (1 - collide) / m) + 0.01, shift


def test_sampler_is_reproducible_and_noisy():
    tgt = get_target("line", 3, seed=2)
    qc = QuantumCircuit(3)
    qc.h(0)
    qc.cx(0, 1)
    qc.cx(1, 2)
    qc.measure_all()
    tqc = tgt.transpile(qc)
    sampler = target_sampler(tgt, seed=21, shots=500)
    assert isinstance(sampler, BaseSamplerV2)  # a primitive on qiskit-aer's public SamplerV2
    first = sampler.run([tqc]).result()[0].data.meas
    again = target_sampler(tgt, seed=21, shots=500).run([tqc]).result()[0].data.meas
    other = target_sampler(tgt, seed=22, shots=500).run([tqc]).result()[0].data.meas
    assert first.num_shots == 500
    assert first.get_counts() == again.get_counts()
    assert first.get_counts() != other.get_counts()
    # GHZ under noise leaks outside {000, 111}; the ideal target never does
    noisy = target_sampler(tgt, seed=1, shots=4000).run([tqc]).result()[0].data.meas.get_counts()
    assert set(noisy) - {"000", "111"}
    ideal = get_target("ideal", 3)
    clean = target_sampler(ideal, seed=1, shots=4000).run([ideal.transpile(qc)]).result()[0]
    assert set(clean.data.meas.get_counts()) == {"000", "111"}


def test_target_sampler_kinds_seed_and_options():
    tgt = get_target("line", 3, seed=2)
    auto = target_sampler(tgt)
    assert isinstance(auto, AdaptiveSampler)
    assert auto.seed == aer_seed(2) and auto.default_shots == 1024  # the target's seed
    fixed = target_sampler(tgt, seed=5, shots=7, method="density_matrix",
                           options={"max_parallel_threads": 1})
    assert isinstance(fixed, AerSampler)
    assert fixed.seed == aer_seed(5) and fixed.default_shots == 7
    opts = fixed.simulator.options
    assert opts.method == "density_matrix" and opts.max_parallel_threads == 1
    assert opts.noise_model is tgt.noise_model
    for key, value in FAST_SAMPLER_OPTIONS.items():
        if key != "max_parallel_threads":
            assert getattr(opts, key) == value
    slow = target_sampler(tgt, method="statevector", fast=False).simulator.options
    assert slow.runtime_parameter_bind_enable is False


@pytest.mark.parametrize(("kwargs", "exc", "match"), [
    ({"shots": 0}, ValueError, "shots"),
    ({"shots": 1.5}, TypeError, "shots"),
    ({"method": "stabiliser"}, ValueError, "method"),
    ({"device": "TPU"}, ValueError, "device"),
    ({"fast": "yes"}, TypeError, "fast"),
    ({"options": ["method"]}, TypeError, "options"),
    ({"seed": -1}, ValueError, "seed"),
])
def test_target_sampler_refuses_bad_arguments(kwargs, exc, match):
    tgt = get_target("ideal", 2)
    with pytest.raises(exc, match=match):
        target_sampler(tgt, **kwargs)
    with pytest.raises(TypeError, match="target"):
        target_sampler("ideal")

# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
#       format_version: '1.3'
#       jupytext_version: 1.19.6
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Tomography of unary states and of the density state
#
# An orthogonal QNN (RBS circuits on a unary loader, Fig. 2, Fig. 9) leaves its output in the
# unary subspace: `|y> = sum_j y_j |e_j>` with `y` real and of unit norm. Its *signed* amplitudes
# are what a classical read-out layer needs (the MoE reading of Supp. H), and Supp. F reads them
# with l-infinity tomography (Kerenidis-Prakash; Landman et al. Fig. 18) from three circuits:
#
# 0. the circuit measured as is: `p_j = y_j^2` gives the magnitudes;
# 1. then `RBS(pi/4)` on the pairs `(0,1), (2,3), ...`, and
# 2. on the pairs `(1,2), (3,4), ...`: the differences of the outcome probabilities give the
#    relative sign of neighbouring amplitudes.
#
# `O(log(n) / delta^2)` shots per circuit give `||y_hat - y||_inf <= delta` (up to the global
# sign). `qdensity.circuits.tomography` builds the circuits, reconstructs from counts with an error
# bound,
# and says how many shots a target error needs. Below: a pure unary state, the error against
# shots, Hamming-weight post-selection on a noisy device, and the density state
# `rho = sum_k alpha_k |y_k><y_k|` of a density QNN (eq. 1) rebuilt from its sub-unitaries.

# %%
import numpy as np
from qiskit.quantum_info import Statevector

from qdensity import get_target, target_sampler, unary_loader
from qdensity.circuits.ansatze import round_robin
from qdensity.circuits.tomography import (
    bridge_circuit,
    bridge_pairs,
    reconstruct,
    shots_for_error,
    tomography_circuits,
)

n = 5
rng = np.random.default_rng(0)
x = np.array([0.6, -0.3, 0.9, 0.2, -0.5])
layer = round_robin(n)
angles = rng.uniform(-np.pi, np.pi, layer.num_parameters)
circuit = unary_loader(x).compose(layer.assign_parameters(angles))
y = Statevector(circuit).data.real[2 ** np.arange(n)]          # the exact unary amplitudes
assert np.isclose(np.linalg.norm(y), 1.0)
circuits = tomography_circuits(circuit)
print([c.name for c in circuits])
print(circuits[1].draw('text', fold=120))  # the even-pair circuit

ideal = get_target('ideal', n, seed=0)
compiled = ideal.transpile(circuits)

def sample(target, compiled, shots, seed):
    result = target_sampler(target, seed=seed, shots=shots).run(compiled).result()
    return [r.data.meas.get_counts() for r in result]

def linf(estimate, exact):                                      # up to the global sign
    return min(np.abs(estimate - exact).max(), np.abs(estimate + exact).max())


# %%
res = reconstruct(sample(ideal, compiled, 4000, seed=1), n)
err = linf(res.amplitudes, y)
fidelity = float(res.amplitudes @ y) ** 2 / float(res.amplitudes @ res.amplitudes)
print('exact   ', y.round(3))
print('estimate', res.amplitudes.round(3), ' signs resolved:', res.signs_resolved)
print(f"l-inf error {err:.4f} <= bound {res.error_estimate:.4f}; fidelity {fidelity:.5f}, "
      f"trace distance {np.sqrt(1 - fidelity):.4f}")
assert res.signs_resolved and err <= res.error_estimate
assert fidelity > 0.99
print('shots per circuit for delta = 0.1 with probability 0.99:', shots_for_error(0.1, n, 0.01))

# %% [markdown]
# ## Error against shots
#
# The l-infinity error falls like `1/sqrt(N)`; the bound `error_estimate` (which holds with
# probability `1 - p_fail`, here 0.99) sits above it by the constant of `shots_for_error`
# (`(1 + 4 sqrt 2) sqrt(ln(6 n / p_fail))` is the worst case over signs and outcomes).

# %%
import matplotlib.pyplot as plt

budgets = [100, 300, 1000, 3000, 10000]
errors, bounds = [], []
for shots in budgets:
    runs = [reconstruct(sample(ideal, compiled, shots, seed=10 * shots + s), n) for s in range(3)]
    errors.append([linf(r.amplitudes, y) for r in runs])
    bounds.append(np.mean([r.error_estimate for r in runs]))
    assert all(linf(r.amplitudes, y) <= r.error_estimate for r in runs)
mean_err = np.mean(errors, axis=1)
slope = np.polyfit(np.log(budgets), np.log(mean_err), 1)[0]
print('mean l-inf error', mean_err.round(4), ' log-log slope', round(slope, 2))
assert -0.8 < slope < -0.3                      # 1/sqrt(N), within the noise of 3 runs

fig, ax = plt.subplots(figsize=(6, 3))
ax.loglog(budgets, mean_err, 'o-', label='l-inf error (mean of 3 runs)')
ax.loglog(budgets, bounds, 's--', label='error_estimate (p_fail = 0.01)')
ax.loglog(budgets, mean_err[0] * np.sqrt(budgets[0] / np.array(budgets)), ':', label='1/sqrt(N)')
ax.set_xlabel('shots per tomography circuit')
ax.set_ylabel('error')
ax.legend(fontsize=8)
plt.show()

# %% [markdown]
# ## On a noisy device: Hamming-weight post-selection
#
# Gate and readout noise move weight out of the unary subspace. Keeping only Hamming-weight-1
# outcomes (`postselect=True`, the default) and renormalising removes that part of the noise;
# `kept_fraction` says how much was kept. Without post-selection the estimate is of the
# un-renormalised amplitudes, shrunk by the leak.

# %%
noisy = get_target('heavy_hex', n, seed=2)
counts = sample(noisy, noisy.transpile(circuits), 4000, seed=5)
kept = reconstruct(counts, n, postselect=True)
raw = reconstruct(counts, n, postselect=False)
print('kept fractions:', np.round(kept.kept_fraction, 3))
print(f"l-inf error, post-selected: {linf(kept.amplitudes, y):.4f}; "
      f"all shots: {linf(raw.amplitudes, y):.4f}")
assert linf(kept.amplitudes, y) < linf(raw.amplitudes, y)

# %% [markdown]
# ## The density state of a density QNN
#
# The density QNN's state (eq. 1) on a unary input with Hamming-weight-preserving sub-unitaries
# is `rho = sum_k alpha_k |y_k><y_k|`, an `n x n` real matrix on the unary subspace, with
# `y_k = U_k |x>`. Tomography of each sub-unitary's randomised circuit (Fig. 1c) gives
# `y_hat_k`, and `rho_hat = sum_k alpha_k |y_hat_k><y_hat_k|` (the global sign of each `y_hat_k`
# cancels). Where an amplitude is (near) zero between two others the three circuits cannot fix the
# relative sign across it; `bridge_pairs` names the pairs of an extra `bridge_circuit` that does.
# We compare with the exact `rho` by the trace distance
# (`qdensity.analysis.mixing.trace_distance` returns the trace norm `||rho - sigma||_1`, twice
# the trace distance) and the fidelity.

# %%
from scipy.linalg import sqrtm

from qdensity import by_moments
from qdensity.analysis.mixing import trace_distance
from qdensity.circuits.preparation import randomised_circuits

dec = by_moments(round_robin(n))                              # K = n = 5 layers (n odd)
subs = [c.assign_parameters(rng.uniform(-np.pi, np.pi, c.num_parameters))
        for c in dec.sub_unitaries]
alpha = rng.dirichlet(np.ones(len(subs)))
prepared = randomised_circuits(subs, unary_loader(x))          # U_k V(x), one per k
ys = [Statevector(c).data.real[2 ** np.arange(n)] for c in prepared]
rho = sum(a * np.outer(v, v) for a, v in zip(alpha, ys, strict=True))

def fidelity(a, b):
    root = sqrtm(a)
    return float(np.real(np.trace(sqrtm(root @ b @ root))) ** 2)

def tomograph(circ, shots, seed):
    # the three circuits, then bridge circuits across any gap the signs could not cross
    counts = sample(ideal, ideal.transpile(tomography_circuits(circ)), shots, seed)
    res = reconstruct(counts, n)
    pairs = bridge_pairs(res)
    if pairs:
        bridges = ideal.transpile([bridge_circuit(circ, p) for p in pairs])
        bridge_counts = sample(ideal, bridges, shots, seed + 1)
        res = reconstruct(counts, n, extra=list(zip(pairs, bridge_counts, strict=True)))
    return res, len(pairs)

distances = []
for shots in (500, 5000):
    results = [tomograph(c, shots, seed=10 * k) for k, c in enumerate(prepared)]
    assert all(r.signs_resolved for r, _ in results)
    y_hat = [r.amplitudes for r, _ in results]
    rho_hat = sum(a * np.outer(v, v) for a, v in zip(alpha, y_hat, strict=True))
    td = trace_distance(rho_hat, rho) / 2
    # convexity, then D(a, b) = sqrt(1 - (a.b)^2) <= ||a - b||_2 <= sqrt(n) ||a - b||_inf for unit
    # vectors: a bound from the per-circuit l-inf bounds (each holds with probability 0.99)
    bound = sum(a * np.sqrt(n) * r.error_estimate for a, (r, _) in zip(alpha, results, strict=True))
    print(f"{shots:>5} shots per circuit: trace distance {td:.4f} <= bound {bound:.4f}, "
          f"fidelity {fidelity(rho_hat, rho):.5f}, bridge circuits {[b for _, b in results]}")
    assert td <= bound
    distances.append(td)
assert distances[1] < distances[0]
print(f"purity of rho: {np.trace(rho @ rho):.3f} "
      "(a mixed state: the density QNN is not a pure QNN)")

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
# # Noisy runs and shot schedulers
#
# The randomised density QNN (Fig. 1c) prepares `rho = sum_k alpha_k U_k rho(x) U_k^dagger`
# (eq. 1) only on average: each shot runs one sub-unitary `U_k`. Its output (eq. 3)
# `f(x) = sum_k alpha_k f_k(x)` is estimated from a shot budget, and *how* the budget is split
# over the `K` sub-unitaries matters (Supp. I):
#
# * `per_shot`: the physical protocol of Fig. 1c, each shot draws `k ~ alpha`;
# * `proportional`: `n_k ~ alpha_k S` fixed in advance (stratified sampling), which removes the
#   between-sub-unitary variance `sum_k alpha_k (f_k - f)^2 / S`;
# * `neyman`: a pilot run estimates each sub-unitary's spread `sigma_k`, the rest of the budget
#   goes `n_k ~ alpha_k sigma_k` (the variance-optimal split).
#
# Here a density OrthoQNN (round-robin, cut into its `n - 1` layers, Fig. 6) is sampled on a noisy
# simulated device under a fixed budget with each scheduler; every estimate comes with a standard
# error that never collapses to zero (Wilson's extra term, `qdensity.execution.intervals`), and we
# compare with the exact value. Then the shot ledger, and readout mitigation with Hamming-weight
# post-selection on a calibrated IBM device snapshot.

# %%
import numpy as np

from qdensity import DensityQNN, Encoding, SamplerEngine, by_moments, get_target
from qdensity.circuits.ansatze import round_robin

n = 4
dec = by_moments(round_robin(n))                      # K = n - 1 = 3 sub-unitaries
alpha = np.array([0.6, 0.3, 0.1])
model = DensityQNN(dec.sub_unitaries, alpha, encoding=Encoding.unary(n), seed=4)   # <Z_0>
x = np.array([0.3, -0.8, 0.5, 0.2])
f_k = model.expert_outputs(x[None])[0]                # exact, noiseless f_k(x)
exact = float(model.predict(x[None])[0])
assert np.isclose(exact, alpha @ f_k)
# per-shot value of sub-unitary k: +1 / -1 (the Z_0 eigenvalue) with P(-1) = p_k(e_0)
probs = DensityQNN(dec.sub_unitaries, alpha, encoding=Encoding.unary(n),
                   readout='unary_probabilities', seed=4).expert_outputs(x[None])[0]
var_k = 1 - f_k**2                                    # variance of a +-1 value with mean f_k
assert np.allclose(f_k, 1 - 2 * probs[:, 0])
print('f_k =', f_k.round(3), ' f = sum_k alpha_k f_k =', round(exact, 4))

# %% [markdown]
# ## The noisy target
#
# `rbs_native` is a trapped-ion-like all-to-all device whose native two-qubit gate is the beam
# splitter itself (one gate per RBS), with depolarising and thermal-relaxation errors after every
# gate and 0.4% readout error, uniform across the chain, so the compiled layout does not change
# the noise. Each `model.sample` call compiles for it and samples its noisy Aer simulator with a
# fresh seed drawn from `seed` (pilot and main phase independent).

# %%
target = get_target('rbs_native', n, seed=1)
assert target.is_noisy
budget, repeats = 2000, 4
runs = {s: [model.sample(x, budget, scheduler=s, target=target, seed=100 * r + i)
            for r in range(repeats)]
        for i, s in enumerate(('per_shot', 'proportional', 'neyman'))}
print(f"exact (noiseless) f = {exact:.4f}")
for s, results in runs.items():
    for res in results:
        assert res.shots_used == budget                      # never more than the budget
        assert abs(res.estimate - exact) < 5 * res.standard_error
    est = np.array([r.estimate for r in results])
    print(f"{s:>13}: estimates {np.round(est, 3)}, mean reported standard error "
          f"{np.mean([r.standard_error for r in results]):.4f}")

# %% [markdown]
# The noise of this device pulls `f` towards 0 by about 0.01 here (depolarising shrinks
# `<Z_0>`), less than the standard error of 2000 shots, so each estimate lies within a few
# standard errors of the exact noiseless value (the calibrated snapshot below is much noisier).
# The standard errors match the theory: with the exact `f_k` and per-shot variances
# `1 - f_k^2`, the three schedulers' standard deviations are below. Here the two heaviest
# sub-unitaries have close `f_k`, so stratification gains little; the gain is
# `sum_k alpha_k (f_k - f)^2 / S`, largest when the `f_k` differ.

# %%
from qdensity.execution.schedulers import (
    allocate_neyman,
    allocate_proportional,
    per_shot_variance,
    stratified_variance,
)

theory = {
    'per_shot': per_shot_variance(alpha, f_k, var_k, budget),
    'proportional': stratified_variance(alpha, var_k, allocate_proportional(alpha, budget)),
    'neyman (true sigma, no pilot)': stratified_variance(
        alpha, var_k, allocate_neyman(alpha, np.sqrt(var_k), budget)),
}
for name, v in theory.items():
    print(f"{name:>30}: standard deviation {np.sqrt(v):.4f}")
assert theory['proportional'] <= theory['per_shot']
assert theory['neyman (true sigma, no pilot)'] <= theory['proportional']
for s in ('per_shot', 'proportional'):
    reported = np.mean([r.standard_error for r in runs[s]])
    assert abs(reported - np.sqrt(theory[s])) < 0.25 * np.sqrt(theory[s])

# %%
import matplotlib.pyplot as plt

fig, ax = plt.subplots(figsize=(7, 3))
for i, (s, results) in enumerate(runs.items()):
    xs = i + np.linspace(-0.2, 0.2, len(results))
    ax.errorbar(xs, [r.estimate for r in results], yerr=[r.standard_error for r in results],
                fmt='o', capsize=3, label=s)
ax.axhline(exact, color='k', ls='--', label='exact (noiseless)')
ax.set_xticks(range(len(runs)), list(runs))
ax.set_ylabel('estimate of f(x)')
ax.set_title(f'{budget} shots per estimate on rbs_native, error bars: 1 standard error')
ax.legend(fontsize=8)
plt.show()

# %% [markdown]
# ## The shot ledger: pilot shots versus the allocation
#
# A `ScheduleResult` reports the main phase's `allocation` and, for Neyman, the pilot's
# `pilot_allocation`; `shots_used` is their sum and never exceeds the budget. An engine's
# `ShotLedger` records every job: the randomised shots are labelled `randomised_k{k}`, a Neyman
# pilot's `pilot_k{k}`.

# %%
ney = runs['neyman'][0]
print('pilot     ', ney.pilot_allocation, '  (proportional to alpha)')
print('allocation', ney.allocation, '  (~ alpha_k sigma_k, sigma_k from the pilot)')
print('spreads from the pilot:', np.round(ney.info['pilot_sigma'], 3),
      ' exact:', np.sqrt(var_k).round(3))
assert ney.pilot_allocation.sum() + ney.allocation.sum() == ney.shots_used == budget

engine = SamplerEngine(target=target, seed=7)          # one engine, its ledger kept
res = model.sample(x, budget, scheduler='proportional', engine=engine)
print(engine.ledger.summary())
by_label = engine.ledger.by_label()
assert [by_label[f'randomised_k{k}'][1] for k in range(3)] == res.allocation.tolist()

# %% [markdown]
# `engine=` uses one engine for every call, and an Aer sampler with a fixed seed repeats its shots
# from one call to the next: fine for the single call of `per_shot` and `proportional`, but a
# Neyman pilot and main phase would then share shots. For Neyman pass `target=` (fresh seeds per
# call, as above) or a hardware sampler.
#
# ## Readout mitigation and Hamming-weight post-selection (the `ibm` extra)
#
# On a calibrated device snapshot (`fake_manila`: the coupling map, gates, T1/T2 and readout
# errors of an IBM device) noise biases the estimate by many standard errors. Two corrections
# (`qdensity.execution.sampler.mitigated.mitigated_expectation`): mthree's readout mitigation
# (calibrated
# on the same device, its shots in the ledger) and post-selection on Hamming weight 1 (a unary
# model never leaves that subspace; gate noise does). Each `f_k` is estimated with a fixed
# number of shots, then `f = sum_k alpha_k f_k`.

# %%
import importlib.util

if importlib.util.find_spec('qiskit_ibm_runtime') and importlib.util.find_spec('mthree'):
    from qdensity.execution.sampler.mitigated import mitigated_expectation
    from qdensity.hardware.mitigation import ReadoutMitigator

    device = get_target('fake_manila', n, seed=0)
    eng = SamplerEngine(target=device, seed=3)
    mitigator = ReadoutMitigator(device, shots=4000, seed=4, ledger=eng.ledger)
    settings = {'raw': dict(postselect=None), 'post-selected': dict(postselect=1),
                'mitigated + post-selected': dict(mitigator=mitigator, postselect=1)}
    out = {}
    for name, kw in settings.items():
        parts = [mitigated_expectation(model.circuit(k), model.observable, model.rows(k, x[None]),
                                       engine=eng, shots=4000, label=name, **kw)
                 for k in range(model.num_subunitaries)]
        value = sum(a * p.value[0] for a, p in zip(alpha, parts, strict=True))
        se = np.sqrt(sum((a * p.standard_error[0]) ** 2 for a, p in zip(alpha, parts, strict=True)))
        kept = [round(float(p.kept_fraction[0]), 3) for p in parts]
        out[name] = (value, se)
        print(f"{name:>26}: {value:.4f} +- {se:.4f}  (error {value - exact:+.4f}; kept {kept})")
    print(eng.ledger.summary())
    raw, both = out['raw'], out['mitigated + post-selected']
    assert abs(both[0] - exact) < 5 * both[1] + 0.03
    assert abs(both[0] - exact) < abs(raw[0] - exact)
else:
    print("readout mitigation needs the ibm extra: pip install -e '.[ibm]' "
          "(qiskit-ibm-runtime and mthree)")

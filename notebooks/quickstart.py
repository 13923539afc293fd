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
# # qdensity quick tour
#
# A density QNN `rho = sum_k alpha_k U_k rho(x) U_k^dagger` (paper eq. 1) built from a round-robin
# OrthoQNN cut into its layers (Fig. 6), evaluated exactly, differentiated with commuting-generator
# circuits, prepared deterministically (Fig. 1b) and trained. Small sizes so the notebook runs in
# seconds; the test suite executes it.

# %%
import numpy as np

from qdensity import DensityQNN, Encoding, ExactEngine, SamplerEngine, by_moments
from qdensity.circuits.ansatze import round_robin
from qdensity.models.mixtures import SoftmaxMixture

n = 4
decomposition = by_moments(round_robin(n))
decomposition

# %%
model = DensityQNN(decomposition.sub_unitaries, SoftmaxMixture(decomposition.num_subunitaries),
                   encoding=Encoding.unary(n), readout='unary_probabilities', seed=0)
X = np.random.default_rng(1).normal(size=(3, n))
probs = model.predict(X)              # unary engine, exact
assert np.allclose(probs.sum(axis=1), 1.0)
assert np.allclose(probs, model.predict(X, method='statevector'))
probs.round(3)

# %% [markdown]
# ## Gradients: n - 1 commuting circuits instead of 4 per RBS gate (Table 1)

# %%
from qdensity.gradients import density_gradient_plan

shift = density_gradient_plan(model, X[:1], method='shift')
commuting = density_gradient_plan(model, X[:1], method='commuting')
print('parameter shift:', shift.meta['gradient_circuits'], 'circuits; commuting:',
      commuting.meta['gradient_circuits'])
exact = commuting.run(ExactEngine())
sampled = commuting.with_shots(2000).run(SamplerEngine(seed=7))
print(np.abs(sampled.jacobians[0] - exact.jacobians[0]).max())

# %% [markdown]
# ## Preparation circuits (Fig. 1) and what they cost

# %%
from qdensity import compare_reports, resource_report, unary_loader
from qdensity.circuits.preparation import deterministic_circuit, randomised_circuits

# each sub-unitary bound to its own angles: theta[indices of sub-unitary k]
bound = [c.assign_parameters(model.theta[model.subunitary_parameter_indices(k)])
         for k, c in enumerate(model.sub_unitaries)]
loader = unary_loader(X[0])
alpha = model.alpha()[0]
print(compare_reports({'randomised (k=0)': resource_report(randomised_circuits(bound, loader)[0]),
                       'deterministic': resource_report(
                           deterministic_circuit(bound, alpha, loader))}))

# %% [markdown]
# ## Training (exact unary engine)

# %%
from qdensity import QNNClassifier
from qdensity.learning.nn import Linear

rng = np.random.default_rng(0)
y = rng.integers(0, 2, 40)
Xtrain = np.array([[2, .5, .1, .1], [.1, .1, .5, 2]])[y] + 0.3 * rng.normal(size=(40, n))
clf = QNNClassifier(model, post=Linear(n, 2, seed=0), learning_rate=0.1, epochs=10,
                    batch_size=10, seed=0, verbose=False)
clf.fit(Xtrain, y)
print('train accuracy', clf.score(Xtrain, y), 'final loss', clf.history_['loss'][-1].round(3))

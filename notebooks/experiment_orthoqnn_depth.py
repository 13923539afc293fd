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
# # Experiment `orthoqnn-depth`: round-robin OrthoQNN vs density QNNs of sub-unitary depth D
#
# **The paper's claim** (Fig. 7, *Numerical results: Orthogonal quantum neural networks*; Fig. 6):
# a round-robin OrthoQNN on n = 10 qubits needs 4 n (n - 1) / 2 = 180 parameter-shift circuits
# per gradient, while its *shallow* density version (the n - 1 = 9 round-robin layers as
# sub-unitaries, D = 1) is a commuting-generator model whose gradient needs only n - 1 = 9
# circuits. Against epochs (Fig. 7a) the shallow density QNN trains with little or no loss of
# accuracy; against measurement shots (Fig. 7b) it gets there far more cheaply. Making each of
# the K = n - 1 sub-unitaries deeper (D in {1, 2, 3, 4, n - 1} cyclically consecutive layers,
# sub-unitaries pretrained in parallel for 25 epochs, then the density model trained for 25 more)
# *monotonically* improves accuracy (Fig. 7c, d), at a growing shot cost (no longer efficient for
# D >= 2).
#
# The cell below runs the experiment at `quick` size (6 qubits, depths 1 and 5, one epoch of
# pretraining and one of density training, 150 training digits): it exercises the whole pipeline
# in seconds, it does not show the scientific result.

# %%
import tempfile

from IPython.display import Image, display

from qdensity_paper import run

out = tempfile.mkdtemp()
try:
    result = run("orthoqnn-depth", mode="quick", out=out, progress=False)
except ImportError as exc:  # an optional extra is missing: say what to install
    result = None
    print(f"skipped: {exc}")
if result is not None:
    print(f"seeds {result.seeds}, {result.seconds:.1f} s")
    for metric, s in result.summary.items():
        print(f"{metric:45s} {s['mean']:.4g}  [{s['low']:.4g}, {s['high']:.4g}]")
    for path in result.figures:
        display(Image(filename=f"{out}/{path}"))  # names beside the JSON

# %% [markdown]
# **How to read it.** The first figure is Fig. 7's top row (pure OrthoQNN vs the shallow D = 1
# density QNN), the second its bottom row (all depths). For a density model the first
# `pretrain_epochs` points are the mean test accuracy of its K sub-models trained separately;
# the later points are the warm-started density model (uniform trainable alpha, read-out
# initialised as the mean of the sub-models' read-outs). Training is exact; the shot axis counts
# what the same training would run on hardware: `circuits_per_row x training rows x
# shots_per_circuit` per epoch, with `circuits_per_row` read off the gradient plan (parameter
# shift for the pure model: 4 x 45 + 1 = 181 at n = 10; one commuting-generator circuit plus one
# forward circuit per sub-unitary for D = 1: 18). At quick size the accuracies are near chance
# and the confidence intervals (2 seeds) are wide. The full run (`qdensity experiment
# orthoqnn-depth --full`, 10 qubits, digits PCA to 10 features, 25 + 25 epochs, 5 seeds) is
# reported in EXPERIMENTS.md with its reductions from the paper's MNIST protocol.

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
# # Experiment `pyramid-shots`: pyramid OrthoQNN vs its density versions against shots
#
# **The paper's claim** (Fig. 11, Supp. H.1 *Odd-even pyramid decomposition*, hyperparameters
# appendix): in the hybrid model `Linear(784, 8) -> ReLU -> unary loader -> OrthoQNN ->
# Linear(8, 10) -> softmax` on MNIST, splitting the pyramid OrthoQNN into its even- and
# odd-qubit gates (a density QNN with K = 2 commuting-generator sub-unitaries), or further
# compressing each pair's run of gates into one, reaches a test accuracy close to the pure
# pyramid's while needing far fewer measurement shots to train: the pure model's gradient needs
# the parameter-shift rule on all n (n - 1) / 2 RBS angles, the density models' only one
# diagonalising circuit per sub-unitary. (Paper: best accuracies around 90% for all three; the
# density curves reach them with orders of magnitude fewer shots.)
#
# The cell below runs the experiment at `quick` size (scikit-learn's 8x8 digits, 200 training
# images, 2 epochs): it exercises the whole pipeline in seconds, it does not show the scientific
# result. It needs the PyTorch extra (`pip install -e '.[torch]'`).

# %%
import tempfile

from IPython.display import Image, display

from qdensity_paper import run

out = tempfile.mkdtemp()
try:
    result = run("pyramid-shots", mode="quick", out=out, progress=False)
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
# **How to read it.** The left panel is Fig. 11b: test accuracy against the shots training
# would spend (log scale), the right panel the same runs against epochs. Training is exact (the
# unary engine's reverse mode inside a `torch.nn.Sequential`); the shot axis counts the quantum
# layer's gradient circuits per training row times `shots_per_circuit`: 4 x 28 + 1 = 113 for the
# pure pyramid on 8 qubits (four-term parameter shift), 4 for both density models (one
# commuting-generator circuit and one forward circuit per sub-unitary). The loader's gradient
# circuits (needed on hardware to train the layer before it) are not counted, for any model, as
# in the paper. At equal epochs the density curves therefore sit about 28 times further left.
# `pure/test_accuracy_at_density_budget` is the pure model's accuracy after spending as many
# shots as the odd-even model's whole training. The full run (30 epochs on all 1497 training
# digits, 5 seeds) is reported in EXPERIMENTS.md with its reductions from the paper's MNIST
# protocol.

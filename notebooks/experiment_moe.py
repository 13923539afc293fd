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
# # Experiment `moe`: density QNNs as a mixture of experts (Supp. H.2, Fig. 15)
#
# **The paper's claim.** A density QNN's mixture weights can depend on the input, `alpha(x) =
# softmax(Linear(x))` ("MoE") or `softmax(GELU(Linear(x)))` ("MoE*"): the sub-unitaries become
# experts and the linear layer a gating network. Over an optuna sweep of 32 trials (batch size, log
# learning rate, Adam / SGD / RMSProp, l2 or none; test accuracy after 100 epochs of MNIST, mean
# with a 95% bootstrap interval, best run in the inset), the gate does **not** help the shallow
# decompositions (the butterfly cut into its `log2 n` layers, the compressed odd-even pyramid) but
# **does** help the odd-even pyramid decomposition, whose sub-unitaries carry more parameters,
# bringing it up to the pure OrthoQNN; it also narrows the spread over hyperparameters.
#
# The model is the hybrid of Fig. 11a: `Linear(d -> n)`, ReLU, unary loader, quantum layer (unary
# outcome probabilities), `Linear(n -> 10)`. Below runs the quick size (4 qubits, two trials of one
# epoch on a few digits), which exercises the pipeline but says nothing about the claim.

# %%
import tempfile
from pathlib import Path

from IPython.display import Image, display

from qdensity_paper import run

out = Path(tempfile.mkdtemp())
try:
    result = run("moe", mode="quick", out=out, progress=False)
except ImportError as exc:  # an optional extra is missing: say what to install
    result = None
    print(f"skipped: {exc}")
if result is not None:
    print(f"seeds {result.seeds}, {result.seconds:.1f} s")
    for key, s in result.summary.items():
        if any(word in key for word in ("mean_accuracy", "best_accuracy")):
            print(f"{key:45s} {s['mean']:.3f}  [{s['low']:.3f}, {s['high']:.3f}]")
    for figure in result.figures:
        display(Image(filename=f"{out}/{figure}"))  # names beside the JSON

# %% [markdown]
# **How to read it.** Each panel is one decomposition (Fig. 15b, c, d): the violins are the test
# accuracies of every sweep trial after training, pooled over seeds; the black point and bar are
# their mean and its 95% bootstrap interval, the star the best trial (the paper's inset). The
# paper's claim would show as the MoE and MoE* violins of the odd-even panel sitting higher (and
# narrower) than the plain density model's, close to the pure pyramid, with no such gain in the
# butterfly and compressed panels. The second figure is the mean over trials of the test accuracy
# against epochs. At quick size every model is near chance (10 classes): one epoch is not training.
# The full run (`qdensity experiment moe --full`: 8 qubits, the 8x8 digits instead of MNIST, 100
# epochs, 8 trials x 4 seeds per model) is what `EXPERIMENTS.md` reports, with its reductions.

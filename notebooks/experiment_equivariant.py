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
# # Equivariant QNNs and their density versions on noisy bars and dots
#
# **The paper's claim** (Fig. 5, Sec. *Equivariant quantum neural networks*, Methods *Equivariant
# density QNN*): on 10 qubits, noisy bars and dots with $\sigma = 1.8$ (1000 training / 100 test
# points, batch 20, Adam), a density QNN initialised from a pre-trained base model ($\alpha = (0.99,
# 0.01)$, trainable) improves the final test accuracy once the base model has saturated, for all
# three models of Bowles et al.: the commuting-generator XX model (density version XX+YY), the
# non-commuting equivariant model and the QCNN (density versions with a second, independently
# trained copy). Against shots, the density curves start after a gap: the shots spent pre-training
# the second sub-unitary. XX+YY gives the best trade-off between shots and accuracy, because both of
# its sub-unitaries have commuting-generator gradients.
#
# Below: the experiment at `quick` size (5 qubits, a few Adam steps), which only checks the
# pipeline; the full-size numbers are in `EXPERIMENTS.md` (`qdensity experiment equivariant
# --full`).

# %%
import tempfile

from IPython.display import Image, display

from qdensity_paper import run

out = tempfile.mkdtemp()
try:
    result = run("equivariant", mode="quick", out=out, progress=False)
except ImportError as exc:  # an optional extra is missing: say what to install
    result = None
    print(f"skipped: {exc}")
if result is not None:
    for name, s in sorted(result.summary.items()):
        if name.endswith(("test_accuracy", "gain", "alpha_2", "circuits_per_row")):
            print(f"{name:42s} {s['mean']:10.3f}  [{s['low']:.3f}, {s['high']:.3f}]")
    for path in result.figures:
        display(Image(filename=f"{out}/{path}"))  # names beside the JSON

# %% [markdown]
# **How to read it.** The left figure is the paper's Fig. 5a: test accuracy against training epochs,
# where an epoch is one Adam step on a mini-batch of 20, as in Bowles et al.'s code that the paper
# adapts. One panel per family. The base model runs the whole length; the density model branches off
# at the end of pre-training and starts from the base model's angles and read-out head, with 1%
# weight on the second sub-unitary. The right figure is Fig. 5b: the same accuracies against shots.
# Shots are counted as a sampled run would need them: gradient circuits plus one forward circuit per
# sub-unitary (commuting-generator circuits for XX and YY, parameter shift for the non-commuting
# model and the QCNN) x 20 rows x 1000 shots per circuit. The density curve starts after the base
# model's pre-training shots plus the second sub-unitary's. The paper's claim is that, after the
# branch point, the density curve ends above the base curve. `density_gain` is that difference,
# averaged over the last evaluations, and `density_alpha_2` is where the trainable weight of the
# second sub-unitary ends up.
#
# At quick size nothing has converged, so the gain is noise. The full run (10 qubits, the paper's
# data) uses fewer steps than the paper's 1000 + 1000 and a larger learning rate, and encodes a
# feature x as the angle 0.5 x, as Bowles et al.'s code does. The Methods' angle pi x / 2 leaves no
# learnable signal at sigma = 1.8 (see the module docstring and `reductions`). Compare the full
# numbers in `EXPERIMENTS.md` with Fig. 5 for the trend (does the density version end above its base
# model?) rather than for the absolute accuracies.

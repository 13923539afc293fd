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
# # Experiment `noise`: pure vs density QNNs on a noisy device (beyond the paper)
#
# **The question.** The paper trains on noiseless simulators. Its case for density QNNs is a
# training-cost one (Table 1: a round-robin OrthoQNN on `n` qubits needs `4 n (n - 1) / 2`
# parameter-shift circuits per gradient, its layer-by-layer density version `n - 1`
# commuting-generator circuits plus `K` forward circuits) and a depth one (each sub-unitary is one
# moment of the round-robin circuit, Fig. 3 and 6). What a hardware team wants to know is what is
# left of that on a real, noisy device: at the **same number of training shots**, which model ends
# up better, and how much do **Hamming-weight-1 post-selection** (unary circuits keep every ideal
# outcome in the weight-1 subspace; gate noise leaks out of it) and **readout-error mitigation**
# (mthree) recover of the accuracy when the device, not a simulator, makes the predictions?
#
# Both models are trained with sampled gradient circuits on the noisy Aer simulator of a calibrated
# IBM device snapshot (`fake_manila`, 5 qubits; needs `pip install -e '.[ibm]'`;
# `target="heavy_hex"` runs without the extra), on 4-class digits (PCA to `n` features, unary
# amplitude encoding, linear read-out), with the same budget of training shots. Training uses the
# raw counts; the corrections are applied to the predictions only. Test accuracy is scored five
# ways: exactly (the trained parameters, noiseless) and from device counts (the same shots per test
# point for both models, split over the sub-unitaries in proportion to alpha): raw, post-selected,
# mitigated, mitigated and post-selected. Below runs the quick size (4 qubits, 1600 training shots,
# 16 test digits), which exercises the pipeline but says nothing about the question.

# %%
import tempfile
from pathlib import Path

from IPython.display import Image, display

from qdensity_paper import run

out = Path(tempfile.mkdtemp())
try:
    result = run("noise", mode="quick", out=out, progress=False)
except ImportError as exc:  # an optional extra is missing: say what to install
    result = None
    print(f"skipped: {exc}")
if result is not None:
    print(f"seeds {result.seeds}, {result.seconds:.1f} s, target {result.config['target']}")
    for key, s in result.summary.items():
        if any(word in key for word in ("accuracy", "kept_fraction", "output_error", "train_shots",
                                        "two_qubit", "calibration")):
            print(f"{key:34s} {s['mean']:8.3f}  [{s['low']:.3f}, {s['high']:.3f}]")
    for figure in result.figures:
        display(Image(filename=f"{out}/{figure}"))  # names beside the JSON

# %% [markdown]
# **How to read it.** The first figure has one panel per model: test accuracy against the training
# shots spent, scored exactly (what training achieved) and from device counts raw, post-selected,
# mitigated and both. The gap between the exact curve and the raw device curve is what noise costs
# at prediction time; how much of it post-selection and mitigation close is the practical question.
# The second figure puts pure and density side by side at equal training shots, exactly, raw and
# mitigated + post-selected: the density model takes about four times as many optimiser steps for
# the same shots (its gradient needs `2 K` circuits per data point instead of `4 n (n - 1) / 2 +
# 1`), and its circuits are shallower (compare `two_qubit_gates_mean`), so less weight leaks out of
# the unary subspace (`raw_kept_fraction`). The third figure is the accuracy of the trained models
# against the shots spent per prediction, the fourth the mean L1 distance between each device
# estimate of the model output `f(x)` and the exact output: this is where post-selection and
# mitigation show most plainly, because the classifier's linear read-out was trained on raw device
# outputs and argmax decisions forgive much of the distortion. The scalars give, per model, the mean
# L1 error of each device estimate of the model output against the exact output, the weight kept in
# the Hamming-weight-1 subspace, mthree's overhead (the factor by which mitigation inflates the
# variance) and the readout-calibration shots (not part of the training budget). The exact-training
# `ceiling_accuracy` is each model trained noiselessly with exact gradients, the reference both
# sampled runs fall short of. At quick size nothing has trained and two seeds give wide intervals;
# the full run (`qdensity experiment noise --full`: 5 qubits, 600k training shots per model, 120
# test digits, 5 seeds) is what `EXPERIMENTS.md` reports.

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
# # Experiment `reuploading`: density QNNs mitigate overfitting (Fig. 6, Supp. J)
#
# **The paper's claim.** A vanilla single-qubit data re-uploading model with `L` layers (`R_z R_y
# R_z` per upload, `3L` parameters) overfits noisy Chebyshev data as `L` grows: its test MSE and its
# generalisation gap (test minus train MSE) grow. A density QNN with `K = 5` sub-unitaries of `D`
# layers each, `5 x 3D ~ 3L` parameters, does not: its test error stays small (Fig. 6b). At `L = 50`
# the density model's test MSE falls as `K` grows over `{2, 7}` (Supp. J, Fig. 17).
#
# The paper describes two settings that disagree; the `setting` key chooses: `"methods"` (the
# Methods section: `T_4`, noise variance 0.25, one `R_x(x)` per upload) or `"supp_j"` (Supp. J:
# `T_2`, noise std 0.2, `R_y(x) R_x(x)` per upload), or `"both"` (the full run). 25 noisy training
# points, 110 clean test points on `[-1, 1]`, batch 5, Adam 0.001. The models are simulated exactly
# on one qubit (`qdensity.models.single_qubit`). Below runs the quick size (`L` in {5, 10}, 30
# epochs, the Methods setting).

# %%
import tempfile
from pathlib import Path

from IPython.display import Image, display

from qdensity_paper import run

out = Path(tempfile.mkdtemp())
try:
    result = run("reuploading", mode="quick", out=out, progress=False)
except ImportError as exc:  # an optional extra is missing: say what to install
    result = None
    print(f"skipped: {exc}")
if result is not None:
    print(f"seeds {result.seeds}, {result.seconds:.1f} s")
    for key, s in result.summary.items():
        if any(word in key for word in ("test_mse", "gap")):
            print(f"{key:45s} {s['mean']:.3f}  [{s['low']:.3f}, {s['high']:.3f}]")
    for figure in result.figures:
        display(Image(filename=f"{out}/{figure}"))  # names beside the JSON

# %% [markdown]
# **How to read it.** The first figure has Fig. 6b's shape: test MSE, generalisation gap and train
# MSE against `L` for the vanilla model and the density model with the same number of circuit
# parameters. The claim would show as the vanilla curves rising with `L` (train MSE falling below
# the noise level while test MSE grows) and the density curves staying low. The second figure is
# Supp. J's: test MSE at the largest `L` against `K` (`K = 1` is the vanilla model), the fitted
# functions on the test grid beside the true polynomial, and the learning curves. At quick size
# neither model is trained (30 epochs of Adam at 0.001), so nothing here speaks to the claim; note
# that a density model with `D = 1` or `2` uploads per sub-unitary cannot represent `T_4` at all
# under the Methods encoding (a degree-`D` Fourier series), which is why density underfits at small
# `L` there. The full run (`qdensity experiment reuploading --full`: both settings, `L` up to 50,
# `K` in {2, 5, 7}, 6 seeds) is what `EXPERIMENTS.md` reports.

"""A toy experiment whose functions the Dask workers import (module level, on the path that
pytest gives this folder): seeded numbers per (setting, seed), a unit that kills its worker
once, the model counts of a seed split into settings."""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np

from qdensity_paper.registry import Experiment


def toy_seed(config: dict, seed: int, progress: bool) -> dict:
    """Per model: a seeded draw that depends only on (model, seed); a curve per model."""
    out: dict = {"seed": seed, "curves": {}}
    for model in config["models"]:
        rng = np.random.default_rng([seed, model])
        value = float(rng.normal())
        marker = config.get("die_once")
        if marker and model == config["models"][0] and seed == 1:
            path = Path(marker)
            if not path.exists():  # the first attempt: the worker process dies mid-unit
                path.write_text(str(os.getpid()))
                os._exit(1)
        time.sleep(float(config.get("sleep", 0.0)))
        out[f"m{model}/value"] = value
        out[f"m{model}/draws"] = rng.normal(size=3)  # numpy array: normalised to a list
        out["curves"][f"m{model}/curve"] = {"x": [1, 2], "y": [value, 2 * value],
                                            "x_label": "x", "y_label": "y"}
    return out


def toy_units(config: dict) -> list[dict]:
    """One unit per model."""
    return [{**config, "models": [m]} for m in config["models"]]


def toy_plot(result, directory):
    return []


SETTINGS = {"models": [0, 1, 2], "sleep": 0.0, "die_once": ""}

TOY = Experiment(name="toy", title="a toy", paper="none", quick=dict(SETTINGS),
                 full=dict(SETTINGS), run_seed=toy_seed, plot=toy_plot,
                 seeds={"quick": 3, "full": 3}, units=toy_units)
WHOLE = Experiment(name="toy-whole", title="the toy, a seed one unit", paper="none",
                   quick=dict(SETTINGS), full=dict(SETTINGS), run_seed=toy_seed, plot=toy_plot,
                   seeds={"quick": 3, "full": 3})

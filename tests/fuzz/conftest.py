"""Writes the fuzzers' tally of inputs tried (see ``_fuzz.py``) when asked to."""

from __future__ import annotations

import json
import os

import pytest
from _fuzz import TALLY


@pytest.fixture(scope="session", autouse=True)
def _write_tally():
    yield
    path = os.environ.get("QDENSITY_FUZZ_COUNTS")
    if path:
        with open(path, "w", encoding="utf-8") as fh:
            json.dump(dict(sorted(TALLY.items())), fh, indent=1)

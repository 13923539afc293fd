"""A ``qdensity sweep`` worker for the tests whose fit never ends: the real command (storage,
heartbeats, trial claims) with the fit replaced by a stall that first creates FLAG, so the test
knows, without racing a 40 ms trial, that this worker is mid-trial.
``python _stalling_worker.py FLAG SWEEP-ARGS...``."""

import sys
import time
from pathlib import Path

from qdensity.cli import main
from qdensity.learning import sweep


def _stall(*args, **kwargs):
    Path(sys.argv[1]).touch()
    while True:
        time.sleep(60)


if __name__ == "__main__":
    sweep._evaluate = _stall
    sys.exit(main(sys.argv[2:]))

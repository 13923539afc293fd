"""A sweep worker for the tests: waits until all its peers have started, then opens the study
on a fresh storage at the same moment as they do and runs cheap trials until the study has
``n`` COMPLETE ones. ``python _race_worker.py STORAGE N START_DIR NAME PEERS``."""

import sys
import time
from pathlib import Path

from qdensity.learning.sweep import open_study, run_trials


def main() -> None:
    storage, n, start, me, peers = sys.argv[1], int(sys.argv[2]), Path(sys.argv[3]), \
        sys.argv[4], int(sys.argv[5])
    (start / me).touch()
    while len(list(start.iterdir())) < peers:  # start together
        time.sleep(0.002)
    study = open_study("race", storage, n_trials=n, grace_period=3)

    def evaluate(trial):
        x = trial.suggest_float("x", 0.0, 1.0)
        trial.set_user_attr("worker", me)
        time.sleep(0.05)
        return x

    run_trials(study, evaluate, n)


if __name__ == "__main__":
    main()

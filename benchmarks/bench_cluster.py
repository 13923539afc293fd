"""One experiment on Dask, side by side: in this process, ``local:1``, ``local:2`` and a
two-worker ``dask scheduler`` on loopback (issue 24).

Every configuration runs the same experiment, mode and seeds
(:func:`qdensity_paper.run`), in a fresh temporary ``--out`` (no resumed units), and
reports:

* wall time of the whole run (cluster start-up included);
* speedup against ``local:1``;
* the sum of the units' own seconds (what the work costs wherever it runs);
* scheduling overhead per unit: ``(wall x workers - sum of unit seconds) / units``, the time
  a worker slot spent not computing, per unit (start-up, shipping, waiting for the last unit).

The ``tcp`` row starts ``dask scheduler`` and two ``dask worker --nworkers 1 --nthreads 1``
processes (subprocesses, loopback) before the clock starts, as a user would have them running;
``local:N`` rows start their LocalCluster inside the timed run. The machine's load average is
printed with the table: on a shared machine the wall times move with it.

Run::

    python benchmarks/bench_cluster.py [--experiment mixing-lemma] [--mode full] [--seeds 4]
        [--configs in-process,local:1,local:2,tcp2] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from qdensity_paper import registry


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class _Scheduler:
    """``dask scheduler`` and two ``dask worker`` subprocesses on loopback."""

    def __init__(self, workers: int = 2):
        self.port = _free_port()
        self.address = f"tcp://127.0.0.1:{self.port}"
        dask = [sys.executable, "-m", "distributed.cli.dask_scheduler"]
        log = subprocess.DEVNULL
        self.procs = [subprocess.Popen([*dask, "--host", "127.0.0.1", "--port", str(self.port),
                                        "--dashboard-address", ":0"], stdout=log, stderr=log)]
        worker = [sys.executable, "-m", "distributed.cli.dask_worker", self.address,
                  "--nworkers", "1", "--nthreads", "1", "--no-dashboard"]
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(
            [str(Path(__file__).resolve().parents[1]), os.environ.get("PYTHONPATH", "")])}
        self.procs += [subprocess.Popen(worker, stdout=log, stderr=log, env=env)
                       for _ in range(workers)]
        from distributed import Client

        with Client(self.address, timeout="60s") as client:
            client.wait_for_workers(workers, timeout=120)

    def close(self) -> None:
        for p in reversed(self.procs):
            p.terminate()
        for p in self.procs:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()


def _one(name: str, mode: str, seeds: int, config: str):
    out = Path(tempfile.mkdtemp(prefix="qdensity-bench-cluster-"))
    scheduler = None
    try:
        if config == "in-process":
            kwargs, workers = {}, 1
        elif config.startswith("local:"):
            kwargs, workers = {"cluster": config}, int(config.split(":")[1])
        elif config == "tcp2":
            scheduler = _Scheduler(2)
            kwargs, workers = {"cluster": scheduler.address}, 2
        else:
            raise ValueError(f"unknown configuration {config!r}")
        t0 = time.perf_counter()
        result = registry.run(name, mode=mode, seeds=seeds, out=out, plot=False,
                              progress=False, **kwargs)
        wall = time.perf_counter() - t0
    finally:
        if scheduler is not None:
            scheduler.close()
        shutil.rmtree(out, ignore_errors=True)
    busy = sum(float(r["seconds"]) for r in result.per_seed)
    units = len(result.per_seed) * len(registry._split(registry.get_experiment(name),
                                                       dict(result.config)))
    return {"config": config, "workers": workers, "wall": wall, "unit_seconds": busy,
            "units": units, "overhead_per_unit": (wall * workers - busy) / units,
            "workers_seen": sorted({w for r in result.per_seed for w in r["worker"].split(", ")})}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--experiment", default="mixing-lemma")
    p.add_argument("--mode", default="full", choices=registry.MODES)
    p.add_argument("--seeds", type=int, default=4)
    p.add_argument("--configs", default="in-process,local:1,local:2,tcp2")
    p.add_argument("--json", default=None, metavar="FILE")
    args = p.parse_args(argv)
    rows = []
    for config in args.configs.split(","):
        rows.append(_one(args.experiment, args.mode, args.seeds, config))
        print(f"  done {config}: {rows[-1]['wall']:.1f} s", file=sys.stderr)
    base = next((r["wall"] for r in rows if r["config"] == "local:1"), rows[0]["wall"])
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    print(f"{args.experiment} --{args.mode}, {args.seeds} seeds; {os.cpu_count()} cores, load "
          f"average {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} (1 / 5 / 15 min)")
    print(f"{'config':<11} {'workers':>7} {'units':>5} {'wall s':>8} {'vs local:1':>10} "
          f"{'unit s':>8} {'overhead/unit s':>15}")
    for r in rows:
        print(f"{r['config']:<11} {r['workers']:>7} {r['units']:>5} {r['wall']:>8.1f} "
              f"{base / r['wall']:>9.2f}x {r['unit_seconds']:>8.1f} "
              f"{r['overhead_per_unit']:>15.2f}")
    if args.json:
        Path(args.json).write_text(json.dumps({"load": load, "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

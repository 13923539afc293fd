"""Shared by the library's and the paper's tests (``tests/``, ``paper/tests/``): Hypothesis
profiles, warning filters, a two-worker Dask cluster on loopback (started once), a real
PostgreSQL server (started once) and fresh optuna storages on it or in an SQLite file."""

from __future__ import annotations

import functools
import logging
import os
import pwd
import shutil
import socket
import subprocess
import tempfile
import uuid
from pathlib import Path

import pytest
from hypothesis import settings


def pytest_configure(config) -> None:
    """Silence scipy's SparseEfficiencyWarning, raised inside Qiskit's sparse ``expm`` when
    ``Operator`` evaluates a ``PauliEvolutionGate``; it says nothing about qdensity."""
    config.addinivalue_line("filterwarnings", "ignore::scipy.sparse.SparseEfficiencyWarning")


# Property tests are reproducible: every run (any pytest-randomly seed, any order, any
# machine) tries the same examples, and no example database carries state between runs.
# HYPOTHESIS_PROFILE=explore draws fresh examples for a local bug hunt.
settings.register_profile("qdensity", derandomize=True, database=None, deadline=None,
                          print_blob=True)
settings.register_profile("explore", derandomize=False, database=None, deadline=None,
                          print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "qdensity"))


@pytest.fixture(scope="session")
def client():
    """A ``distributed.Client`` of a LocalCluster: two worker processes of one thread each on
    127.0.0.1."""
    import distributed  # a core dependency
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       host="127.0.0.1", dashboard_address=":0",
                                       silence_logs=logging.ERROR)
    with distributed.Client(cluster) as c:
        yield c
    cluster.close()


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _unavailable(reason: str):
    """Skip, or fail where CI requires the server (QDENSITY_REQUIRE_POSTGRES=1, .ci/run)."""
    if os.environ.get("QDENSITY_REQUIRE_POSTGRES") == "1":
        pytest.fail(f"a PostgreSQL server is required here and cannot start: {reason}")
    pytest.skip(f"no PostgreSQL server: {reason}")


@pytest.fixture(scope="session")
def postgres_server():
    """A real PostgreSQL server (Debian's ``initdb``/``pg_ctl``) in a temporary directory on a
    free loopback port, trust authentication for ``postgres``; stopped at the end. As root it
    runs as the ``postgres`` OS user (the server refuses root). Yields ``(host, port)``."""
    try:
        import psycopg2  # noqa: F401 - the sweep extra's driver
    except ImportError:
        _unavailable("psycopg2 is not installed (pip install -e '.[sweep]')")
    if not (shutil.which("initdb") and shutil.which("pg_ctl")):
        _unavailable("initdb and pg_ctl are not on PATH (apt-get install postgresql)")
    prefix: list[str] = []
    directory = Path(tempfile.mkdtemp(prefix="qdensity-pg-"))
    if os.geteuid() == 0:
        try:
            user = pwd.getpwnam("postgres")
        except KeyError:
            shutil.rmtree(directory, ignore_errors=True)
            _unavailable("running as root and there is no 'postgres' OS user to run it as")
        os.chown(directory, user.pw_uid, user.pw_gid)
        prefix = ["runuser", "-u", "postgres", "--"]
    data, port = directory / "data", _free_port()
    run = functools.partial(subprocess.run, capture_output=True, text=True, timeout=120)
    init = run([*prefix, "initdb", "-D", str(data), "-A", "trust", "-U", "postgres",
                "--no-sync", "-E", "UTF8"])
    if init.returncode != 0:
        shutil.rmtree(directory, ignore_errors=True)
        _unavailable(f"initdb failed: {init.stderr.strip()[-300:]}")
    options = f"-p {port} -k {directory} -c listen_addresses=127.0.0.1 -c fsync=off"
    start = run([*prefix, "pg_ctl", "-D", str(data), "-l", str(directory / "log"), "-o",
                 options, "-w", "-t", "60", "start"])
    if start.returncode != 0:
        log = (directory / "log").read_text() if (directory / "log").exists() else ""
        shutil.rmtree(directory, ignore_errors=True)
        _unavailable(f"pg_ctl start failed: {start.stderr.strip()[-300:]} {log[-300:]}")
    try:
        yield "127.0.0.1", port
    finally:
        run([*prefix, "pg_ctl", "-D", str(data), "-m", "immediate", "stop"])
        shutil.rmtree(directory, ignore_errors=True)


@pytest.fixture
def postgres_url(postgres_server):
    """A fresh database on the server: its SQLAlchemy URL."""
    import psycopg2

    host, port = postgres_server
    name = f"t{uuid.uuid4().hex[:12]}"
    conn = psycopg2.connect(host=host, port=port, user="postgres", dbname="postgres")
    conn.autocommit = True
    with conn.cursor() as cur:
        cur.execute(f"CREATE DATABASE {name}")
    conn.close()
    return f"postgresql+psycopg2://postgres@{host}:{port}/{name}"


@pytest.fixture(params=["sqlite", "postgresql"])
def fresh_storage(request, tmp_path):
    """A fresh optuna storage URL: an SQLite file, or a database on a real PostgreSQL server."""
    if request.param == "sqlite":
        return f"sqlite:///{tmp_path / 'fresh.db'}"
    return request.getfixturevalue("postgres_url")

"""What the cluster tests compare between a run on Dask workers and one in process."""


def science(row: dict) -> dict:
    """A per-seed row without what differs between machines (its time and its worker)."""
    return {k: v for k, v in row.items() if k not in ("seconds", "worker")}

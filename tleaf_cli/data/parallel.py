"""Where the parallel stages run their per-item work: in-process, joblib's local processes
(`jobs`), or the workers of a dask.distributed cluster (`cluster`, an address like
``tcp://host:8786``; needs the optional extra ``tleaf[cluster]``).

`parallel_map` is the one place the stages (compile-dfa, gen-formulas, gen-traces, kb-extract)
call; results come back in input order whatever the backend, so the files written are the same.
On a cluster the same joblib calls run under ``joblib.parallel_config(backend="dask")``; a worker
lost mid-run has its tasks rescheduled by the scheduler on the others.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from typing import Any

from joblib import Parallel, delayed, parallel_config

from tleaf_cli.errors import SettingError

CONNECT_TIMEOUT = 10.0  # seconds to reach the scheduler before giving up


@contextmanager
def cluster_client(address: str, timeout: float | None = None):
    """A `distributed.Client` connected to the scheduler at `address`, closed on exit;
    SettingError("cluster", ...) when distributed is missing or the scheduler cannot be reached
    within `timeout` seconds (default CONNECT_TIMEOUT)."""
    timeout = CONNECT_TIMEOUT if timeout is None else timeout
    try:
        from distributed import Client
    except ImportError:
        raise SettingError(
            "cluster", "needs the optional package distributed: pip install 'tleaf[cluster]'"
        ) from None
    try:
        client = Client(address, timeout=timeout, set_as_default=False)
    except (OSError, TimeoutError, ValueError, TypeError) as e:
        why = str(e).splitlines()[0] if str(e) else type(e).__name__
        raise SettingError(
            "cluster", f"cannot reach a dask scheduler at {address} within {timeout:g} s ({why})"
        ) from None
    try:
        yield client
    finally:
        client.close()


def check_cluster(address: str | None) -> None:
    """SettingError now, before any work, when `address` is given and no scheduler answers there
    (or distributed is missing): a refused call writes nothing."""
    if address:
        with cluster_client(address):
            pass


def parallel_map(
    func: Callable[..., Any],
    arg_tuples: Iterable[tuple],
    jobs: int = 1,
    cluster: str | None = None,
    **parallel_kwargs: Any,
) -> Iterator[Any]:
    """`func(*args)` for each of `arg_tuples`, yielded in input order.

    With `cluster` the calls run on that dask scheduler's workers (`jobs` is then not used);
    else with `jobs` > 1 on joblib's local processes; else here, one after the other.
    `parallel_kwargs` go to `joblib.Parallel` (e.g. batch_size).
    """
    if cluster:
        with cluster_client(cluster) as client, parallel_config(backend="dask", client=client):
            parallel = Parallel(return_as="generator", **parallel_kwargs)
            yield from parallel(delayed(func)(*a) for a in arg_tuples)
    elif jobs == 1:
        for a in arg_tuples:
            yield func(*a)
    else:
        parallel = Parallel(n_jobs=jobs, return_as="generator", **parallel_kwargs)
        yield from parallel(delayed(func)(*a) for a in arg_tuples)

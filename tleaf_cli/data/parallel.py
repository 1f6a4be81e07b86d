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
# parallel_map(share_work=True) hands out items in chunks of at most this many.
SHARE_CHUNK = 32


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
    share_work: bool = False,
    **parallel_kwargs: Any,
) -> Iterator[Any]:
    """`func(*args)` for each of `arg_tuples`, yielded in input order.

    With `cluster` the calls run on that dask scheduler's workers (`jobs` is then not used);
    else with `jobs` > 1 on joblib's local processes; else here, one after the other.
    `parallel_kwargs` go to `joblib.Parallel` (e.g. batch_size).

    `share_work` (local processes only), for many items of a millisecond or less: this process
    works too, so `jobs` counts it, and it starts on the items at once, while the other
    `jobs - 1` workers start (half a second, what a thousand such items take). Items are cut into
    chunks; this process takes them from the front, the workers, once running, from the back, so
    short work never waits for workers and long work uses them all.
    """
    if cluster:
        with cluster_client(cluster) as client, parallel_config(backend="dask", client=client):
            parallel = Parallel(return_as="generator", **parallel_kwargs)
            yield from parallel(delayed(func)(*a) for a in arg_tuples)
    elif jobs == 1:
        for a in arg_tuples:
            yield func(*a)
    elif share_work:
        yield from _shared_map(func, list(arg_tuples), jobs)
    else:
        parallel = Parallel(n_jobs=jobs, return_as="generator", **parallel_kwargs)
        yield from parallel(delayed(func)(*a) for a in arg_tuples)


def _shared_map(func: Callable[..., Any], items: list[tuple], jobs: int) -> Iterator[Any]:
    """`parallel_map(..., share_work=True)`. This process runs the chunks from the front; once a
    probe task says the `jobs - 1` workers of a loky executor (joblib's process pool) have
    started, they are fed chunks from the back, two per worker in flight. Nothing is handed to
    the workers before they run (a pool queues submitted work before its workers exist, which
    would make this process wait for their start-up), so short work never waits; results are
    yielded in input order."""
    from joblib.externals.loky import ProcessPoolExecutor

    size = max(1, min(SHARE_CHUNK, len(items) // (4 * jobs)))
    chunks = [items[i : i + size] for i in range(0, len(items), size)]
    results: list[list[Any] | None] = [None] * len(chunks)
    executor = ProcessPoolExecutor(max_workers=jobs - 1)
    started = executor.submit(_started)
    in_flight: dict[int, Any] = {}  # chunk index -> future, all from the back
    front, back, next_out = 0, len(chunks), 0
    try:
        while front < back:
            if started.done():
                while len(in_flight) < 2 * (jobs - 1) and back - 1 > front:
                    back -= 1
                    in_flight[back] = executor.submit(_run_chunk, func, chunks[back])
            results[front] = _run_chunk(func, chunks[front])
            front += 1
            for k in [k for k, future in in_flight.items() if future.done()]:
                results[k] = in_flight.pop(k).result()
            while next_out < front:  # in order, so progress shows as work is done
                yield from results[next_out] or ()
                results[next_out] = None
                next_out += 1
        for k, future in in_flight.items():
            results[k] = future.result()
        for k in range(next_out, len(chunks)):
            yield from results[k] or ()
    finally:
        for future in in_flight.values():
            future.cancel()
        executor.shutdown(wait=False, kill_workers=True)  # all results are in by now


def _started() -> bool:
    return True


def _run_chunk(func: Callable[..., Any], chunk: list[tuple]) -> list[Any]:
    return [func(*a) for a in chunk]

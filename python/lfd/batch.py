"""Run one function over many recordings: in this process, a local process pool, or Ray.

:func:`run_batch` calls ``func(item)`` for every item and returns one :class:`ItemResult` per
item, in input order, whatever order they finish in. An item whose call raises (or whose worker
process dies) becomes an :class:`ItemResult` with ``error`` set; the batch goes on.

- ``jobs=1`` (or a single item): in this process, one after the other.
- ``jobs=N``: a :class:`concurrent.futures.ProcessPoolExecutor` of N processes started with
  ``spawn`` (MuJoCo/EGL, the engine's thread pool and rich's threads do not survive ``fork``).
- ``ray_address``: Ray tasks, one per item (``"local"``: a new local Ray instance with ``jobs``
  CPUs; ``"auto"`` or ``"HOST:PORT"`` / ``"ray://HOST:PORT"``: an existing cluster). Items are
  sent as they are (paths), so every node must see the recordings at the same path.

``func`` must be a picklable top-level function taking the item (a path) and plain options (bind
them with :func:`functools.partial`). A segmentation method is one such option: an
:class:`lfd.Method` pickles as its portable text (:meth:`lfd.Method.portable`) and is rebuilt,
checked, once per worker process; that is the one way a method reaches a worker.

Only an item's own failure is its result: ``KeyboardInterrupt`` (Ctrl+C, also when it arrives
inside an engine call, which the engine raises as such) stops the whole batch. Workers run with one thread each for the engine (rayon)
and numpy's BLAS (:data:`WORKER_ENV`): the parallelism is across items.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterable, Iterator, Mapping
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, Generic, TypeVar

from .errors import UsageError

T = TypeVar("T")

WORKER_ENV: Mapping[str, str] = {
    "RAYON_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "NUMEXPR_NUM_THREADS": "1",
}
"""Environment of every worker process: one thread per worker for the engine and BLAS."""

RAY_INSTALL_HINT = "--ray needs Ray: pip install 'lfd[ray]'"

WORKER_DIED = "the worker process died"

LOCAL_RAY = "local"
"""``ray_address`` that starts a new local Ray instance with ``jobs`` CPUs."""

RAY_CONNECT_TIMEOUT_S = 15.0
"""How long (s) ``--ray HOST:PORT`` waits for something to answer at that address before it
gives up with one line (Ray itself would retry for minutes)."""


@dataclass
class ItemResult(Generic[T]):
    """What one item of a batch gave: ``value`` or ``error`` (a one-line message)."""

    item: Any
    value: T | None = None
    error: str | None = None
    seconds: float = 0.0
    """Wall time of the call in its worker."""
    warnings: list[str] = field(default_factory=list)
    """The warnings the call raised (one line each, in order, each once)."""
    categories: list[type[Warning]] = field(default_factory=list, repr=False, compare=False)
    """The class of each of :attr:`warnings`."""
    exception: BaseException | None = field(default=None, repr=False, compare=False)
    """The exception itself, when the call ran in this process (``None`` from a worker)."""

    @property
    def ok(self) -> bool:
        return self.error is None


def one_line(err: BaseException) -> str:
    """An exception as one line: its message (an :class:`~lfd.errors.LfdError`'s is meant for
    the user), or ``Type: message`` for anything else."""
    from .errors import LfdError

    text = " ".join(str(err).split())
    if isinstance(err, LfdError):
        return text or type(err).__name__
    if isinstance(err, OSError) and err.strerror:
        where = f"{err.filename}: " if err.filename else ""
        return f"{where}{err.strerror}"
    return f"{type(err).__name__}: {text}" if text else type(err).__name__


def call_item(func: Callable[[Any], T], item: Any) -> ItemResult[T]:
    """``func(item)`` as an :class:`ItemResult`: its value, or the exception as one line."""
    import warnings

    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            value = func(item)
        except Exception as err:  # one item's failure, whatever it is, is that item's result
            res: ItemResult[T] = ItemResult(item, error=one_line(err), exception=err)
        else:
            res = ItemResult(item, value=value)
    res.seconds = time.perf_counter() - t0
    seen: dict[str, type[Warning]] = {}
    for w in caught:
        seen.setdefault(" ".join(str(w.message).split()), w.category)
    res.warnings, res.categories = list(seen), list(seen.values())
    return res


def reemit_warnings(res: ItemResult[Any], prefix: str = "") -> None:
    """Warn again (:func:`warnings.warn`, same classes) what ``res``'s call warned."""
    import warnings

    for message, category in zip(res.warnings, res.categories, strict=False):
        warnings.warn(f"{prefix}{message}", category, stacklevel=2)


def call_in_worker(func: Callable[[Any], T], item: Any) -> ItemResult[T]:
    """:func:`call_item` in a worker: the exception stays there (it may not pickle)."""
    res = call_item(func, item)
    res.exception = None
    return res


def raise_failed(results: Iterable[ItemResult[Any]], name: Callable[[Any], str] = str) -> None:
    """Raise the first failed item's error: its own exception when it ran in this process,
    else :class:`~lfd.errors.BatchError` with ``NAME: message``."""
    from .errors import BatchError

    for res in results:
        if res.exception is not None:
            raise res.exception
        if res.error is not None:
            raise BatchError(f"{name(res.item)}: {res.error}")


def _init_worker() -> None:
    import signal

    os.environ.update(WORKER_ENV)
    # Ctrl+C reaches the whole process group: the parent stops the batch (drops the queued
    # items, waits for the running ones); a worker interrupted mid-task would break the pool
    signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextmanager
def _worker_env(**more: str) -> Iterator[None]:
    """:data:`WORKER_ENV` (and ``more``) in this process's environment while workers start (a
    spawned worker loads numpy and the engine before any initializer runs: they read it then)."""
    env = {**WORKER_ENV, **more}
    old = {k: os.environ.get(k) for k in env}
    os.environ.update(env)
    try:
        yield
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def check_jobs(jobs: int | None) -> int:
    """``jobs`` (default: the machine's cores) checked: a positive number."""
    if jobs is None:
        return os.cpu_count() or 1
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise UsageError(f"--jobs must be a positive number of processes, got {jobs}")
    return jobs


def run_batch(
    func: Callable[[Any], T],
    items: Iterable[Any],
    *,
    jobs: int | None = None,
    ray_address: str | None = None,
    progress: Callable[[ItemResult[T]], Any] | Any | None = None,
) -> list[ItemResult[T]]:
    """``func(item)`` for every item, in parallel; the results in input order.

    Parameters
    ----------
    func : callable
        A picklable top-level function (or :func:`functools.partial` of one) of one item.
    items : iterable
        Usually recording paths; with Ray they are read where they are.
    jobs : int, optional
        Worker processes (default: :func:`os.cpu_count`); 1 runs in this process. With
        ``ray_address="local"`` the CPUs of the local Ray instance; ignored with a cluster.
    ray_address : str, optional
        Run on Ray: ``"local"`` (a new local instance), ``"auto"`` (the cluster this machine
        joined with ``ray start``) or a cluster address. An already initialised Ray is used
        as it is and left running.
    progress : callable or rich.progress.Progress, optional
        Called with each :class:`ItemResult` as it finishes (completion order), in this
        process; or a rich ``Progress``, to which a task of ``len(items)`` steps is added and
        advanced.

    Raises
    ------
    UsageError
        ``jobs`` is not a positive integer, or Ray is asked for but not installed.
    """
    jobs = check_jobs(jobs)
    todo = list(items)
    if progress is not None and hasattr(progress, "add_task"):
        progress = _rich_steps(progress, len(todo))
    if ray_address is not None:
        return _run_ray(func, todo, jobs, ray_address, progress)
    if jobs == 1 or len(todo) <= 1:
        out = []
        for item in todo:
            # the same worker environment is not forced on this process: its threads are free
            res = call_item(func, item)
            out.append(res)
            if progress is not None:
                progress(res)
        return out
    return _run_pool(func, todo, min(jobs, len(todo)), progress)


def _rich_steps(bar: Any, total: int) -> Callable[[ItemResult[Any]], None]:
    task = bar.add_task("recordings", total=total)
    failed = [0]

    def step(res: ItemResult[Any]) -> None:
        failed[0] += 0 if res.ok else 1
        bar.update(
            task,
            advance=1,
            description=f"recordings ({failed[0]} failed)" if failed[0] else "recordings",
        )

    return step


def _run_pool(
    func: Callable[[Any], T],
    items: list[Any],
    jobs: int,
    progress: Callable[[ItemResult[T]], Any] | None,
) -> list[ItemResult[T]]:
    """The items on a pool of ``jobs`` processes, at most ``jobs`` of them in flight at once.

    A worker that dies (a crash in native code) takes the pool down with the items in flight:
    those (at most ``jobs``) are each retried in a process of their own, so only the one that
    crashes fails, and the items not yet started go on in a new pool. If every one of those
    retries dies too and no item has run to its end yet, no worker can run at all: the rest
    fail at once."""
    import multiprocessing
    from collections import deque

    results: list[ItemResult[T] | None] = [None] * len(items)

    def finish(i: int, res: ItemResult[T]) -> None:
        results[i] = res
        if progress is not None:
            progress(res)

    ctx = multiprocessing.get_context("spawn")
    todo = deque(range(len(items)))
    while todo:
        lost = _pool_pass(func, items, todo, jobs, ctx, finish)
        alone = {i: _run_alone(func, items[i], ctx) for i in lost}
        ran = any(r is not None and r.error != WORKER_DIED for r in results)
        if alone and not ran and all(r.error == WORKER_DIED for r in alone.values()):
            for j in [*lost, *todo]:  # every worker so far died, even alone: none can run
                finish(j, ItemResult(items[j], error=f"{WORKER_DIED}; no worker could run"))
            break
        for i, res in alone.items():
            finish(i, res)
    return [
        r if r is not None else ItemResult(items[i], error="not run") for i, r in enumerate(results)
    ]


def _pool_pass(
    func: Callable[[Any], T],
    items: list[Any],
    todo: Any,
    jobs: int,
    ctx: Any,
    finish: Callable[[int, ItemResult[T]], None],
) -> list[int]:
    """Run the indices of ``todo`` (a deque, consumed) on one pool until it is done or a
    worker dies; returns the indices that were in flight when the pool broke."""
    from concurrent.futures.process import BrokenProcessPool

    with (
        _worker_env(),
        ProcessPoolExecutor(max_workers=jobs, mp_context=ctx, initializer=_init_worker) as pool,
    ):
        running: dict[Future[ItemResult[T]], int] = {}
        try:
            while True:
                while todo and len(running) < jobs:  # a free worker takes the next item
                    i = todo.popleft()
                    running[pool.submit(call_in_worker, func, items[i])] = i
                if not running:
                    return []
                finished, _ = wait(set(running), return_when=FIRST_COMPLETED)
                broken = False
                for fut in finished:
                    i = running.pop(fut)
                    try:
                        finish(i, fut.result())
                    except BrokenProcessPool:
                        broken = True
                        running[fut] = i  # lost with the others in flight
                    except Exception as err:  # the result could not be sent back
                        finish(i, ItemResult(items[i], error=one_line(err)))
                if broken:
                    lost = []
                    for fut, i in running.items():
                        if fut.done() and fut.exception() is None:
                            finish(i, fut.result())  # it made it out before the crash
                        else:
                            lost.append(i)
                    return sorted(lost)
        except BaseException:  # Ctrl+C: stop now, neither running nor finishing the rest
            workers = list((getattr(pool, "_processes", None) or {}).values())
            manager = getattr(pool, "_executor_manager_thread", None)
            pool.shutdown(wait=False, cancel_futures=True)
            for proc in workers:
                proc.terminate()
            # the pool's manager thread sees its workers gone and closes its wake-up pipe;
            # until it has, the interpreter's exit hook may write to that pipe as it closes
            # ("Exception ignored ... Bad file descriptor" after "interrupted")
            if manager is not None:
                manager.join(timeout=MANAGER_EXIT_S)
            raise


MANAGER_EXIT_S = 2.0
"""How long Ctrl+C waits for a process pool's manager thread to wind down (it takes
milliseconds once the workers are terminated)."""


def _run_alone(func: Callable[[Any], T], item: Any, ctx: Any) -> ItemResult[T]:
    """One item in a process of its own: a crash of that process is this item's error."""
    from concurrent.futures.process import BrokenProcessPool

    with (
        _worker_env(),
        ProcessPoolExecutor(max_workers=1, mp_context=ctx, initializer=_init_worker) as pool,
    ):
        try:
            return pool.submit(call_in_worker, func, item).result()
        except BrokenProcessPool:
            return ItemResult(item, error=WORKER_DIED)
        except Exception as err:
            return ItemResult(item, error=one_line(err))


def is_recording_folder(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is a folder of recordings (not a ROS 2 bag directory, which is one
    recording: it holds ``metadata.yaml``)."""
    from .inputs import is_ros_path

    return os.path.isdir(path) and not is_ros_path(path)


def mcap_files(inputs: Iterable[str | os.PathLike[str]]) -> list[str]:
    """Each file as given, each directory as its ``*.mcap`` files and ROS 2 bag directories
    (sorted); a ROS 2 bag directory given is one recording. May be empty."""
    from pathlib import Path

    out: list[str] = []
    for it in (os.fspath(i) for i in inputs):
        if is_recording_folder(it):
            found = [f for f in Path(it).iterdir() if f.suffix == ".mcap" and not f.is_dir()]
            found += [f for f in Path(it).iterdir() if f.is_dir() and not is_recording_folder(f)]
            out.extend(str(f) for f in sorted(found))
        else:
            out.append(it)
    return out


def recording_paths(inputs: Iterable[str | os.PathLike[str]]) -> list[str]:
    """The recordings ``inputs`` name (:func:`mcap_files`).

    Raises :class:`UsageError` when there is none (e.g. only empty directories)."""
    given = [os.fspath(it) for it in inputs]
    out = mcap_files(given)
    if not out:
        raise UsageError(f"no .mcap recordings in {' '.join(given)}")
    return out


def _import_ray() -> Any:
    try:
        import ray
    except ModuleNotFoundError as err:
        if (err.name or "").split(".")[0] != "ray":
            raise
        raise UsageError(RAY_INSTALL_HINT) from None
    return ray


def _run_ray(
    func: Callable[[Any], T],
    items: list[Any],
    jobs: int,
    address: str,
    progress: Callable[[ItemResult[T]], Any] | None,
) -> list[ItemResult[T]]:
    ray = _import_ray()
    started_here = not ray.is_initialized()
    if started_here:
        kwargs: dict[str, Any] = {
            "include_dashboard": False,
            "logging_level": "ERROR",
            "log_to_driver": False,
        }
        if address == LOCAL_RAY:
            # the local workers inherit the environment (a runtime_env costs seconds), and run
            # at normal priority, as the local pool's do (Ray's default niceness is 15)
            with _worker_env(RAY_worker_niceness="0"):
                ray.init(num_cpus=jobs, **kwargs)
        else:  # the cluster's nodes get it per job
            check_ray_address(address)
            ray.init(address=address, runtime_env={"env_vars": dict(WORKER_ENV)}, **kwargs)
    try:
        task = ray.remote(num_cpus=1, max_retries=0)(call_in_worker)
        refs = [task.remote(func, item) for item in items]
        index = {ref: i for i, ref in enumerate(refs)}
        results: list[ItemResult[T] | None] = [None] * len(items)
        waiting = list(refs)
        while waiting:
            done, waiting = ray.wait(waiting, num_returns=1)
            for ref in done:
                i = index[ref]
                try:
                    res = ray.get(ref)
                except Exception as err:  # the worker died, the node went away, ...
                    res = ItemResult(items[i], error=_ray_error(err))
                results[i] = res
                if progress is not None:
                    progress(res)
    finally:
        if started_here:
            ray.shutdown()
    return [
        r if r is not None else ItemResult(items[i], error="not run") for i, r in enumerate(results)
    ]


HTTP2_PREFACE = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n" + b"\x00\x00\x00\x04\x00\x00\x00\x00\x00"
"""What an HTTP/2 client sends first (RFC 9113, 3.4): the connection preface and an empty
SETTINGS frame. Ray's cluster address (its GCS) and the Ray Client are gRPC servers, which answer
with a SETTINGS frame of their own; anything else listening there does not."""


def check_ray_address(address: str, timeout_s: float | None = None) -> None:
    """Refuse a cluster address where no Ray cluster answers within ``timeout_s`` (default
    :data:`RAY_CONNECT_TIMEOUT_S`): ``HOST:PORT`` or ``ray://HOST:PORT`` is tried until a TCP
    connection succeeds, and what accepted it must answer the HTTP/2 preface as a gRPC server
    does (:data:`HTTP2_PREFACE`; Ray itself would otherwise retry for minutes); ``auto`` (the
    cluster ``ray start`` recorded) is left to Ray.

    Raises
    ------
    UsageError
        The address is malformed, nothing accepted a connection in time, or what did is not a
        gRPC server.
    """
    import socket

    if address == "auto":
        return
    wait_s = RAY_CONNECT_TIMEOUT_S if timeout_s is None else timeout_s
    host, _, port = address.split("://", 1)[-1].rpartition(":")
    host = host.strip("[]")
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise UsageError(
            f"--ray {address}: expected HOST:PORT, ray://HOST:PORT or auto (a running cluster)"
        )
    deadline = time.monotonic() + wait_s
    while True:
        left = deadline - time.monotonic()
        try:
            conn = socket.create_connection((host, int(port)), timeout=max(0.2, min(left, 5.0)))
        except OSError as err:
            if time.monotonic() + 0.5 >= deadline:
                why = err.strerror or str(err) or type(err).__name__
                raise UsageError(
                    f"--ray {address}: no Ray cluster answered there within {wait_s:g} s "
                    f"({why}); start one with `ray start --head` or check the address"
                ) from None
            time.sleep(0.5)
            continue
        with conn:
            if not _answers_http2(conn, max(1.0, min(deadline - time.monotonic(), 5.0))):
                raise UsageError(
                    f"--ray {address}: something listens there but it is not a Ray cluster (no "
                    "gRPC answer); give the address `ray start --head` printed"
                )
        return


def _answers_http2(conn: Any, timeout_s: float) -> bool:
    """Whether the server on ``conn`` answers :data:`HTTP2_PREFACE` with a SETTINGS frame
    within ``timeout_s``."""
    conn.settimeout(timeout_s)
    try:
        conn.sendall(HTTP2_PREFACE)
        head = b""
        while len(head) < 9:  # a frame header: 3 bytes length, type, flags, stream id
            part = conn.recv(9 - len(head))
            if not part:
                return False
            head += part
    except OSError:  # timed out, reset
        return False
    return head[3] == 0x04


def _ray_error(err: BaseException) -> str:
    name = type(err).__name__
    if "WorkerCrashed" in name or "ActorDied" in name:
        return WORKER_DIED
    if "NodeDied" in name or "ObjectLost" in name:
        return f"the Ray node running it went away ({name})"
    return one_line(err)

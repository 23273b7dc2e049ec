"""Work in several processes, and the threads of the libraries darcyan loads: one way for the
whole package (describing shapes, dense maps, the benchmark), the library's and the command's alike.

darcyan's own work does not gain from more BLAS/OpenMP threads (small products, sparse solves,
nearest neighbours), and the libraries' own thread pools oversubscribe a machine whose cores are
busy: a dense map of a 28k pair took 52 s through the library with the default pools beside a busy
neighbour, 4.5 s with one thread. So the library's entry points (:func:`owns_threads`) run with
:func:`get_threads` threads, 1 by default; :func:`set_threads` (``darcyan.set_threads``), the
environment variable ``DARCYAN_THREADS`` or ``darcyan --threads N`` change it, 0 leaves the
libraries' own pools as they are.

darcyan's own loops that split into independent blocks (the nearest-neighbour searches of dense
maps) run on :func:`own_threads` Python threads, each with its BLAS thread: numpy releases the
interpreter lock in its matrix products, and threads that wait do not spin as a BLAS pool's do.
"""

from __future__ import annotations

import contextlib
import functools
import os
import threading

from .errors import DarcyanError

DEFAULT_THREADS = 1
_threads = {"count": None}  # set_threads's value; None: DARCYAN_THREADS, else DEFAULT_THREADS
_lock = threading.Lock()
_in_worker = {"value": False}  # True in a worker process of process_map: the workers fill the cores
# darcyan's own threads at most: the blocked searches gain little beyond (memory bandwidth).
MAX_OWN_THREADS = 8
_pool = {"pid": None, "threads": 0, "executor": None}
_depth = {"count": 0, "limits": None}  # entry points running in the process; the limit they set
_alone = threading.local()  # .value True: this thread runs pool work (_alone_in_thread), its loops in it alone

# Set to 1 in every worker: libraries that start a thread pool later read them.
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def process_map(function, tasks: list, jobs: int, ordered: bool = False):
    """Yield ``function(task)`` for every task, computed in up to ``jobs`` worker processes:
    as each finishes, or in the order of ``tasks`` with ``ordered``.

    Workers are forked where the platform allows (they start with darcyan imported: a fresh
    interpreter costs ~0.4 s) and keep one BLAS/OpenMP thread each: the workers already fill
    the cores, and a forked worker keeps the parent's thread pool (2 workers x 2 OpenBLAS
    threads made the heat kernel's eigensolver 1.5 to 3 times slower on 2 cores).
    """
    from concurrent.futures import as_completed

    with process_pool(min(jobs, len(tasks))) as pool:
        futures = [pool.submit(function, task) for task in tasks]
        try:
            for future in (futures if ordered else as_completed(futures)):
                yield future.result()
        finally:
            for future in futures:
                future.cancel()


@contextlib.contextmanager
def process_pool(jobs: int):
    """A ``concurrent.futures`` pool of ``jobs`` worker processes, made as :func:`process_map`
    makes its own (forked where the platform allows, one BLAS/OpenMP thread each); work not yet
    started is cancelled when the block ends by an error."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    method = "fork" if "fork" in multiprocessing.get_all_start_methods() else "spawn"
    pool = ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context(method), initializer=_one_thread)
    try:
        yield pool
    except BaseException:
        pool.shutdown(wait=True, cancel_futures=True)
        raise
    pool.shutdown(wait=True)


def _one_thread() -> None:
    from threadpoolctl import threadpool_limits

    _in_worker["value"] = True
    for name in THREAD_VARIABLES:
        os.environ[name] = "1"
    threadpool_limits(1)


def own_threads() -> int:
    """How many threads darcyan's own block-wise loops use (:func:`map_blocks`): the cores this
    process may run on (at most :data:`MAX_OWN_THREADS`), 1 inside a worker of
    :func:`process_map`, whose workers already fill the cores, 1 inside a block of
    :func:`map_blocks` or a task of :func:`side_by_side`, which do, and 1 when the BLAS threads are
    not 1 (:func:`set_threads`: several BLAS threads per block would oversubscribe the cores)."""
    if _in_worker["value"] or getattr(_alone, "value", False) or get_threads() != 1:
        return 1
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cores = os.cpu_count() or 1
    return max(1, min(cores, MAX_OWN_THREADS))


def map_blocks(function, blocks: list) -> list:
    """``[function(block) for block in blocks]``, computed on up to :func:`own_threads` threads
    (in order; each block's result is the same bits whichever thread computes it)."""
    threads = own_threads()
    if threads <= 1 or len(blocks) <= 1:
        return [function(block) for block in blocks]
    return list(_thread_pool(threads).map(functools.partial(_alone_in_thread, function), blocks))


def side_by_side(tasks: list) -> list:
    """``[task() for task in tasks]``, the tasks at once on up to :func:`own_threads` threads
    (this one and the pool's), each task's own :func:`map_blocks` loops in its thread alone:
    for independent pieces of work (a map's two directions) each too small to split well, the
    pieces side by side instead of each split in turn. The results are the same bits either way.
    An error in one task is raised once every task has ended."""
    import concurrent.futures

    threads = own_threads()
    if threads <= 1 or len(tasks) <= 1:
        return [task() for task in tasks]
    others = [_thread_pool(threads).submit(_alone_in_thread, task) for task in tasks[1:]]
    try:
        first = _alone_in_thread(tasks[0])
    finally:
        concurrent.futures.wait(others)  # none left running behind an error
    return [first, *(future.result() for future in others)]


def _alone_in_thread(function, *args):
    """``function(*args)`` with :func:`own_threads` 1 in this thread while it runs: work that runs
    on the pool's threads (a block, a task of :func:`side_by_side`) never waits on the pool, which
    could have no thread left to give."""
    before = getattr(_alone, "value", False)
    _alone.value = True
    try:
        return function(*args)
    finally:
        _alone.value = before


def _thread_pool(threads: int):
    """The process's pool of ``threads`` threads for :func:`map_blocks`, made on first use (and
    anew in a forked child, which has none of its parent's threads): starting threads for every
    search cost more than a small search."""
    from concurrent.futures import ThreadPoolExecutor

    with _lock:
        if _pool["pid"] != os.getpid() or _pool["threads"] != threads:
            _pool.update(pid=os.getpid(), threads=threads,
                         executor=ThreadPoolExecutor(threads, thread_name_prefix="darcyan"))
        return _pool["executor"]


def get_threads() -> int:
    """The BLAS/OpenMP threads darcyan's entry points run with (0: the libraries' own)."""
    if _threads["count"] is not None:
        return _threads["count"]
    value = os.environ.get("DARCYAN_THREADS", "")
    try:
        count = int(value) if value.strip() else DEFAULT_THREADS
    except ValueError:
        count = -1
    if count < 0:
        raise DarcyanError(f"DARCYAN_THREADS must be 0 (the libraries' default) or more threads, got {value!r}")
    return count


def set_threads(count: int | None) -> None:
    """Run darcyan's work with ``count`` BLAS/OpenMP threads (0: the libraries' own pools;
    ``None``: back to ``DARCYAN_THREADS`` or the default, 1)."""
    if count is not None and (not isinstance(count, int) or isinstance(count, bool) or count < 0):
        raise DarcyanError(f"threads must be 0 (the libraries' default) or more, got {count!r}")
    _threads["count"] = count


@contextlib.contextmanager
def limited_threads(count: int | None = None):
    """A context in which the thread pools loaded (and, through the environment, those loaded
    later) run ``count`` threads (default :func:`get_threads`; 0: as they are). The pools and the
    environment belong to the whole process: the first of nested or concurrent contexts (any
    thread) sets the limit, the last to leave restores them."""
    count = get_threads() if count is None else count
    with _lock:
        first = _depth["count"] == 0
        if first and count != 0:
            from threadpoolctl import threadpool_limits

            _depth["saved"] = {name: os.environ.get(name) for name in THREAD_VARIABLES}
            for name in THREAD_VARIABLES:  # for the libraries loaded later (scipy's OpenBLAS, OpenMP)
                os.environ[name] = str(count)
            _depth["limits"] = threadpool_limits(count)  # for those loaded already (numpy's OpenBLAS)
        _depth["count"] += 1
    try:
        yield
    finally:
        with _lock:
            _depth["count"] -= 1
            if _depth["count"] == 0 and _depth.get("limits") is not None:
                _depth["limits"].restore_original_limits()
                for name, value in _depth.pop("saved").items():
                    if value is None:
                        os.environ.pop(name, None)
                    else:
                        os.environ[name] = value
                _depth["limits"] = None


def owns_threads(function):
    """Run ``function`` inside :func:`limited_threads`: an entry point of the library."""

    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        with limited_threads():
            return function(*args, **kwargs)

    return wrapper

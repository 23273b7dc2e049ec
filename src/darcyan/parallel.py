"""Work in several processes, one way for the whole package (describing shapes, the benchmark)."""

from __future__ import annotations

import os

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
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    method = "fork" if "fork" in multiprocessing.get_all_start_methods() else "spawn"
    context = multiprocessing.get_context(method)
    with ProcessPoolExecutor(min(jobs, len(tasks)), mp_context=context, initializer=_one_thread) as pool:
        futures = [pool.submit(function, task) for task in tasks]
        try:
            for future in (futures if ordered else as_completed(futures)):
                yield future.result()
        finally:
            for future in futures:
                future.cancel()


def _one_thread() -> None:
    from threadpoolctl import threadpool_limits

    for name in THREAD_VARIABLES:
        os.environ[name] = "1"
    threadpool_limits(1)

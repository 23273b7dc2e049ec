"""The library's own thread policy (darcyan.parallel): its entry points run BLAS with one thread
by default, whatever the caller's pools, as the command does."""

import os

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

import darcyan
from darcyan.dense.maps import dense_map
from darcyan.dense.seeds import verified_matches
from darcyan.errors import DarcyanError
from darcyan.parallel import limited_threads, owns_threads


def blas_threads() -> set:
    return {pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"}


@owns_threads
def seen_inside() -> set:
    np.ones((64, 64)) @ np.ones((64, 64))  # BLAS is loaded and used
    return blas_threads()


@pytest.fixture(autouse=True)
def default_policy():
    darcyan.set_threads(None)
    yield
    darcyan.set_threads(None)


def test_entry_points_run_one_blas_thread_whatever_the_callers_pools(monkeypatch):
    monkeypatch.delenv("DARCYAN_THREADS", raising=False)
    if not blas_threads():
        pytest.skip("no BLAS thread pool to inspect")
    with threadpool_limits(2):
        assert seen_inside() == {1}
        darcyan.set_threads(0)  # the libraries' own pools: the caller's limit stands
        assert seen_inside() == blas_threads()
        darcyan.set_threads(3)
        assert seen_inside() == {3}
    monkeypatch.setenv("DARCYAN_THREADS", "2")
    darcyan.set_threads(None)
    assert darcyan.get_threads() == 2 and seen_inside() == {2}


def test_an_inner_entry_point_keeps_the_outer_limit():
    if not blas_threads():
        pytest.skip("no BLAS thread pool to inspect")
    with limited_threads(2):
        assert seen_inside() == {2}  # the outer limit holds inside a nested entry point


def test_the_public_entry_points_own_their_threads():
    for function in (darcyan.describe_shape, darcyan.analyze_shape, darcyan.match_shapes, darcyan.load_shape,
                     darcyan.match_files, dense_map, verified_matches):
        assert hasattr(function, "__wrapped__"), function.__name__


@pytest.mark.parametrize("bad", [-1, 1.5, True, "2"])
def test_a_bad_thread_count_is_one_clear_error(bad, monkeypatch):
    with pytest.raises(DarcyanError, match="threads must be"):
        darcyan.set_threads(bad)
    for value in ("many", "-3"):
        monkeypatch.setenv("DARCYAN_THREADS", value)
        with pytest.raises(DarcyanError, match="DARCYAN_THREADS"):
            darcyan.get_threads()


def test_the_commands_thread_setting_does_not_outlive_it(monkeypatch, capsys):
    from darcyan.cli import main

    monkeypatch.delenv("DARCYAN_THREADS", raising=False)
    darcyan.set_threads(3)
    assert main(["features", "missing.off", "--threads", "4"]) == 2  # fails on its input, after setting it
    assert darcyan.get_threads() == 3


def test_limits_set_in_two_threads_are_restored_when_both_leave():
    import threading

    if not blas_threads():
        pytest.skip("no BLAS thread pool to inspect")
    before, omp = blas_threads(), os.environ.get("OMP_NUM_THREADS")
    entered, leave = threading.Barrier(3), threading.Event()

    def hold():
        with limited_threads(1):
            entered.wait()
            leave.wait()

    workers = [threading.Thread(target=hold) for _ in range(2)]
    for worker in workers:
        worker.start()
    entered.wait()
    assert os.environ["OMP_NUM_THREADS"] == "1"  # the process's, whatever each pool's own scope
    leave.set()
    for worker in workers:
        worker.join()
    assert blas_threads() == before and os.environ.get("OMP_NUM_THREADS") == omp


def test_own_threads_split_searches_into_the_same_blocks():
    """darcyan's own threads (map_blocks) give the results of the blocks in order, the same bits
    as one thread; with BLAS threads other than 1 they are one (no oversubscription)."""
    import numpy as np

    from darcyan.geometry.knn import THREADED_SEARCH_MIN, nearest_points, nearest_rows
    from darcyan.parallel import map_blocks, own_threads, set_threads

    assert map_blocks(lambda x: x * x, list(range(10))) == [x * x for x in range(10)]
    rng = np.random.default_rng(0)
    reference, queries = rng.standard_normal((700, 20)), rng.standard_normal((1000, 20))
    threaded = nearest_rows(reference, queries)
    try:
        set_threads(2)
        assert own_threads() == 1
        serial = nearest_rows(reference, queries)
    finally:
        set_threads(None)
    exact = ((queries[:, None, :] - reference[None]) ** 2).sum(axis=2).argmin(axis=1)
    assert np.array_equal(threaded, serial) and (threaded == exact).mean() > 0.99
    # numpy's exact search, by blocks too when large enough to be worth the threads
    few, few_queries = rng.standard_normal((2500, 3)), rng.standard_normal((2000, 3))
    assert len(few) * len(few_queries) >= THREADED_SEARCH_MIN
    threaded = nearest_points(few, few_queries)
    try:
        set_threads(2)
        serial = nearest_points(few, few_queries)
    finally:
        set_threads(None)
    exact = ((few_queries[:200, None, :] - few[None]) ** 2).sum(axis=2).argmin(axis=1)
    assert np.array_equal(threaded, serial) and np.array_equal(threaded[:200], exact)


def test_side_by_side_runs_its_tasks_at_once_in_order_each_with_its_loops_alone():
    import threading

    from darcyan.parallel import own_threads, set_threads, side_by_side

    def where():
        return threading.get_ident(), own_threads()

    threads = own_threads()
    seen = side_by_side([where, where, lambda: "third"])
    assert seen[2] == "third" and [inner for _, inner in seen[:2]] == [1, 1]
    assert (seen[0][0] != seen[1][0]) == (threads > 1) and own_threads() == threads  # restored
    nested = side_by_side([lambda: side_by_side([where, where]), lambda: None])[0]
    assert nested[0] == nested[1] and nested[0][1] == 1  # inside a task: in turn, in its thread
    try:
        set_threads(2)  # BLAS threads: one task after the other, here
        assert {ident for ident, _ in side_by_side([where, where])} == {threading.get_ident()}
    finally:
        set_threads(None)


def test_side_by_side_raises_a_tasks_error_after_every_task_has_ended():
    import threading
    import time

    from darcyan.parallel import own_threads, side_by_side

    if own_threads() < 2:
        pytest.skip("one core: the tasks run in turn")
    ended = threading.Event()

    def slow():
        time.sleep(0.2)
        ended.set()

    def fails():
        raise ValueError("task failed")

    with pytest.raises(ValueError, match="task failed"):
        side_by_side([fails, slow])
    assert ended.is_set()


def test_work_on_the_pools_threads_never_waits_on_the_pool():
    # A block of map_blocks that splits its own work (side_by_side, map_blocks) runs it in its
    # thread: with every pool thread waiting on the pool there would be none left to run it.
    import threading

    from darcyan.parallel import map_blocks, own_threads, side_by_side

    if own_threads() < 2:
        pytest.skip("one core: no pool")

    def block(i):
        inner = side_by_side([threading.get_ident, threading.get_ident])
        nested = map_blocks(lambda j: threading.get_ident(), [0, 1, 2])
        return {*inner, *nested} == {threading.get_ident()} and own_threads() == 1

    found = []
    runner = threading.Thread(target=lambda: found.append(all(map_blocks(block, list(range(8))))), daemon=True)
    runner.start()
    runner.join(timeout=30)  # a deadlock fails here instead of hanging the run
    assert found == [True]

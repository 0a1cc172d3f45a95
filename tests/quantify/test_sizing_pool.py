"""Sizing workers stop when told to, a sizing in flight abandoned (``quantify.identified.stop_pool``)."""

import functools
import signal
import time

from stiction.quantify.identified import TERMINATE_GRACE_S, sizing_pool, stop_pool


def test_stopping_the_pool_ends_a_worker_busy_with_a_long_sizing():
    pool = sizing_pool(1)
    busy = pool.submit(time.sleep, 60)  # a sizing that would outlast any reasonable stop
    queued = pool.submit(time.sleep, 60)
    deadline = time.monotonic() + 60
    while not busy.running() and time.monotonic() < deadline:  # queued for the spawned worker (it may not have it yet)
        time.sleep(0.05)
    assert busy.running()
    workers = list(pool._processes.values())
    t0 = time.monotonic()
    stop_pool(pool)
    assert all(w.exitcode is not None for w in workers), "a worker still runs the abandoned sizing"
    assert time.monotonic() - t0 < 10
    # nothing left waiting: the queued sizing cancelled, or failed with the pool it was handed to
    deadline = time.monotonic() + 10
    while not (busy.done() and queued.done()) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert busy.done() and queued.done()


def test_a_worker_that_does_not_heed_sigterm_is_killed_after_its_grace():
    """A worker that ignores SIGTERM keeps sleeping through it: the stop kills it after ``TERMINATE_GRACE_S``
    instead of leaving it behind."""
    pool = sizing_pool(1, initializer=functools.partial(signal.signal, signal.SIGTERM, signal.SIG_IGN))
    pool.submit(time.sleep, 0).result(timeout=60)  # the worker is up, its initializer run
    busy = pool.submit(time.sleep, 60)
    time.sleep(0.5)  # "running" is said when the item is queued for a worker: give the worker time to take it
    assert busy.running()
    workers = list(pool._processes.values())
    t0 = time.monotonic()
    stop_pool(pool)
    assert all(w.exitcode is not None for w in workers), "a worker that ignores SIGTERM outlived the stop"
    assert TERMINATE_GRACE_S <= time.monotonic() - t0 < TERMINATE_GRACE_S + 5

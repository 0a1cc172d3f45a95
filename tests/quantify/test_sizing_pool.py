"""Sizing workers stop when told to, a sizing in flight abandoned (``quantify.identified.stop_pool``)."""

import time

from stiction.quantify.identified import sizing_pool, stop_pool


def test_stopping_the_pool_ends_a_worker_busy_with_a_long_sizing():
    pool = sizing_pool(1)
    busy = pool.submit(time.sleep, 60)  # a sizing that would outlast any reasonable stop
    queued = pool.submit(time.sleep, 60)
    deadline = time.monotonic() + 60
    while not busy.running() and time.monotonic() < deadline:  # the spawned worker has taken it
        time.sleep(0.05)
    assert busy.running()
    workers = list(pool._processes.values())
    t0 = time.monotonic()
    stop_pool(pool)
    for w in workers:
        w.join(10)
    assert not any(w.is_alive() for w in workers), "a worker still runs the abandoned sizing"
    assert time.monotonic() - t0 < 10
    # nothing left waiting: the queued sizing cancelled, or failed with the pool it was handed to
    deadline = time.monotonic() + 10
    while not (busy.done() and queued.done()) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert busy.done() and queued.done()

"""Heavy calls release the GIL: a Python thread keeps running while they work."""

import threading
import time

import strata
from conftest import scalar_volume


def count_during(call):
    """How often a second Python thread incremented a counter while `call` ran, and how long it took."""
    state = {"count": 0, "stop": False}

    def counter():
        while not state["stop"]:
            state["count"] += 1

    thread = threading.Thread(target=counter)
    thread.start()
    time.sleep(0.05)  # the counter is running before the call starts
    before = state["count"]
    start = time.perf_counter()
    call()
    seconds = time.perf_counter() - start
    during = state["count"] - before
    state["stop"] = True
    thread.join()
    return during, seconds


def test_compress_releases_the_gil(tmp_path):
    volume = scalar_volume((128, 128, 192))  # about half a second on two cores
    # With the GIL held the counter could not run at all while the call lasts; released, it
    # counts millions of times per second even while the compressor's threads share the cores.
    during, seconds = count_during(lambda: strata.compress(volume, tmp_path / "v.strata", rank=16))
    assert seconds > 0.1, "the volume is too small to measure"
    assert during > 20000 * seconds, f"{during} increments in {seconds:.2f} s"


def test_decode_releases_the_gil(tmp_path):
    strata.compress(scalar_volume((64, 64, 96)), tmp_path / "v.strata", rank=16)
    f = strata.open(tmp_path / "v.strata")
    during, seconds = count_during(lambda: [f.read(as_float=True) for _ in range(5)])
    assert during > 20000 * seconds, f"{during} increments in {seconds:.2f} s"

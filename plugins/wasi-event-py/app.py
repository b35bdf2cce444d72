"""Test fixture: every second, triggers with what Python's standard library
reads through WASI: time.time(), time.monotonic_ns() (since the first
check) and os.urandom(). Under the virtual clock all must be
deterministic."""

import os
import time

import wit_world
from radar_guest import Interrupted, sleep_nanos


class WitWorld(wit_world.WitWorld):
    def __init__(self) -> None:
        self.first = None

    def check(self):
        try:
            sleep_nanos(1_000_000_000)
        except Interrupted:
            return None
        now = time.monotonic_ns()
        if self.first is None:
            self.first = now
        return wit_world.Observation(
            wall_ms=int(time.time() * 1000),
            monotonic_ns=now - self.first,
            random=int.from_bytes(os.urandom(8), "little"),
        )

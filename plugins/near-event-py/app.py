"""Near, in Python: reads the blackboard entry `range` every `interval_s`
(0.1 s); once per approach nearer than `near_m` (0.5 m) it writes the
count of approaches to `near-count`, emits its signal `too-near` and
triggers with the range; it emits `clear` when the range is clear again."""

import wit_world
from wit_world.imports import board, signals
from radar_guest import Interrupted, config, info, sleep

# Module-level: what lives between checks.
state = {"near": False, "count": 0}


class WitWorld(wit_world.WitWorld):
    def check(self):
        try:
            sleep(config("interval_s", 0.1))
        except Interrupted:
            return None  # deactivated meanwhile
        range_ = board.read_range()  # None until something writes it
        if range_ is None:
            return None
        near = range_ < config("near_m", 0.5)
        was_near = state["near"]
        state["near"] = near
        if near and not was_near:
            state["count"] += 1
            board.write_near_count(state["count"])
            signals.too_near(range_)
            info(f"too near: {range_:.2f} m")
            return range_
        if was_near and not near:
            signals.clear()
        return None

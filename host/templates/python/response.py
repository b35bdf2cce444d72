"""`{{plugin}}`: a response. `start` runs when it is started, one step a
second for `steps` steps (default 3); an interruption ends it at its next
`sleep`, then `interrupt` and `exit` run."""

from radar_guest import State, config, info, sleep
from wit_world import exports

# What the plugin keeps, also across a hot swap.
state = State(starts=0)


class Slots(exports.Slots):
    def start(self, payload: int) -> int:
        state.starts += 1
        info(f"started with {payload} (start {state.starts})")
        steps = config("steps", 3)
        for step in range(1, steps + 1):
            sleep(config("interval_s", 1.0))  # an interruption ends `start`
            info(f"step {step}")
        return steps

    def interrupt(self) -> None:
        info("interrupted")

    # Always runs last: after `start` returns, after a fault (on a fresh
    # instance) and when the run is stopped. Stop the motors here, with
    # constants, so that running it twice is harmless. For a fail-safe that
    # holds even when this cannot run, see radar.toml.
    def exit(self) -> None:
        info("exit")

    # Hand the state over on a hot swap.
    snapshot = state.snapshot
    restore = state.restore

"""`{{plugin}}`: an event. `check` runs again and again while the event is
connected; returning a value triggers it with that payload. Every
`every`-th check (default 3) triggers, one check a second."""

import wit_world
from radar_guest import Interrupted, State, config, info, sleep

# What the plugin keeps, also across a hot swap: a new version of this
# file carries on from the old one's count.
state = State(checks=0)


class WitWorld(wit_world.WitWorld):
    def check(self):
        try:
            sleep(config("interval_s", 1.0))
        except Interrupted:
            return None  # deactivated meanwhile
        state.checks += 1
        info(f"check {state.checks}")
        return state.checks if state.checks % max(config("every", 3), 1) == 0 else None

    # Hand the state over on a hot swap.
    snapshot = state.snapshot
    restore = state.restore

"""`{{name}}`: an event. `check` runs again and again while the event is
connected; returning a value triggers it with that payload. Every
`every`-th check (default 3) triggers, one check a second."""

import wit_world
from radar_guest import Interrupted, config, info, sleep


class WitWorld(wit_world.WitWorld):
    def __init__(self) -> None:
        self.checks = 0  # lives in the instance, between checks

    def check(self):
        try:
            sleep(config("interval_s", 1.0))
        except Interrupted:
            return None  # deactivated meanwhile
        self.checks += 1
        info(f"check {self.checks}")
        return self.checks if self.checks % max(config("every", 3), 1) == 0 else None

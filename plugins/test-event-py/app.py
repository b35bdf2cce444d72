"""TestEvent (paper Listing 2/3) in Python: counts up to `count_to` (5),
one count every `interval_s` (1 s), then resets its counter and triggers
with the count. The counter lives in the instance, between checks."""

import wit_world
from radar_guest import Interrupted, config, nanos, sleep_nanos


class WitWorld(wit_world.WitWorld):
    def __init__(self) -> None:
        self.count = 0

    def check(self):
        try:
            sleep_nanos(nanos(config("interval_s", 1.0)))
        except Interrupted:
            return None
        count_to = config("count_to", 5)
        self.count += 1
        if self.count < count_to:
            return None
        count, self.count = self.count, 0
        return count

"""TestResponse (paper Listing 2/3) in Python: counts for `count_for_s`
seconds (default 10), one count every `interval_s` (default 1), and may be
interrupted between counts. `start` returns the number of counts made."""

from radar_guest import config, info, nanos, sleep_nanos
from wit_world import exports


class Slots(exports.Slots):
    """The world exports its slots in the interface `slots`."""

    def start(self, trigger: int) -> int:
        interval = nanos(config("interval_s", 1.0))
        total = nanos(config("count_for_s", 10.0))
        counts = total // max(interval, 1)
        info(f"started by a trigger at count {trigger}")
        for count in range(1, counts + 1):
            sleep_nanos(interval)  # an interruption ends `start` with it
            info(f"count {count}")
        return counts

    def interrupt(self) -> None:
        info("interrupted")

    def exit(self) -> None:
        info("exit")

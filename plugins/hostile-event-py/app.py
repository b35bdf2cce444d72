"""Test fixture: a Python event written as its author would, with the
standard library, that does in each check what its `mode` config says:

- `sleep` (the default): `time.sleep(sleep_s)` (0.2), then triggers with the
  number of checks so far every `every` (5) checks: a blocking WASI wait,
  which Radar serves in its own time;
- `log`: logs `bytes` bytes (1 MiB) in lines of 1 KiB, in one call;
- `alloc`: keeps a `mib` MiB (32) bytearray from its first check on.
"""

import time

import wit_world
from radar_guest import config, info

kept = []


class WitWorld(wit_world.WitWorld):
    def __init__(self) -> None:
        self.checks = 0

    def check(self):
        self.checks += 1
        mode = config("mode", "sleep")
        if mode == "sleep":
            time.sleep(config("sleep_s", 0.2))
            if self.checks % config("every", 5) == 0:
                return self.checks
            return None
        if mode == "log":
            line = "x" * 1024
            for _ in range(config("bytes", 1 << 20) // 1024):
                info(line)
            return self.checks
        if mode == "alloc":
            if not kept:
                kept.append(bytearray(config("mib", 32) << 20))
            return self.checks
        return None

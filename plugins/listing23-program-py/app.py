"""The deliberative part of the paper's Listing 2/3 in Python, a component
of the radar:reactive/deliberative world: the same program as
`plugins/listing23-program` (Rust), with the same trace. Connections are
context managers, so RADAR's scoped connections are `with` blocks.

    def do_loop():
        once TestEvent2 interrupt TestResponse
        for ii in range(15): sleep(1)
    def main():
        whenever TestEvent start TestResponse
        do_loop()
        while True: pass
"""

import wit_world
from wit_world.imports import system


def connect(mode, source, target):
    return system.connect(
        system.Link(source, target, mode, None, system.Busy.DROP, 1, None)
    )


def whenever(source, target):
    return connect(system.Mode.WHENEVER, source, target)


def once(source, target):
    return connect(system.Mode.ONCE, source, target)


def sleep(seconds):
    """Waits `seconds` of the system's time (this program has no anonymous
    slots, so nothing else ends the wait)."""
    deadline = system.now() + int(seconds * 1_000_000_000)
    while not isinstance(system.wait(deadline, None), system.Woke_Deadline):
        pass


def do_loop():
    with once("TestEvent2", "TestResponse.interrupt"):
        for _ in range(15):
            sleep(1)


class WitWorld(wit_world.WitWorld):
    def run(self) -> None:
        with whenever("TestEvent", "TestResponse.start"):
            do_loop()
            while True:
                sleep(3600)

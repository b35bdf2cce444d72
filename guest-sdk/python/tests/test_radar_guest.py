"""Checks radar_guest's interruptions outside a component: the modules
componentize-py generates are stood in for by small fakes with the same
shape (an `Err` exception with `.value`, export classes as `Protocol`s).

Run: python3 guest-sdk/python/tests/test_radar_guest.py (the suite does,
from tests/tests/guest_sdk.rs)."""

import enum
import sys
import types as pytypes
import unittest
from pathlib import Path
from typing import Protocol


class Err(Exception):
    """As componentize-py's: an error result, its value in `.value`."""

    def __init__(self, value):
        super().__init__(value)
        self.value = value


class Interruption(enum.Enum):
    INTERRUPT = 0
    EXIT = 1


class Clock:
    """The host's clock: `sleep` fails with `pending` once it is set."""

    pending = None

    def sleep(self, nanos):
        if self.pending is not None:
            raise Err(self.pending)

    def yield_(self):
        self.sleep(0)

    def interrupted(self):
        return self.pending


def install_fakes():
    cpt = pytypes.ModuleType("componentize_py_types")
    cpt.Err = Err
    world = pytypes.ModuleType("wit_world")

    class WitWorld(Protocol):
        pass

    world.WitWorld = WitWorld
    exports = pytypes.ModuleType("wit_world.exports")

    class Slots(Protocol):
        def start(self, trigger: int) -> int:
            raise NotImplementedError

    Slots.__module__ = "wit_world.exports.slots"
    exports.Slots = Slots
    world.exports = exports
    imports = pytypes.ModuleType("wit_world.imports")
    imports.clock = Clock()
    imports.config = pytypes.SimpleNamespace(get=lambda key: None, keys=lambda: [])
    imports.logging = pytypes.SimpleNamespace(log=lambda level, message: None)
    imports.types = pytypes.SimpleNamespace(Level=enum.Enum("Level", "DEBUG INFO WARN ERROR"))
    world.imports = imports
    sys.modules.update(
        {
            "componentize_py_types": cpt,
            "wit_world": world,
            "wit_world.exports": exports,
            "wit_world.imports": imports,
        }
    )
    return imports.clock, Slots


CLOCK, SLOTS = install_fakes()
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import radar_guest  # noqa: E402


class Counter(SLOTS):
    def start(self, trigger: int) -> int:
        radar_guest.sleep(1.0)
        return trigger


class Interruptions(unittest.TestCase):
    def tearDown(self):
        CLOCK.pending = None

    def test_sleep_raises_interrupted_with_the_reason(self):
        CLOCK.pending = Interruption.EXIT
        with self.assertRaises(radar_guest.Interrupted) as caught:
            radar_guest.sleep(0.5)
        self.assertIs(caught.exception.value, Interruption.EXIT)
        with self.assertRaises(radar_guest.Interrupted):
            radar_guest.yield_now()

    def test_except_interrupted_leaves_other_error_results_alone(self):
        with self.assertRaises(Err) as caught:
            try:
                raise Err("no such entry")
            except radar_guest.Interrupted:
                self.fail("an error result that is not an interruption was caught")
        self.assertNotIsInstance(caught.exception, radar_guest.Interrupted)

    def test_an_uncaught_interruption_leaves_start_as_a_plain_err(self):
        CLOCK.pending = Interruption.INTERRUPT
        with self.assertRaises(Err) as caught:
            Counter().start(3)
        self.assertIs(type(caught.exception), Err)
        self.assertIs(caught.exception.value, Interruption.INTERRUPT)

    def test_start_runs_as_written_when_not_interrupted(self):
        self.assertEqual(Counter().start(3), 3)


if __name__ == "__main__":
    unittest.main()

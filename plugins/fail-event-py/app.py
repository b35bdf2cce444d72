"""A TestEvent whose sensor fails: its first check raises, for the test that
an uncaught Python exception becomes a fault that says why."""

import wit_world


class WitWorld(wit_world.WitWorld):
    def check(self):
        raise ValueError("no reading from the range sensor")

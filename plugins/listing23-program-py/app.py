"""The deliberative part of the paper's Listing 2/3 in Python, a component
of the radar:reactive/deliberative world, over the helpers of
`radar_program`: the same program as `plugins/listing23-program` (Rust),
with the same trace. Connections are context managers, so RADAR's scoped
connections are `with` blocks.

    def do_loop():
        once TestEvent2 interrupt TestResponse
        for ii in range(15): sleep(1)
    def main():
        whenever TestEvent start TestResponse
        do_loop()
        while True: pass
"""

from radar_program import once, program, sleep, whenever


def do_loop():
    with once("TestEvent2", "TestResponse.interrupt"):
        for _ in range(15):
            sleep(1)


def main():
    with whenever("TestEvent", "TestResponse"):
        do_loop()
        while True:
            sleep(3600)


WitWorld = program(main)

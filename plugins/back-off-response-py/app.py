"""BackOff, in Python: `start(speed)` sends a whole Twist backing away at
`speed` (its signal `cmd-vel`), says so (`moving`), keeps the command on
the blackboard (`last-command`) and backs away for `back_s` seconds
(default 1); `exit` sends the zero Twist, whatever ended the activation.
The world is `plugins/wit/back-off`, shared with Rust, JavaScript and C."""

from wit_world import exports
from wit_world.imports import board, signals
from wit_world.imports.commands import Motion_Reversing, Motion_Stopped, Twist, Vector3
from radar_guest import config, info, nanos, sleep_nanos


def command(forward: float) -> None:
    twist = Twist(linear=Vector3(x=forward, y=0.0, z=0.0), angular=Vector3(x=0.0, y=0.0, z=0.0))
    signals.cmd_vel(twist)
    board.write_last_command(twist)


class Slots(exports.Slots):
    """The world exports its slots in the interface `slots`."""

    def start(self, speed: float) -> None:
        command(-speed)
        signals.moving(Motion_Reversing(speed))
        sleep_nanos(nanos(config("back_s", 1.0)))  # an interruption ends `start`

    def exit(self) -> None:
        command(0.0)
        signals.moving(Motion_Stopped())
        info("motors stopped")

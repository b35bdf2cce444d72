//! BackOff, in Rust: `start(speed)` sends a whole Twist backing away at
//! `speed` (its signal `cmd-vel`), says so (`moving`), keeps the command on
//! the blackboard (`last-command`) and backs away for `back_s` seconds
//! (default 1); `exit` sends the zero Twist, whatever ended the activation.
//! The world is `plugins/wit/back-off`, shared with Python, JavaScript and C.
use radar_guest::prelude::*;

radar_guest::plugin!(world: "back-off", path: "../wit/back-off");

use exports::radar_examples::back_off::slots::Guest;
use radar_examples::back_off::commands::{Motion, Twist, Vector3};
use radar_examples::back_off::{board, signals};

struct BackOff;

fn twist(forward: f64) -> Twist {
    let zero = Vector3 {
        x: 0.0,
        y: 0.0,
        z: 0.0,
    };
    Twist {
        linear: Vector3 { x: forward, ..zero },
        angular: zero,
    }
}

fn command(forward: f64) {
    let command = twist(forward);
    signals::cmd_vel(command);
    board::write_last_command(command);
}

impl Guest for BackOff {
    fn start(speed: f64) -> Result<(), Interrupted> {
        command(-speed);
        signals::moving(Motion::Reversing(speed));
        sleep(config_secs("back_s", Duration::from_secs(1)))
    }

    fn exit() {
        command(0.0);
        signals::moving(Motion::Stopped);
        info("motors stopped");
    }
}

export!(BackOff);

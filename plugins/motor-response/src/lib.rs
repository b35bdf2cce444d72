//! Test fixture: a robot base's back-off. `start` commands a speed of
//! -0.2 (its signal `command`) and drives for `drive_s` seconds (default
//! 10); `exit` commands 0.0 and logs `motors stopped`: the slot that must
//! run however the activation ended (`docs/semantics.md#exit-always-runs`).
//! It goes wrong where its config says:
//! - `fail`: `trap`, `fuel` (spins), `memory` (allocates without end) in
//!   `start` after `fail_after_ms` (default 500); `interrupt` (its
//!   `interrupt` slot traps); `ignore` (asked to stop, `start` spins and
//!   never returns);
//! - `interrupt_sleep_ms`: `interrupt` sleeps this long (its sleep
//!   ignored if ended early);
//! - `exit_sleep_ms`: `exit` sleeps this long before stopping the motors;
//!   `exit_fail`: `trap` (`exit` traps).
use radar_guest::prelude::*;

radar_guest::plugin!(
    r#"
    package radar-fixtures:motor-response;

    /// What the base is told.
    interface signals {
        /// A speed command, m/s.
        command: func(speed: f64);
    }

    world motor-response {
        include radar:reactive/response@0.1.0;
        use radar:reactive/types@0.1.0.{interruption};
        import signals;
        export start: func() -> result<_, interruption>;
        export interrupt: func();
        export exit: func();
    }
"#
);

use radar_fixtures::motor_response::signals;

struct MotorResponse;

fn spin() -> ! {
    let mut n: u64 = 0;
    loop {
        n = std::hint::black_box(n.wrapping_add(1));
    }
}

impl Guest for MotorResponse {
    fn start() -> Result<(), Interrupted> {
        signals::command(-0.2);
        let fail: String = config_or("fail", String::new());
        let after = Duration::from_millis(config_or("fail_after_ms", 500u64));
        let drive = config_secs("drive_s", Duration::from_secs(10));
        match fail.as_str() {
            "trap" => {
                sleep(after)?;
                panic!("the fixture traps on purpose");
            }
            "fuel" => {
                sleep(after)?;
                spin();
            }
            "memory" => {
                sleep(after)?;
                let mut kept: Vec<Vec<u8>> = Vec::new();
                loop {
                    kept.push(vec![1u8; 1 << 20]);
                    std::hint::black_box(&kept);
                }
            }
            "ignore" => {
                if sleep(drive).is_err() {
                    spin();
                }
                Ok(())
            }
            _ => sleep(drive),
        }
    }

    fn interrupt() {
        if config_or("fail", String::new()) == "interrupt" {
            panic!("the fixture's interrupt traps on purpose");
        }
        let pause = config_or("interrupt_sleep_ms", 0u64);
        if pause > 0 {
            let _ = sleep(Duration::from_millis(pause));
        }
        info("interrupted");
    }

    fn exit() {
        let pause = config_or("exit_sleep_ms", 0u64);
        if pause > 0 {
            let _ = sleep(Duration::from_millis(pause));
        }
        if config_or("exit_fail", String::new()) == "trap" {
            panic!("the fixture's exit traps on purpose");
        }
        signals::command(0.0);
        info("motors stopped");
    }
}

export!(MotorResponse);

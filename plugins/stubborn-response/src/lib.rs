//! Test fixture: `start` ignores the result of `sleep`, so once asked to
//! stop it spins until its fuel runs out. Its `interrupt` and `exit` slots
//! log, to show that they still run, on a fresh instance.
use radar_guest::prelude::*;

radar_guest::plugin!(
    r#"
    package radar-fixtures:stubborn-response;
    world stubborn-response {
        include radar:reactive/response@0.1.0;
        export start: func();
        export interrupt: func();
        export exit: func();
    }
"#
);

struct StubbornResponse;

impl Guest for StubbornResponse {
    fn start() {
        loop {
            let _ = sleep(Duration::from_secs(1));
        }
    }

    fn interrupt() {
        info("interrupt ran");
    }

    fn exit() {
        info("exit ran");
    }
}

export!(StubbornResponse);

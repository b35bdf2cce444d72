//! Test fixture: `start` sleeps `after_s` seconds (default 1) and then traps
//! (a Rust panic is a wasm `unreachable`). Its exit slot then runs on a
//! fresh instance (`docs/semantics.md#exit-always-runs`).
use radar_guest::prelude::*;

radar_guest::plugin!(
    r#"
    package radar-fixtures:trap-response;
    world trap-response {
        include radar:reactive/response@0.1.0;
        use radar:reactive/types@0.1.0.{interruption};
        export start: func() -> result<_, interruption>;
        export exit: func();
    }
"#
);

struct TrapResponse;

impl Guest for TrapResponse {
    fn start() -> Result<(), Interrupted> {
        sleep(config_secs("after_s", Duration::from_secs(1)))?;
        panic!("the fixture traps on purpose");
    }

    fn exit() {
        info("exit (after the trap, on a fresh instance)");
    }
}

export!(TrapResponse);

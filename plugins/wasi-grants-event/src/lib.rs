//! A test fixture: each check triggers with what the plugin sees of the
//! host's environment through WASI: the variable `ROBOT` (`none` if it
//! cannot see it) and how many variables there are.
use radar_guest::prelude::*;

radar_guest::plugin!(
    r#"
    package radar-examples:wasi-grants-event;
    world wasi-grants-event {
        include radar:reactive/event@0.1.0;
        export check: func() -> option<string>;
    }
"#
);

struct WasiGrantsEvent;

impl Guest for WasiGrantsEvent {
    fn check() -> Option<String> {
        sleep(Duration::from_secs(1)).ok()?;
        let robot = std::env::var("ROBOT").unwrap_or_else(|_| "none".into());
        Some(format!("ROBOT={robot} of {}", std::env::vars().count()))
    }
}

export!(WasiGrantsEvent);

//! A test fixture: each check triggers with what the plugin sees of the
//! host through WASI: the variable `ROBOT` (`none` if it cannot see it),
//! how many variables there are, and the first line of `/data/hello.txt`
//! (`none` if it cannot read it).
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
        let file = std::fs::read_to_string("/data/hello.txt")
            .ok()
            .and_then(|t| t.lines().next().map(str::to_string))
            .unwrap_or_else(|| "none".into());
        Some(format!(
            "ROBOT={robot} of {} file={file}",
            std::env::vars().count()
        ))
    }
}

export!(WasiGrantsEvent);

//! Test fixture: `start` allocates 1 MiB every `every_ms` milliseconds
//! (default 10) and keeps it, until the plugin's memory limit stops it.
use radar_guest::prelude::*;

radar_guest::plugin!(
    r#"
    package radar-fixtures:hog-response;
    world hog-response {
        include radar:reactive/response@0.1.0;
        use radar:reactive/types@0.1.0.{interruption};
        export start: func() -> result<u32, interruption>;
    }
"#
);

struct HogResponse;

impl Guest for HogResponse {
    fn start() -> Result<u32, Interrupted> {
        let every = Duration::from_millis(config_or("every_ms", 10u64));
        let mut kept: Vec<Vec<u8>> = Vec::new();
        loop {
            kept.push(vec![1u8; 1 << 20]);
            sleep(every)?;
        }
    }
}

export!(HogResponse);

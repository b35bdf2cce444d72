//! Test fixture: `start` yields `count` times (default 3), asking
//! `interrupted()` before each yield, and logs what it saw. Exercises the two
//! interruption points that are not `sleep`.
use radar_guest::prelude::*;

radar_guest::plugin!(
    r#"
    package radar-fixtures:yield-response;
    world yield-response {
        include radar:reactive/response@0.1.0;
        use radar:reactive/types@0.1.0.{interruption};
        export start: func() -> result<u32, interruption>;
    }
"#
);

struct YieldResponse;

impl Guest for YieldResponse {
    fn start() -> Result<u32, Interrupted> {
        let count = config_or("count", 3u32);
        for i in 0..count {
            if let Some(why) = interrupted() {
                info(&format!(
                    "interrupted() said {} before yield {i}",
                    why.name()
                ));
                return Err(why);
            }
            yield_now()?;
        }
        Ok(count)
    }
}

export!(YieldResponse);

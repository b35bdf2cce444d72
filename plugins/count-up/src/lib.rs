//! CountUp (paper Listing 1): counts to `count_to` (default 10), one count
//! every `interval_s` (default 0.5 s); interruptible between counts.
use radar_guest::prelude::*;

radar_guest::plugin!(
    r#"
    package radar-examples:count-up;
    world count-up {
        include radar:reactive/response@0.1.0;
        use radar:reactive/types@0.1.0.{interruption};
        /// Counts; returns the count reached.
        export start: func() -> result<u32, interruption>;
        /// Runs after an interrupted start.
        export interrupt: func();
    }
"#
);

struct CountUp;

impl Guest for CountUp {
    fn start() -> Result<u32, Interrupted> {
        let count_to = config_or("count_to", 10u32);
        let interval = config_secs("interval_s", Duration::from_millis(500));
        let mut i = 0;
        while i < count_to {
            sleep(interval)?;
            i += 1;
            info(&format!("i = {i}"));
        }
        Ok(i)
    }

    fn interrupt() {
        info("interrupted before reaching the end");
    }
}

export!(CountUp);

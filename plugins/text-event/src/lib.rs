//! Test fixture: an event whose payload is a string, every `after_s` seconds
//! (default 1); connecting it to a slot that takes a number is refused.
use radar_guest::prelude::*;

radar_guest::plugin!(
    r#"
    package radar-fixtures:text-event;
    world text-event {
        include radar:reactive/event@0.1.0;
        export check: func() -> option<string>;
    }
"#
);

struct TextEvent;

impl Guest for TextEvent {
    fn check() -> Option<String> {
        sleep(config_secs("after_s", Duration::from_secs(1))).ok()?;
        Some("hello".to_string())
    }
}

export!(TextEvent);

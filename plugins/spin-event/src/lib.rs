//! Test fixture: `check` computes forever without calling the host, so only
//! its fuel budget stops it (the plugin then goes to `error`).
radar_guest::plugin!(
    r#"
    package radar-fixtures:spin-event;
    world spin-event {
        include radar:reactive/event@0.1.0;
        export check: func() -> option<u64>;
    }
"#
);

struct SpinEvent;

impl Guest for SpinEvent {
    fn check() -> Option<u64> {
        let mut x: u64 = 1;
        loop {
            x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
        }
    }
}

export!(SpinEvent);

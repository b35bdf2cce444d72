use radar_guest::prelude::*;

radar_guest::plugin! {r#"
    package example:hello;
    world hello { include radar:reactive/event@0.1.0; export check: func() -> option<u32>; }
"#}

struct Hello;
impl Guest for Hello {
    fn check() -> Option<u32> {
        sleep(Duration::from_secs(1)).ok()?; // None if deactivated meanwhile
        Some(42)
    }
}
export!(Hello);

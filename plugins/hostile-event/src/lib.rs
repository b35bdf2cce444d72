//! Test fixture: an event that does, in its `check`, what its `mode`
//! config says; a hostile or careless plugin beside well-behaved ones
//! (`tests/tests/hostile.rs`). Every mode triggers with a byte list:
//!
//! - `sleep`: `std::thread::sleep` for `ms` milliseconds (a blocking WASI
//!   wait), then triggers with the number of checks so far;
//! - `log`: logs `bytes` bytes in lines of `line` bytes, in one call;
//! - `burst`: emits its named signal `tick` `count` times in one call;
//! - `flood`: emits its named signal `chunk` `count` times in one call,
//!   each with `bytes` bytes;
//! - `files`: writes `/data/check-N.txt`, appends to `/data/log.txt`,
//!   reads both back and lists `/data`, and triggers with what it read;
//! - `symlink`: makes the links `/data/up` → `..`, `/data/root` → `/` and
//!   `/data/down` → `sub`, and triggers with which were made (1 a link);
//! - `alloc`: allocates `mib` MiB (touched) on its first check and keeps it;
//! - `payload`: triggers with `bytes` bytes;
//! - `yield`: yields to the scheduler without end, ignoring interruption.
use radar_guest::prelude::*;

radar_guest::plugin!(
    r#"
    package radar-fixtures:hostile-event;

    interface signals {
        tick: func();
        chunk: func(bytes: list<u8>);
    }

    world hostile-event {
        include radar:reactive/event@0.1.0;
        import signals;
        export check: func() -> option<list<u8>>;
    }
"#
);

use radar_fixtures::hostile_event::signals;
use std::cell::{Cell, RefCell};

thread_local! {
    static CHECKS: Cell<u32> = const { Cell::new(0) };
    static KEPT: RefCell<Vec<Vec<u8>>> = const { RefCell::new(Vec::new()) };
}

struct HostileEvent;

impl Guest for HostileEvent {
    fn check() -> Option<Vec<u8>> {
        let n = CHECKS.with(|c| {
            c.set(c.get() + 1);
            c.get()
        });
        let mode: String = config_or("mode", String::new());
        match mode.as_str() {
            "sleep" => {
                std::thread::sleep(Duration::from_millis(config_or("ms", 200)));
                Some(n.to_le_bytes().to_vec())
            }
            "log" => {
                let (bytes, line) = (config_or("bytes", 1usize << 20), config_or("line", 1024));
                let text = "x".repeat(line);
                for _ in 0..bytes.div_ceil(line) {
                    info(&text);
                }
                Some(vec![])
            }
            "burst" => {
                for _ in 0..config_or("count", 20_000u32) {
                    signals::tick();
                }
                Some(vec![])
            }
            "flood" => {
                let chunk = vec![3u8; config_or("bytes", 256usize << 10)];
                for _ in 0..config_or("count", 1_000u32) {
                    signals::chunk(&chunk);
                }
                Some(vec![])
            }
            "files" => Some(files(n)),
            "symlink" => {
                #[allow(deprecated)]
                let made = ["..", "/", "sub"]
                    .iter()
                    .zip(["/data/up", "/data/root", "/data/down"])
                    .map(|(target, link)| u8::from(std::fs::soft_link(target, link).is_ok()))
                    .collect();
                Some(made)
            }
            "alloc" => {
                if n == 1 {
                    let mib = config_or("mib", 32usize);
                    KEPT.with(|k| k.borrow_mut().push(vec![1u8; mib << 20]));
                }
                Some(vec![])
            }
            "payload" => Some(vec![7u8; config_or("bytes", 10usize << 20)]),
            "yield" => loop {
                let _ = yield_now();
            },
            _ => None,
        }
    }
}

/// Writes, appends, reads back and lists: what it read, as bytes.
fn files(n: u32) -> Vec<u8> {
    let name = format!("/data/check-{n}.txt");
    let mut out = Vec::new();
    let wrote = std::fs::write(&name, format!("check {n}\n").repeat(100));
    let appended = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open("/data/log.txt")
        .and_then(|mut f| std::io::Write::write_all(&mut f, format!("{n}\n").as_bytes()));
    out.push(u8::from(wrote.is_ok() && appended.is_ok()));
    if let Ok(text) = std::fs::read_to_string(&name) {
        out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    }
    if let Ok(text) = std::fs::read_to_string("/data/log.txt") {
        out.extend_from_slice(&(text.lines().count() as u32).to_le_bytes());
    }
    if let Ok(entries) = std::fs::read_dir("/data") {
        out.extend_from_slice(&(entries.count() as u32).to_le_bytes());
    }
    out
}

export!(HostileEvent);

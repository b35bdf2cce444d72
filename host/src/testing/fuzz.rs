//! Fuzz targets (`fuzz/`, `docs/testing.md#fuzzing`): what users and the
//! network hand Radar, each as a function of arbitrary bytes that must
//! never panic, hang or take the host down, and whose round trips must
//! hold.
//!
//! The coverage-guided runs (`fuzz/run TARGET`, cargo-fuzz with libFuzzer
//! on the stable toolchain) call these; so does the test suite, on every
//! input a run has kept in `fuzz/corpus/TARGET` and on a few thousand
//! inputs more, so that a crash found once stays fixed.
//!
//! | target | what it reads |
//! |---|---|
//! | [`manifest`] | `radar.toml` text, then the system it describes, built |
//! | [`payload`] | JSON against a WIT type drawn from the bytes, both ways |
//! | [`inputs`] | an `inputs.jsonl` file, then a system fed with it |
//! | [`trace`] | a trace (JSON Lines or MCAP): the laws, comparison, conversion |
//! | [`network`] | ctl's requests, agents' messages, ROS 2 CDR messages |
//! | [`component`] | a component's bytes, loaded and run as a plugin |

use std::path::Path;
use std::time::Duration;

use serde_json::Value as Json;

use crate::clock::ClockKind;
use crate::manifest::Manifest;
use crate::payload::{json_to_val, val_to_json, PayloadType};
use crate::plugin::Limits;
use crate::system::{Link, Plugin, System, SystemBuilder};

/// How long a fuzzed system runs, in virtual time.
const RUN_FOR: Duration = Duration::from_secs(2);

/// Fuel a fuzzed plugin's call may burn: enough to run, little enough to
/// end a loop at once.
const FUEL: u64 = 2_000_000;

/// A system small enough to run many times a second: virtual, a bounded
/// trace, small budgets. Its built-in components come from the compiled
/// cache (the first run fills it); a fuzzed component, new each time, is
/// compiled and not kept.
fn quick(builder: SystemBuilder, cache: bool) -> SystemBuilder {
    let builder = if cache {
        builder
    } else {
        builder.cache_dir(None)
    };
    builder
        .clock(ClockKind::Virtual)
        .trace_limit(Some(10_000))
        .default_limits(Limits {
            fuel_per_call: FUEL,
            memory_bytes: 16 << 20,
            ..Limits::default()
        })
}

/// `radar.toml`: parsed; if it parses, its system built and run for a
/// moment (its plugins built-in ones, or files that are not there).
pub fn manifest(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let dir = Path::new("/nonexistent-radar-fuzz");
    let Ok(manifest) = Manifest::parse(text, &dir.join("radar.toml"), dir) else {
        return;
    };
    let _ = manifest.builds();
    let _ = manifest.nodes();
    let mut manifest = manifest;
    manifest.run_everything_here();
    if let Ok(system) = manifest.add_to(quick(System::builder(), true)).build() {
        let _ = system.run(Some(RUN_FOR));
    }
}

/// A WIT type drawn from the bytes, then JSON (the rest, as text) parsed
/// as a value of that type; a value that parses renders back to JSON that
/// parses to the same value.
pub fn payload(data: &[u8]) {
    let mut bytes = Bytes(data);
    let ty = bytes.payload_type(0);
    let Ok(text) = std::str::from_utf8(bytes.0) else {
        return;
    };
    let Ok(json) = serde_json::from_str::<Json>(text) else {
        return;
    };
    let Ok(val) = json_to_val(&json, &ty) else {
        return;
    };
    let back = val_to_json(&val);
    let again = json_to_val(&back, &ty)
        .unwrap_or_else(|e| panic!("{back} (from {json}) no longer parses as {ty}: {e}"));
    assert_eq!(
        val_to_json(&again),
        back,
        "a value of {ty} renders the same each time"
    );
}

/// An inputs file (`inputs.jsonl`, a recording): parsed; if it parses, a
/// small system (the paper's example) fed with it for a moment.
pub fn inputs(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(inputs) = crate::trace::inputs::parse(text, Path::new("/nonexistent-radar-fuzz")) else {
        return;
    };
    let builder = crate::example::listing23(quick(System::builder(), true)).inputs(&inputs);
    if let Ok(system) = builder.build() {
        let _ = system.run(Some(RUN_FOR));
    }
}

/// A trace: as JSON Lines, the laws checked, explained, compared with
/// itself, and through MCAP and back byte for byte; as MCAP bytes, read.
pub fn trace(data: &[u8]) {
    let mut jsonl = Vec::new();
    let _ = crate::view::mcap::mcap_to_jsonl(data, &mut jsonl);
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(records) = crate::trace::parse_json_lines(text) else {
        return;
    };
    let violations = crate::trace::check(&records);
    let _ = crate::trace::explain(&records, &violations, 5);
    let values = crate::trace::to_values(&records);
    let how = crate::trace::compare::Comparison::default();
    assert!(
        crate::trace::compare::compare(&values, &values, &how).is_none(),
        "a trace agrees with itself"
    );
    let lines = crate::trace::to_json_lines(&records);
    let mut mcap = std::io::Cursor::new(Vec::new());
    if crate::view::mcap::jsonl_to_mcap(lines.as_bytes(), &mut mcap).is_ok() {
        let mut back = Vec::new();
        crate::view::mcap::mcap_to_jsonl(mcap.get_ref(), &mut back)
            .expect("an MCAP trace Radar wrote reads back");
        assert_eq!(
            String::from_utf8_lossy(&back),
            lines,
            "JSON Lines → MCAP → JSON Lines gives the same lines"
        );
    }
}

/// What arrives from the network: the first byte says which kind; a ctl
/// request (its JSON line and a component after it), an agent's message
/// either way, or a ROS 2 message in CDR for a built-in type.
pub fn network(data: &[u8]) {
    let Some((&kind, rest)) = data.split_first() else {
        return;
    };
    match kind % 4 {
        0 => {
            let (head, _component) = crate::network::protocol::split(rest);
            if let Ok(request) = serde_json::from_slice::<crate::network::protocol::Request>(head) {
                let _ = request.command.summary();
                let _ = request.command.changes();
            }
        }
        1 => {
            let _ = serde_json::from_slice::<crate::plugin::remote::ToAgent>(rest);
        }
        2 => {
            let _ = serde_json::from_slice::<crate::plugin::remote::FromAgent>(rest);
        }
        _ => {
            let Some((&which, bytes)) = rest.split_first() else {
                return;
            };
            let names: Vec<&str> = crate::network::ros2::MessageTypes::builtin_names().collect();
            let name = names[usize::from(which) % names.len()];
            let types = crate::network::ros2::MessageTypes::default();
            let Ok(message) = types.load(name) else {
                return;
            };
            if let Ok(value) = crate::network::ros2::cdr::decode(&message, bytes) {
                // What decodes encodes, and decodes to the same value.
                let encoded = crate::network::ros2::cdr::encode(&message, &value)
                    .unwrap_or_else(|e| panic!("{name}: {value} decoded but does not encode: {e}"));
                let again = crate::network::ros2::cdr::decode(&message, &encoded)
                    .unwrap_or_else(|e| panic!("{name}: its own encoding does not decode: {e}"));
                assert_eq!(again, value, "{name}: decode ∘ encode");
            }
        }
    }
}

/// A component's bytes as a plugin: loaded (most bytes are refused, with
/// an error); one that loads runs for a moment beside a response it
/// triggers, under small fuel and memory, and must fault, not take the
/// host down.
pub fn component(data: &[u8]) {
    let builder = quick(System::builder(), false).plugin(Plugin::bytes("Fuzzed", data.to_vec()));
    // An event: connected, so that it runs; a response: started.
    let events = builder
        .plugin(Plugin::bytes(
            "Partner",
            crate::assets::builtin("test-response")
                .expect("built in")
                .to_vec(),
        ))
        .connect(Link::whenever("Fuzzed.triggered", "Partner.start"));
    let system = match events.build() {
        Ok(system) => system,
        Err(_) => {
            let responses = quick(System::builder(), false)
                .plugin(Plugin::bytes("Fuzzed", data.to_vec()))
                .inject_at(Duration::ZERO, "Fuzzed.start", Json::Null);
            match responses.build() {
                Ok(system) => system,
                Err(_) => return,
            }
        }
    };
    // An error is an answer (an injection that does not fit its slot);
    // a panic, a hang or a broken law is not.
    let Ok(report) = system.run(Some(RUN_FOR)) else {
        return;
    };
    let violations = crate::trace::check(&report.trace);
    assert!(
        violations.is_empty(),
        "{}",
        crate::trace::explain(&report.trace, &violations, 3)
    );
}

/// Bytes read from the front, for drawing a type.
struct Bytes<'a>(&'a [u8]);

impl Bytes<'_> {
    fn byte(&mut self) -> u8 {
        match self.0.split_first() {
            Some((&b, rest)) => {
                self.0 = rest;
                b
            }
            None => 0,
        }
    }

    fn name(&mut self) -> String {
        format!("f{}", self.byte() % 8)
    }

    fn payload_type(&mut self, depth: u32) -> PayloadType {
        use PayloadType as P;
        let leaf = depth >= 3;
        match self.byte() % if leaf { 13 } else { 21 } {
            0 => P::Bool,
            1 => P::S8,
            2 => P::U8,
            3 => P::S16,
            4 => P::U16,
            5 => P::S32,
            6 => P::U32,
            7 => P::S64,
            8 => P::U64,
            9 => P::F32,
            10 => P::F64,
            11 => P::Char,
            12 => P::String,
            13 => P::List(Box::new(self.payload_type(depth + 1))),
            14 => {
                let n = self.byte() % 4;
                let mut fields: Vec<(String, PayloadType)> = Vec::new();
                for _ in 0..n {
                    let name = self.name();
                    let ty = self.payload_type(depth + 1);
                    if !fields.iter().any(|(f, _)| *f == name) {
                        fields.push((name, ty));
                    }
                }
                P::Record(fields)
            }
            15 => {
                let n = 1 + self.byte() % 3;
                P::Tuple((0..n).map(|_| self.payload_type(depth + 1)).collect())
            }
            16 => {
                let n = 1 + self.byte() % 3;
                let mut cases: Vec<(String, Option<PayloadType>)> = Vec::new();
                for _ in 0..n {
                    let name = self.name();
                    let ty = self
                        .byte()
                        .is_multiple_of(2)
                        .then(|| self.payload_type(depth + 1));
                    if !cases.iter().any(|(c, _)| *c == name) {
                        cases.push((name, ty));
                    }
                }
                P::Variant(cases)
            }
            17 => {
                let mut names: Vec<String> = Vec::new();
                for _ in 0..1 + self.byte() % 3 {
                    let name = self.name();
                    if !names.contains(&name) {
                        names.push(name);
                    }
                }
                P::Enum(names)
            }
            18 => P::Option(Box::new(self.payload_type(depth + 1))),
            19 => P::Result {
                ok: self
                    .byte()
                    .is_multiple_of(2)
                    .then(|| Box::new(self.payload_type(depth + 1))),
                err: self
                    .byte()
                    .is_multiple_of(2)
                    .then(|| Box::new(self.payload_type(depth + 1))),
            },
            _ => {
                let mut names: Vec<String> =
                    (0..1 + self.byte() % 3).map(|_| self.name()).collect();
                names.sort();
                names.dedup();
                P::Flags(names)
            }
        }
    }
}

//! Hostile and careless plugins, part two: bounded output,
//! payloads and floods, files and values a plugin hands the host. As in
//! `hostile.rs`, each runs beside a well-behaved pair, one at a time.

mod common;

use std::time::Duration;

use common::hostile::*;
use common::*;
use radar::{ClockKind, Limits, Plugin, RadarError, System};
use radar_fixtures::plugins;
use serde_json::{json, Value as Json};

// --- Bounded output -------------------------------------------------------

#[test]
fn a_calls_log_output_is_cut_at_its_budget_with_a_line_that_says_so() {
    let _one = one_at_a_time();
    let before = resident();
    // 256 MiB of log lines in one call.
    let flood = hostile("log")
        .config("bytes", 256u64 << 20)
        .period(Duration::from_secs(10));
    let report = run_beside(
        virtual_system().keep_trace(true).plugin(flood),
        "Hostile",
        3,
    );
    let grew = resident().saturating_sub(before);
    let (bytes, warnings) = log_bytes(&report, "Hostile");
    assert!(bytes <= (1 << 20) + 512, "{bytes} bytes of log kept");
    assert_eq!(warnings.len(), 2, "{warnings:?}");
    assert!(warnings[0].contains("log_bytes"), "{}", warnings[0]);
    assert!(
        warnings[1].starts_with(&format!(
            "{} bytes of log output cut",
            (256 << 20) - (1 << 20)
        )),
        "{}",
        warnings[1]
    );
    assert!(grew < 256 << 20, "the host grew by {grew} bytes");
    assert_eq!(pair_records(&report, true), pair_alone(3));
    // And in every language.
    for (name, path) in [
        ("FloodPy", plugins::HOSTILE_EVENT_PY),
        ("FloodJs", plugins::HOSTILE_EVENT_JS),
    ] {
        let flood = Plugin::file(name, path)
            .config("mode", "log")
            .config("bytes", 2 << 20)
            .period(Duration::from_secs(10));
        let report = run_beside(virtual_system().plugin(flood), name, 1);
        let (bytes, warnings) = log_bytes(&report, name);
        assert!(bytes <= (1 << 20) + 512, "{name}: {bytes}");
        assert_eq!(warnings.len(), 2, "{name}: {warnings:?}");
    }
}

#[test]
fn a_payload_over_its_limit_faults_and_large_allowed_ones_are_cut_in_the_trace() {
    let _one = one_at_a_time();
    let big = hostile("payload").config("bytes", 10 << 20);
    let report = run_beside(virtual_system().plugin(big), "Hostile", 3);
    let faults = faults(&report, "Hostile");
    assert_eq!(faults.len(), 1, "{faults:?}");
    assert!(faults[0].contains("payload_bytes"), "{}", faults[0]);

    // Allowed, every 10 ms of real time, trace and timeline on.
    let limits = Limits {
        payload_bytes: 16 << 20,
        ..Limits::default()
    };
    let before = resident();
    let report = run_beside(
        System::builder()
            .clock(ClockKind::Real)
            .trace_to(radar::timeline::Timeline::new(std::io::sink()))
            .trace_to(radar::trace::JsonLines::new(std::io::sink()))
            .plugin(hostile("payload").config("bytes", 10 << 20).limits(limits)),
        "Hostile",
        3,
    );
    let grew = resident().saturating_sub(before);
    assert!(self::faults(&report, "Hostile").is_empty());
    let triggered = find(
        &records(&report),
        json!({"kind": "signal", "plugin": "Hostile", "signal": "triggered"}),
    );
    assert!(triggered.len() > 3, "{} triggers", triggered.len());
    assert!(
        triggered
            .iter()
            .all(|r| r["payload"] == json!({"$cut": {"bytes": 10 << 20}})),
        "payloads are cut in the trace"
    );
    assert!(grew < 1 << 30, "the host grew by {grew} bytes");
}

#[test]
fn a_flood_of_payloads_into_deliberative_code_waits_within_a_bound_and_the_rest_is_dropped() {
    let _one = one_at_a_time();
    // 200 payloads of 256 KiB in one call, each to an anonymous slot that
    // runs only once the call is over (virtual clock: in turns).
    let flood = hostile("flood")
        .config("count", 200)
        .period(Duration::from_secs(10));
    let taken = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let seen = taken.clone();
    let before = resident();
    let report = beside_the_pair(virtual_system().plugin(flood))
        .build()
        .expect("builds")
        .run_with(Some(Duration::from_secs(3)), move |radar| {
            radar.whenever("E", "R")?.keep();
            radar.whenever_do("Hostile", |_| {})?.keep();
            radar
                .whenever_do("Hostile.chunk", move |_| {
                    seen.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                })?
                .keep();
            Ok::<_, RadarError>(())
        })
        .expect("runs");
    let report = checked(report);
    let grew = resident().saturating_sub(before);
    let trace = records(&report);
    let full = count(
        &trace,
        json!({"kind": "dropped", "to": "(anonymous)", "reason": "queue-full"}),
    );
    let took = taken.load(std::sync::atomic::Ordering::Relaxed);
    assert_eq!(
        took + full,
        200,
        "each payload taken or dropped: {took} + {full}"
    );
    assert!(
        (1..=17).contains(&took),
        "at most 4 MiB waited: {took} taken"
    );
    assert!(faults(&report, "Hostile").is_empty());
    assert!(grew < 1 << 30, "the host grew by {grew} bytes");
    assert_eq!(pair_records(&report, true), pair_alone(3));
}

#[test]
fn a_flood_of_payloads_under_the_real_clock_leaves_the_pair_its_timing() {
    let _one = one_at_a_time();
    // Payloads of 256 KiB back to back, for longer than the run.
    let flood = hostile("flood")
        .config("count", 1_000_000)
        .period(Duration::from_secs(10));
    let report = beside_the_pair(System::builder().clock(ClockKind::Real).plugin(flood))
        .build()
        .expect("builds")
        .run_with(Some(Duration::from_secs(3)), |radar| {
            radar.whenever("E", "R")?.keep();
            radar.whenever_do("Hostile", |_| {})?.keep();
            radar.whenever_do("Hostile.chunk", |_| {})?.keep();
            Ok::<_, RadarError>(())
        })
        .expect("runs");
    let report = checked(report);
    let chunks = count(
        &records(&report),
        json!({"kind": "signal", "plugin": "Hostile", "signal": "chunk"}),
    );
    assert!(chunks > 10, "{chunks} payloads flowed");
    assert_pair_kept_real_time(&records(&report));
}

#[test]
fn the_kept_trace_is_bounded_in_bytes() {
    let _one = one_at_a_time();
    let flood = hostile("log")
        .config("bytes", 1 << 20)
        .period(Duration::from_millis(10));
    let report = beside_the_pair(System::builder().trace_bytes(4 << 20).plugin(flood))
        .build()
        .expect("builds")
        .run_with(Some(Duration::from_secs(2)), |radar| {
            radar.whenever_do("Hostile", |_| {})?.keep();
            Ok::<_, RadarError>(())
        })
        .expect("runs");
    assert!(report.trace_dropped > 0, "older records went");
    let kept: usize = report.trace.iter().map(|r| r.to_json_line().len()).sum();
    assert!(kept < 5 << 20, "{kept} bytes kept");
    assert!(report.trace.last().is_some_and(|r| r.t > ns(1.9)));
}

// --- Files ----------------------------------------------------------------

fn files_run(dir: &std::path::Path) -> String {
    let files = hostile("files")
        .dir(dir, "/data", true)
        .period(Duration::from_millis(250));
    run_beside(virtual_system().plugin(files), "Hostile", 2).trace_json_lines()
}

#[test]
fn file_access_under_a_grant_gives_the_same_trace_on_every_virtual_run() {
    let _one = one_at_a_time();
    let traces: Vec<String> = (0..100)
        .map(|_| {
            let dir = tempfile::tempdir().expect("temp dir");
            files_run(dir.path())
        })
        .collect();
    assert!(
        traces.iter().all(|t| *t == traces[0]),
        "100 runs, one trace"
    );
    // What it read back is what it wrote: each check reads its own file
    // (800 bytes), the log so far, and lists its files and the log.
    let records = radar::trace::parse_json_lines(&traces[0]).expect("parses");
    let payloads: Vec<Json> = radar::trace::to_values(&records)
        .into_iter()
        .filter(|r| r["kind"] == "signal" && r["plugin"] == "Hostile")
        .map(|r| r["payload"].clone())
        .collect();
    assert_eq!(payloads.len(), 9, "checks at 0, 0.25, ..., 2 s");
    let n = |k: u32| k.to_le_bytes().to_vec();
    let expected = |k: u32| {
        let mut p = vec![1u8];
        p.extend(n(800));
        p.extend(n(k));
        p.extend(n(k + 1));
        json!(p)
    };
    assert_eq!(payloads, (1..=9).map(expected).collect::<Vec<_>>());
}

#[test]
fn a_plugins_links_may_only_point_down_into_its_directory() {
    let _one = one_at_a_time();
    let dir = tempfile::tempdir().expect("temp dir");
    let links = hostile("symlink")
        .dir(dir.path(), "/data", true)
        .period(Duration::from_secs(10));
    let report = run_beside(virtual_system().plugin(links), "Hostile", 1);
    let made = find(
        &records(&report),
        json!({"kind": "signal", "plugin": "Hostile", "signal": "triggered"}),
    );
    assert_eq!(made[0]["payload"], json!([0, 0, 1]), "only `down` → sub");
    for escaping in ["up", "root"] {
        assert!(
            std::fs::symlink_metadata(dir.path().join(escaping)).is_err(),
            "{escaping} was not made"
        );
    }
    let down = std::fs::read_link(dir.path().join("down")).expect("a link");
    assert_eq!(down, std::path::Path::new("sub"));
}

// --- Values ---------------------------------------------------------------

#[test]
fn a_resource_typed_payload_is_refused_at_load_naming_the_plugin_and_function() {
    let component = wat::parse_str(
        r#"(component
            (type $r (resource (rep i32)))
            (export $thing "thing" (type $r))
            (core module $m (func (export "check") (result i32) (i32.const 0)))
            (core instance $i (instantiate $m))
            (func $check (result (own $thing))
                (canon lift (core func $i "check")))
            (export "check" (func $check)))"#,
    )
    .expect("valid component text");
    let err = match System::builder()
        .plugin(Plugin::bytes("Handles", component))
        .build()
    {
        Ok(_) => panic!("refused"),
        Err(e) => e.to_string(),
    };
    assert!(!err.contains('\n') && !err.contains("0x"), "{err}");
    assert!(
        err.contains("`Handles`") && err.contains("`check` returns") && err.contains("resource"),
        "{err}"
    );
}

#[test]
fn nan_and_infinities_survive_the_trace_and_a_replay() {
    let _one = one_at_a_time();
    let dir = tempfile::tempdir().expect("temp dir");
    let recording = dir.path().join("in.jsonl");
    let values = ["NaN", "Infinity", "-Infinity"];
    let program = |radar: radar::Radar| {
        radar.whenever("Obstacle.triggered", "Avoid.start")?.keep();
        radar.sleep(Duration::from_secs(2))?;
        let back = radar.board_read("range")?.expect("written");
        assert_eq!(back.to_json(), json!("-Infinity"), "read back as written");
        Ok::<_, RadarError>(())
    };
    let mut builder = virtual_system().record_to(&recording);
    for (i, value) in values.iter().enumerate() {
        builder = builder.write_at(
            Duration::from_millis(500 * (i as u64 + 1)),
            "range",
            json!(value),
        );
    }
    let report = checked(
        radar::example::obstacle(builder)
            .build()
            .expect("builds")
            .run_with(Some(Duration::from_secs(3)), program)
            .expect("runs"),
    );
    let writes: Vec<Json> = find(
        &records(&report),
        json!({"kind": "board-write", "entry": "range"}),
    )
    .iter()
    .map(|r| r["value"].clone())
    .collect();
    assert_eq!(writes, values.map(|v| json!(v)));
    // The recording holds them as written, and replays to the same trace.
    let inputs = radar::trace::inputs::load(&recording).expect("a recording");
    let replay = checked(
        radar::example::obstacle(virtual_system().inputs(&inputs))
            .build()
            .expect("builds")
            .run_with(Some(Duration::from_secs(3)), program)
            .expect("runs"),
    );
    assert_eq!(replay.trace, report.trace);
    assert_eq!(replay.replay_divergence, None);
}

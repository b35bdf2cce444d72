//! ROS 2 time on rmw_zenoh (`docs/ros2.md#sim-time`): a run that follows a
//! simulator's `/clock` (`[ros2] use_sim_time`), and a paced virtual-clock
//! run that publishes its own (`[ros2] publish_clock`, `--pace`), against
//! zenoh-ros2-sdk's publisher and subscriber (`tests/clients/ros2/`).
//! Loopback only, on ports picked free. (The DDS side is in
//! `ros2_dds_time.rs`, against rclpy.)

use std::time::{Duration, Instant};

use serde_json::Value as Json;

use crate::common::{lawful_trace, text};

use super::ros2::{python, Client, Running};

#[test]
fn a_run_that_follows_a_simulators_clock_goes_by_its_time() {
    let python = python();
    // 20 s of the simulator's time, which runs ten times as fast as the
    // wall clock from 1000 s on.
    let run = Running::start(
        |ep| {
            format!(
                "[plugins.Fib]\nwasm = \"{}\"\n\n\
                 [ros2]\nnode = \"radar_sim\"\nlisten = [\"{ep}\"]\nuse_sim_time = true\n",
                radar_fixtures::plugins::FIBONACCI_RESPONSE
            )
        },
        &[
            "--clock",
            "real",
            "--for",
            "20s",
            "--inject",
            r#"5s:Fib.start={"order":5}"#,
        ],
    );
    let simulator = Client::start(
        &python,
        "sim_clock.py",
        &[
            "--port",
            &run.port.to_string(),
            "--factor",
            "10",
            "--timeout",
            "25",
        ],
    );
    assert_eq!(simulator.line(Duration::from_secs(20)), "ready");
    let began = Instant::now();
    let (out, dir) = run.finish(Duration::from_secs(30));
    let took = began.elapsed();
    assert!(out.status.success(), "{}", text(&out.stderr));
    // Its 20 s went by on the simulator's clock, not the wall's: about
    // 2 s of wall time, and not at once.
    assert!(
        (Duration::from_secs(1)..Duration::from_secs(15)).contains(&took),
        "the run took {took:?}"
    );
    let (trace, records) = lawful_trace(&dir.path().join("trace.jsonl"));
    // The injection at 5 s of simulated time, and the plugin's 100 ms
    // steps on the simulator's clock: four feedbacks before its exit.
    let at = |needle: &str| -> Vec<u64> {
        records
            .iter()
            .zip(trace.lines())
            .filter(|(_, line)| line.contains(needle))
            .map(|(r, _)| r.t)
            .collect()
    };
    let injected = at(r#""kind":"inject","to":"Fib.start""#);
    assert_eq!(injected.len(), 1, "{trace}");
    assert!(
        (5_000_000_000..5_500_000_000).contains(&injected[0]),
        "{trace}"
    );
    let feedback = at(r#""signal":"feedback""#);
    assert_eq!(feedback.len(), 4, "{trace}");
    for step in feedback.windows(2) {
        let gap = step[1] - step[0];
        assert!((90_000_000..300_000_000).contains(&gap), "{trace}");
    }
    drop(simulator);
}

#[test]
fn a_paced_virtual_run_publishes_its_clock_for_ros2_nodes() {
    let python = python();
    let run = Running::start(
        |ep| {
            format!(
                "[plugins.Fib]\nwasm = \"{}\"\n\n\
                 [ros2]\nnode = \"radar_clock\"\nlisten = [\"{ep}\"]\npublish_clock = true\n",
                radar_fixtures::plugins::FIBONACCI_RESPONSE
            )
        },
        &["--pace", "1", "--for", "8s"],
    );
    let clock = Client::start(
        &python,
        "subscribe.py",
        &[
            "--port",
            &run.port.to_string(),
            "--topic",
            "/clock",
            "--type",
            "rosgraph_msgs/msg/Clock",
            "--count",
            "100",
            "--timeout",
            "15",
        ],
    );
    assert_eq!(clock.line(Duration::from_secs(20)), "ready");
    let (ok, lines, stderr) = clock.finish();
    assert!(ok, "{stderr}");
    let times: Vec<f64> = lines
        .iter()
        .filter(|l| l.starts_with('{'))
        .map(|l| {
            let message: Json = serde_json::from_str(l).expect("JSON");
            let time = &message["clock"];
            time["sec"].as_f64().expect("sec") + time["nanosec"].as_f64().expect("ns") / 1e9
        })
        .collect();
    // A hundred ticks of the run's own time (it began at 0), in order,
    // about 10 ms apart as the pace keeps it to the wall clock.
    assert_eq!(times.len(), 100, "{lines:?}");
    assert!(times.windows(2).all(|w| w[0] < w[1]), "{times:?}");
    assert!(times[99] < 8.0, "{times:?}");
    let span = times[99] - times[0];
    assert!((0.5..3.0).contains(&span), "{times:?}");
    let (out, _dir) = run.finish(Duration::from_secs(30));
    assert!(out.status.success(), "{}", text(&out.stderr));
}

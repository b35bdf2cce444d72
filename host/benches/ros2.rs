//! A ROS 2 message in → the event triggers → a message out, against the
//! same chain fed by a native blackboard write, interleaved in one run
//! (`docs/ros2.md`, `docs/performance.md`).
//!
//! The obstacle system under the real clock: Obstacle checks `range`
//! every 0.5 ms (its period); Avoid (turning for no time) is started when it comes
//! near, and its `started` is published as a `geometry_msgs/msg/Twist` on
//! `/cmd_vel`. Each sample clears the reading, then sets it near and times
//! until the Twist reaches a plain Zenoh subscriber in this process: fed
//! either by a `sensor_msgs/msg/Range` in CDR put on `/range` (as a ROS 2
//! node on rmw_zenoh sends it) or by `Radar::board_write`. Both pay the same
//! check period; the difference is the ROS 2 way in.
//!
//! `cargo bench -p radar --bench ros2` (`RADAR_ROS2_SAMPLES`, default 300
//! of each).

use std::path::Path;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use radar::network::ros2::{cdr, MessageTypes, Ros2, Ros2Settings};
use radar::{ClockKind, Link, Plugin, System};
use zenoh::Wait;

mod common;

use common::{free_port, summary};

fn main() {
    let samples: usize = std::env::var("RADAR_ROS2_SAMPLES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(300);
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let settings: Ros2Settings = toml::from_str(&format!(
        r#"
listen = ["{endpoint}"]
[[subscribe]]
topic = "/range"
type = "sensor_msgs/msg/Range"
entry = "range"
field = "range"
[[publish]]
signal = "Avoid.started"
topic = "/cmd_vel"
type = "geometry_msgs/msg/Twist"
use_payload = false
values = {{ angular = {{ z = 0.8 }} }}
"#
    ))
    .expect("settings");
    let mut ros2 = Ros2::open(&settings, Path::new(".")).expect("ros2");
    let system = System::builder()
        .clock(ClockKind::Real)
        .trace_to(ros2.tap())
        .plugin(
            Plugin::bytes("Obstacle", radar::assets::OBSTACLE_EVENT)
                .config("near_m", 0.5)
                .config("interval_s", 0)
                .period(Duration::from_micros(500))
                .grant_read(["range"]),
        )
        .plugin(
            Plugin::bytes("Avoid", radar::assets::AVOID_RESPONSE)
                .config("turn_s", 0)
                .grant_write(["avoided"]),
        )
        .connect(Link::whenever("Obstacle.triggered", "Avoid.start"))
        .build()
        .expect("builds");
    ros2.start(&system, None).expect("joins");
    let radar = system.handle();
    // The system is not `Send`: it runs here, the samples on a thread.
    let sampler = std::thread::spawn(move || sample(&radar, &endpoint, samples));
    system.run(None).expect("runs");
    let (via_ros2, native) = sampler.join().expect("the samples");
    println!("message in → trigger → message out (real clock, loopback, 0.5 ms checks)");
    let ros = summary("sensor_msgs/Range on /range → Twist on /cmd_vel", via_ros2);
    let own = summary("Radar::board_write(range) → Twist on /cmd_vel", native);
    println!("ratio at p50: {:.2}×", ros / own);
}

/// Interleaved samples of both ways in, in µs; stops the run at the end.
fn sample(radar: &radar::Radar, endpoint: &str, samples: usize) -> (Vec<f64>, Vec<f64>) {
    let mut config = zenoh::Config::default();
    for (key, value) in [
        ("mode", "\"peer\"".to_string()),
        ("connect/endpoints", format!("[\"{endpoint}\"]")),
        ("scouting/multicast/enabled", "false".to_string()),
        ("scouting/gossip/enabled", "false".to_string()),
    ] {
        config.insert_json5(key, &value).expect("config");
    }
    let session = zenoh::open(config).wait().expect("session");
    let (tx, rx) = mpsc::channel();
    let _twists = session
        .declare_subscriber("0/cmd_vel/geometry_msgs::msg::dds_::Twist_/*")
        .callback(move |_| {
            let _ = tx.send(Instant::now());
        })
        .wait()
        .expect("subscriber");
    let range = MessageTypes::default()
        .load("sensor_msgs/msg/Range")
        .expect("Range");
    let key = format!("0/range/sensor_msgs::msg::dds_::Range_/{}", range.hash);
    let publisher = session
        .declare_publisher(key)
        .express(true)
        .wait()
        .expect("publisher");
    let reading = |metres: f32| {
        cdr::encode(&range, &serde_json::json!({ "range": metres })).expect("encodes")
    };
    std::thread::sleep(Duration::from_secs(1));

    let (mut via_ros2, mut native) = (Vec::new(), Vec::new());
    for i in 0..samples * 2 {
        let ros = i % 2 == 0;
        let write = |metres: f32| {
            if ros {
                publisher.put(reading(metres)).wait().expect("put");
            } else {
                radar
                    .board_write("range", serde_json::json!(metres))
                    .expect("write");
            }
        };
        write(1.0);
        std::thread::sleep(Duration::from_millis(5));
        while rx.try_recv().is_ok() {}
        let began = Instant::now();
        write(0.3);
        let Ok(arrived) = rx.recv_timeout(Duration::from_secs(5)) else {
            eprintln!("no Twist within 5 s: sample left out");
            continue;
        };
        let us = arrived.duration_since(began).as_secs_f64() * 1e6;
        if ros {
            via_ros2.push(us)
        } else {
            native.push(us)
        }
    }
    radar.stop();
    (via_ros2, native)
}

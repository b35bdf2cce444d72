//! Config values set while the system runs (`Radar::configure`,
//! `docs/manifest.md#config`): all of one call land at one place or none
//! does, and the plugin's next read sees them.

use crate::common;

use std::time::Duration;

use common::*;
use radar::{example, ConfigChange, RadarError};
use serde_json::json;

#[test]
fn values_set_together_land_at_one_place_or_not_at_all_and_the_next_read_sees_them() {
    let report = run(example::obstacle(virtual_system()), 6, |radar| {
        let _avoiding = radar.whenever("Obstacle.triggered", "Avoid.start")?;
        radar.board_write("range", json!(2.0))?;
        radar.sleep(Duration::from_secs(1))?;
        // One change that cannot be made: none of them is.
        let unknown = radar.configure(
            vec![
                ConfigChange::new("Obstacle", "near_m", "0.3"),
                ConfigChange::new("Nobody", "near_m", "0.3"),
            ],
            "the test",
        );
        assert!(matches!(unknown, Err(RadarError::UnknownPlugin { .. })));
        let hosts = radar.configure(
            vec![ConfigChange::new("Obstacle", "radar.source", "x")],
            "the test",
        );
        assert!(
            matches!(hosts, Err(RadarError::BadSetting { .. })),
            "{hosts:?}"
        );
        radar.configure(
            vec![
                ConfigChange::new("Obstacle", "near_m", "0.3"),
                ConfigChange::new("Obstacle", "interval_s", "0.2"),
            ],
            "the test",
        )?;
        // 0.4 m is near under 0.5 m, not under 0.3 m.
        radar.board_write("range", json!(0.4))?;
        radar.sleep(Duration::from_secs(1))?;
        radar.board_write("range", json!(0.25))?;
        radar.sleep(Duration::from_secs(1))?;
        Ok(())
    });
    assert_eq!(report.program, Some(Ok(())));
    let trace = records(&report);
    let configured = find(&trace, json!({"kind": "configured"}));
    assert_eq!(configured.len(), 2, "only the change that could be made");
    assert_eq!(configured[0]["t"], json!(ns(1.0)));
    assert_eq!(configured[1]["t"], json!(ns(1.0)));
    assert_eq!(configured[0]["value"], json!("0.3"));
    assert_eq!(configured[1]["key"], json!("interval_s"));
    assert_eq!(configured[0]["from"], json!("the test"));
    // They are consecutive: nothing ran between them.
    let at = |r: &serde_json::Value| trace.iter().position(|x| x == r).expect("in the trace");
    assert_eq!(at(&configured[1]), at(&configured[0]) + 1);
    let triggers: Vec<_> = find(&trace, json!({"kind": "signal", "plugin": "Obstacle"}))
        .iter()
        .map(|r| r["payload"].clone())
        .collect();
    assert_eq!(triggers, [json!(0.25)], "0.4 m no longer counts as near");
}

//! Bench fixture: a camera. Every 1/`fps` s (30) its check triggers with a
//! whole `sensor_msgs/msg/Image` of `width` × `height` (640 × 480) rgb8
//! pixels (921,600 bytes), so that `benches/images.rs` can say what a
//! camera costs a run: trace bytes a second, memory, and what the human
//! views print. Its records are pasted from `radar ros2 show
//! sensor_msgs/msg/Image --wit`.
use radar_guest::prelude::*;

radar_guest::plugin!(
    r#"
    package radar-fixtures:camera-event;

    /// The message it sends.
    interface image-types {
        /// builtin_interfaces/msg/Time
        record time {
            sec: s32,
            nanosec: u32,
        }

        /// std_msgs/msg/Header
        record header {
            stamp: time,
            frame-id: string,
        }

        /// sensor_msgs/msg/Image
        record image {
            header: header,
            height: u32,
            width: u32,
            encoding: string,
            is-bigendian: u8,
            step: u32,
            data: list<u8>,
        }
    }

    world camera-event {
        include radar:reactive/event@0.1.0;
        use image-types.{image};
        /// Triggers with each frame.
        export check: func() -> option<image>;
    }
"#
);

use radar_fixtures::camera_event::image_types::{Header, Time};

struct CameraEvent;

impl Guest for CameraEvent {
    fn check() -> Option<Image> {
        let fps: f64 = config_or("fps", 30.0);
        sleep(Duration::from_secs_f64(1.0 / fps)).ok()?;
        let width: u32 = config_or("width", 640);
        let height: u32 = config_or("height", 480);
        let nanos = now().as_nanos();
        let shade = (nanos / 33_000_000 % 256) as u8;
        Some(Image {
            header: Header {
                stamp: Time {
                    sec: (nanos / 1_000_000_000) as i32,
                    nanosec: (nanos % 1_000_000_000) as u32,
                },
                frame_id: "camera".into(),
            },
            height,
            width,
            encoding: "rgb8".into(),
            is_bigendian: 0,
            step: width * 3,
            data: vec![shade; (width * height * 3) as usize],
        })
    }
}

export!(CameraEvent);

//! Gripper: a response whose slots are the shape of the ROS 2 service
//! `std_srvs/srv/SetBool`, so it can be served as that service
//! (`[[ros2.serve]]`, docs/ros2.md). `start(request)` closes the gripper
//! (`data = true`) or opens it (`false`), which takes `move_ms` (default
//! 300 ms), and replies with what it did; an interrupt stops it half-way.
use radar_guest::prelude::*;

radar_guest::plugin!(
    r#"
    package radar-examples:gripper;

    /// The service's messages, as `radar ros2 show std_srvs/srv/SetBool
    /// --wit` prints them.
    interface messages {
        /// std_srvs/srv/SetBool_Request
        record set-bool-request {
            data: bool,
        }
        /// std_srvs/srv/SetBool_Response
        record set-bool-response {
            success: bool,
            message: string,
        }
    }

    interface slots {
        use radar:reactive/types@0.1.0.{interruption};
        use messages.{set-bool-request, set-bool-response};
        /// Closes (`data`) or opens the gripper.
        start: func(request: set-bool-request) -> result<set-bool-response, interruption>;
    }

    world gripper {
        include radar:reactive/response@0.1.0;
        export slots;
    }
"#
);

use exports::radar_examples::gripper::slots::Guest;
use radar_examples::gripper::messages::{SetBoolRequest, SetBoolResponse};

struct Gripper;

impl Guest for Gripper {
    fn start(request: SetBoolRequest) -> Result<SetBoolResponse, Interrupted> {
        sleep(Duration::from_millis(config_or("move_ms", 300u64)))?;
        Ok(SetBoolResponse {
            success: true,
            message: if request.data { "closed" } else { "opened" }.into(),
        })
    }
}

export!(Gripper);

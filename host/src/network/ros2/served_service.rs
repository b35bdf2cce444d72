//! The DDS side of a response served as a service (`served`): ros2-client's
//! service server. A request starts the response; its activation's
//! `exited` is the reply. A ROS 2 service has no way to say no, so a
//! request whose start is dropped (the response is busy), or whose
//! activation faults, is answered by no reply: the client's own timeout
//! ends its wait, and the trace says why (`dropped`, `fault`).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use crossbeam_channel::{Receiver, RecvTimeoutError};
use ros2_client::dds::Server;
use ros2_client::RmwRequestId;

use super::cdr;
use super::dds_cdr::{Answered, Encoded};
use super::served::{Goals, Offered, Say, Seen, Served, SUCCEEDED};
use crate::system::Radar;

/// The server's thread: requests taken as they come, what the run does
/// heard through `seen`, until `stop` or the run's end.
pub(super) fn serve_dds(
    server: Server<Answered, Encoded>,
    served: Arc<Served>,
    radar: Radar,
    seen: Receiver<Seen>,
    stop: Arc<AtomicBool>,
) {
    let Offered::Service(service) = &served.offered else {
        return;
    };
    let Some(mut requests) = Goals::<RmwRequestId>::new(served.clone(), radar) else {
        return;
    };
    Answered::read_on_this_thread(Arc::new(service.request.clone()));
    loop {
        let mut stopping = stop.load(Ordering::Relaxed);
        let mut say = Vec::new();
        while let Ok(Some((id, request))) = server.receive_request() {
            // A request that does not read as its type gets no reply.
            if let Ok(json) = cdr::decode(&service.request, &request.0) {
                requests.new_goal(id, json, &mut say);
            }
        }
        match seen.recv_timeout(Duration::from_millis(2)) {
            Ok(first) => {
                requests.seen(first, &mut say);
                while let Ok(next) = seen.try_recv() {
                    requests.seen(next, &mut say);
                }
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => stopping = true,
        }
        requests.overdue(&mut say);
        for said in say {
            let Say::Ended(id) = said else { continue };
            let reply = requests
                .known
                .iter()
                .find(|r| r.id == id && r.status == SUCCEEDED)
                .and_then(|r| r.result.clone());
            if let Some(reply) = reply {
                let _ = server.send_response(id, Encoded(reply));
            }
            requests.forget(id);
        }
        if stopping {
            // A moment for the last replies to leave.
            std::thread::sleep(Duration::from_millis(100));
            break;
        }
    }
}

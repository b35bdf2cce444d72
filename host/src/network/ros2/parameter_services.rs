//! The node's six parameter services on the wire (`docs/ros2.md#parameters`):
//! rcl_interfaces' `list_parameters`, `get_parameters`,
//! `get_parameter_types`, `describe_parameters`, `set_parameters` and
//! `set_parameters_atomically` under the node's full name, served on
//! rmw_zenoh or DDS by one thread that answers from the
//! [`Parameters`] table and makes sets on the running system.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use super::cdr;
use super::error::Ros2Error;
use super::parameters::{set, Call, Change, Parameters, Setter};
#[cfg(feature = "dds")]
use super::served_service::DdsRequests;
use super::served_service::{zenoh_server, Requests, ZenohRequests};
use super::types::{MessageTypes, Service};
use crate::error::RadarError;
use crate::scheduler::ConfigChange;
use crate::system::Radar;

/// How often the services look for requests: a parameter call is rare and
/// a person's (`ros2 param`), so 20 ms is soon enough.
const LOOK_EVERY: Duration = Duration::from_millis(20);

/// A parameter service, ready for the wire: what it answers, its full name
/// (`/<namespace>/<node>/<service>`) and its type.
pub(super) struct ParameterService {
    pub(super) call: Call,
    pub(super) name: String,
    pub(super) service: Service,
}

/// The six services of node `node` (its full name, `/ns/node`).
pub(super) fn services(node: &str) -> Result<Vec<ParameterService>, Ros2Error> {
    let types = MessageTypes::default();
    Call::ALL
        .iter()
        .map(|(call, name, ty)| {
            let service = types
                .load_service(&format!("rcl_interfaces/srv/{ty}"))
                .map_err(|e| Ros2Error::Settings(e.to_string()))?;
            Ok(ParameterService {
                call: *call,
                name: format!("{}/{name}", node.trim_end_matches('/')),
                service,
            })
        })
        .collect()
}

/// A set made on the running system: as an outside input from `from`
/// (the service the set came on).
struct OnRun<'a> {
    radar: &'a Radar,
    from: String,
}

impl Setter for OnRun<'_> {
    fn configure(&self, changes: &[Change]) -> Result<(), RadarError> {
        let changes = changes
            .iter()
            .map(|c| ConfigChange::new(&c.plugin, &c.key, &c.text))
            .collect();
        self.radar.configure(changes, &self.from)
    }

    fn refused(&self, command: String, reason: &str) {
        let _ = self.radar.refused(command, self.from.clone(), reason);
    }
}

/// The services' thread: each request answered as it comes, a set made
/// on the run or recorded as refused (`from`: the service it came on),
/// until `stop`.
pub(super) fn serve<R: Requests>(
    mut wires: Vec<(ParameterService, R)>,
    parameters: Arc<Parameters>,
    radar: Radar,
    stop: Arc<AtomicBool>,
) {
    while !stop.load(Ordering::Relaxed) {
        for (service, wire) in &mut wires {
            for (id, bytes) in wire.take() {
                let request = match cdr::decode(&service.service.request, &bytes) {
                    Ok(request) => request,
                    Err(e) => {
                        let why = format!("not a {}: {e}", service.service.request.name);
                        wire.no_reply(id, Some(why));
                        continue;
                    }
                };
                let reply = match service.call {
                    Call::Set | Call::SetAtomically => {
                        let on_run = OnRun {
                            radar: &radar,
                            from: format!("a ROS 2 parameter client ({})", service.name),
                        };
                        set(&parameters, service.call, &request, &on_run)
                    }
                    call => parameters.answer(call, &request),
                };
                match cdr::encode(&service.service.response, &reply) {
                    Ok(bytes) => wire.reply(id, bytes),
                    Err(e) => wire.no_reply(id, Some(e.to_string())),
                }
            }
        }
        std::thread::sleep(LOOK_EVERY);
    }
}

/// rmw_zenoh: the six services of node `node` (each a complete queryable
/// with its liveliness token, endpoints `entity` on) and their thread.
pub(super) fn start_zenoh(
    session: &zenoh::Session,
    node: &super::graph::Node,
    entity: &mut u32,
    parameters: Arc<Parameters>,
    radar: Radar,
    stop: Arc<AtomicBool>,
) -> Result<(JoinHandle<()>, Vec<zenoh::liveliness::LivelinessToken>), Ros2Error> {
    let full = format!("{}/{}", node.namespace.trim_end_matches('/'), node.name);
    let mut tokens = Vec::new();
    let mut wires = Vec::new();
    for service in services(&full)? {
        let (queryable, token) =
            zenoh_server(session, node, *entity, &service.name, &service.service)?;
        *entity += 1;
        tokens.push(token);
        wires.push((service, ZenohRequests::new(queryable)));
    }
    let thread = spawn(move || serve(wires, parameters, radar, stop))?;
    Ok((thread, tokens))
}

/// DDS: the six services of node `name` (its full name) as servers of
/// `node`, and their thread.
#[cfg(feature = "dds")]
pub(super) fn start_dds(
    node: &mut super::dds::DdsNode,
    name: &str,
    parameters: Arc<Parameters>,
    radar: Radar,
    stop: Arc<AtomicBool>,
) -> Result<JoinHandle<()>, Ros2Error> {
    let mut wires = Vec::new();
    for service in services(name)? {
        let server = node.server(&service.name, &service.service)?;
        let request = Arc::new(service.service.request.clone());
        wires.push((service, DdsRequests { server, request }));
    }
    spawn(move || serve(wires, parameters, radar, stop))
}

fn spawn(run: impl FnOnce() + Send + 'static) -> Result<JoinHandle<()>, Ros2Error> {
    std::thread::Builder::new()
        .name("radar-ros2-parameters".into())
        .spawn(run)
        .map_err(|e| Ros2Error::Session(format!("cannot start a thread: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    /// A run that takes every set.
    struct Takes;

    impl Setter for Takes {
        fn configure(&self, _: &[Change]) -> Result<(), RadarError> {
            Ok(())
        }
        fn refused(&self, _: String, _: &str) {}
    }

    fn parameters() -> Parameters {
        Parameters::from_toml("[Avoid]\ndistance = 0.5\nsteps = [1, 2.5]\n")
    }

    #[test]
    fn every_reply_encodes_as_its_service_type_with_rosidls_hashes() {
        let p = parameters();
        // The hashes rosidl wrote into rcl_interfaces' .json files (Kilted).
        let hashes = [
            (
                Call::Describe,
                "RIHS01_845b484d71eb0673dae682f2e3ba3c4851a65a3dcfb97bddd82c5b57e91e4cff",
            ),
            (
                Call::Get,
                "RIHS01_bf9803d5c74cf989a5de3e0c2e99444599a627c7ff75f97b8c05b01003675cbc",
            ),
            (
                Call::GetTypes,
                "RIHS01_da199c878688b3e530bdfe3ca8f74cb9fa0c303101e980a9e8f260e25e1c80ca",
            ),
            (
                Call::List,
                "RIHS01_3e6062bfbb27bfb8730d4cef2558221f51a11646d78e7bb30a1e83afac3aad9d",
            ),
            (
                Call::Set,
                "RIHS01_56eed9a67e169f9cb6c1f987bc88f868c14a8fc9f743a263bc734c154015d7e0",
            ),
            (
                Call::SetAtomically,
                "RIHS01_0e192ef259c07fc3c07a13191d27002222e65e00ccec653ca05e856f79285fcd",
            ),
        ];
        let request = json!({
            "names": ["Avoid.distance", "Avoid.steps"], "prefixes": [], "depth": 0,
            "parameters": [{"name": "Avoid.distance", "value": {"type": 3, "double-value": 0.8}}],
        });
        for (service, (call, hash)) in services("/radar").expect("loads").iter().zip(hashes) {
            assert_eq!(service.call, call);
            assert_eq!(service.service.hash, hash, "{}", service.name);
            let reply = match call {
                Call::Set | Call::SetAtomically => set(&p, call, &request, &Takes),
                call => p.answer(call, &request),
            };
            let bytes = cdr::encode(&service.service.response, &reply)
                .unwrap_or_else(|e| panic!("{}: {e}", service.name));
            assert_eq!(
                cdr::decode(&service.service.response, &bytes).expect("reads"),
                reply,
                "{}",
                service.name
            );
        }
        assert_eq!(
            services("/radar").expect("loads")[3].name,
            "/radar/list_parameters"
        );
    }
}

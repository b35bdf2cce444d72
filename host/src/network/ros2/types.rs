//! Where message, service and action definitions come from (`.msg`,
//! `.srv`, `.action`), and what each becomes for Radar:
//! the definitions built in ([`super::builtin`]) and those in the
//! manifest's `[ros2] msg_paths`, a type with every type it refers to, its
//! RIHS01 hash, and the WIT type its values take on the blackboard and in
//! signals.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::builtin::{BUILTIN, BUILTIN_ACTIONS, BUILTIN_SERVICES};
use super::error::TypeError;
use super::hash::rihs01;
use super::msg::{self, Base, MessageDef, Primitive, Shape};
use crate::payload::PayloadType;

/// Finds message definitions: in `msg_paths` first (folders holding
/// `<pkg>/msg/<Name>.msg`, as a ROS 2 install's `share` does), then among
/// the built-in ones.
#[derive(Clone, Debug, Default)]
pub struct MessageTypes {
    paths: Vec<PathBuf>,
}

/// A message type, ready for the wire (and, whole, for an agent's own
/// node: `super::outlets`).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Message {
    /// `pkg/msg/Name`.
    pub name: String,
    /// `RIHS01_…`.
    pub hash: String,
    /// Its definition and those of every type it refers to, by name.
    pub defs: BTreeMap<String, MessageDef>,
}

/// A service type, ready for the wire: its request and its response.
#[derive(Clone, Debug)]
pub struct Service {
    /// `pkg/srv/Name`.
    pub name: String,
    /// `RIHS01_…` of the service (its request, response and event).
    pub hash: String,
    /// `pkg/srv/Name_Request`.
    pub request: Message,
    /// `pkg/srv/Name_Response`.
    pub response: Message,
}

/// An action type, ready for the wire: its goal, result and feedback, and
/// the services and message an action client and server exchange them
/// through.
#[derive(Clone, Debug)]
pub struct Action {
    /// `pkg/action/Name`.
    pub name: String,
    /// `RIHS01_…` of the action.
    pub hash: String,
    /// `pkg/action/Name_Goal`.
    pub goal: Message,
    /// `pkg/action/Name_Result`.
    pub result: Message,
    /// `pkg/action/Name_Feedback`.
    pub feedback: Message,
    /// `pkg/action/Name_SendGoal`: `{goal_id, goal}` → `{accepted, stamp}`.
    pub send_goal: Service,
    /// `pkg/action/Name_GetResult`: `{goal_id}` → `{status, result}`.
    pub get_result: Service,
    /// `pkg/action/Name_FeedbackMessage`: `{goal_id, feedback}`.
    pub feedback_message: Message,
}

impl MessageTypes {
    /// Definitions from `paths` before the built-in ones.
    pub fn new(paths: Vec<PathBuf>) -> Self {
        Self { paths }
    }

    /// Every built-in type's name.
    pub fn builtin_names() -> impl Iterator<Item = &'static str> {
        BUILTIN.iter().map(|(name, _)| *name)
    }

    /// Every built-in service type's name.
    pub fn builtin_service_names() -> impl Iterator<Item = &'static str> {
        BUILTIN_SERVICES.iter().map(|(name, _)| *name)
    }

    /// Every built-in action type's name.
    pub fn builtin_action_names() -> impl Iterator<Item = &'static str> {
        BUILTIN_ACTIONS.iter().map(|(name, _)| *name)
    }

    /// Type `name` (`pkg/msg/Name`) with everything it refers to; the
    /// error names the type that is missing or cannot be read.
    pub fn load(&self, name: &str) -> Result<Message, TypeError> {
        self.load_type(name).map_err(TypeError)
    }

    /// Service type `name` (`pkg/srv/Name`): its `.srv` file split at
    /// `---` into request and response, with everything they refer to.
    pub fn load_service(&self, name: &str) -> Result<Service, TypeError> {
        self.load_service_type(name).map_err(TypeError)
    }

    fn load_service_type(&self, name: &str) -> Result<Service, String> {
        let (package, base) = interface_name(name, "srv", "a service", "std_srvs/srv/SetBool")?;
        let text = self.service_text(name, package, base)?;
        let [request_text, response_text] = sections(&text).try_into().map_err(|_| {
            format!("{name}: a .srv file has one `---` line, between request and response")
        })?;
        let half = |suffix: &str, lines: &[&str]| {
            let half_name = format!("{package}/srv/{base}_{suffix}");
            let def = msg::parse(&half_name, &lines.join("\n"))?;
            self.load_with(&half_name, def)
        };
        let request = half("Request", &request_text)?;
        let response = half("Response", &response_text)?;
        Ok(Service {
            name: name.to_string(),
            hash: service_hash(name, &request, &response),
            request,
            response,
        })
    }

    /// Action type `name` (`pkg/action/Name`): its `.action` file split at
    /// its `---` lines into goal, result and feedback, with the services
    /// and the feedback message rosidl makes of them.
    pub fn load_action(&self, name: &str) -> Result<Action, TypeError> {
        self.load_action_type(name).map_err(TypeError)
    }

    fn load_action_type(&self, name: &str) -> Result<Action, String> {
        let (package, base) =
            interface_name(name, "action", "an action", "test_msgs/action/Fibonacci")?;
        let text = self.interface_text(name, package, base, "action", BUILTIN_ACTIONS)?;
        let [goal, result, feedback] = sections(&text).try_into().map_err(|_| {
            format!(
                "{name}: an .action file has two `---` lines, between goal, result and feedback"
            )
        })?;
        let part = |suffix: &str, lines: &[&str]| {
            let part_name = format!("{package}/action/{base}_{suffix}");
            let def = msg::parse(&part_name, &lines.join("\n"))?;
            self.load_with(&part_name, def)
        };
        let (goal, result, feedback) = (
            part("Goal", &goal)?,
            part("Result", &result)?,
            part("Feedback", &feedback)?,
        );
        let field = |name: &str, base: Base| msg::Field {
            name: name.to_string(),
            base,
            shape: Shape::One,
        };
        let nested = |name: &str, ty: &str| field(name, Base::Nested(ty.to_string()));
        let uuid = "unique_identifier_msgs/msg/UUID";
        let mut known = goal.defs.clone();
        known.extend(result.defs.clone());
        known.extend(feedback.defs.clone());
        let message = |suffix: &str, fields: Vec<msg::Field>| {
            let full = format!("{package}/action/{base}_{suffix}");
            let def = MessageDef {
                name: full.clone(),
                fields,
            };
            self.load_beside(&full, def, known.clone()).map(|mut m| {
                // Only what the message refers to.
                let used = referred(&full, &m.defs);
                m.defs.retain(|name, _| used.contains(name));
                m.hash = rihs01(&full, &m.defs);
                m
            })
        };
        let service = |suffix: &str, request: Message, response: Message| {
            let full = format!("{package}/action/{base}_{suffix}");
            Service {
                hash: service_hash(&full, &request, &response),
                name: full,
                request,
                response,
            }
        };
        let send_goal = service(
            "SendGoal",
            message(
                "SendGoal_Request",
                vec![nested("goal_id", uuid), nested("goal", &goal.name)],
            )?,
            message(
                "SendGoal_Response",
                vec![
                    field("accepted", Base::Primitive(Primitive::Bool)),
                    nested("stamp", "builtin_interfaces/msg/Time"),
                ],
            )?,
        );
        let get_result = service(
            "GetResult",
            message("GetResult_Request", vec![nested("goal_id", uuid)])?,
            message(
                "GetResult_Response",
                vec![
                    field("status", Base::Primitive(Primitive::I8)),
                    nested("result", &result.name),
                ],
            )?,
        );
        let feedback_message = message(
            "FeedbackMessage",
            vec![nested("goal_id", uuid), nested("feedback", &feedback.name)],
        )?;
        let mut defs = BTreeMap::new();
        for m in [&goal, &result, &feedback, &feedback_message] {
            defs.extend(m.defs.clone());
        }
        for s in [&send_goal, &get_result] {
            defs.extend(service_defs(&s.name, &s.request, &s.response));
        }
        defs.insert(
            name.to_string(),
            MessageDef {
                name: name.to_string(),
                fields: vec![
                    nested("goal", &goal.name),
                    nested("result", &result.name),
                    nested("feedback", &feedback.name),
                    nested("send_goal_service", &send_goal.name),
                    nested("get_result_service", &get_result.name),
                    nested("feedback_message", &feedback_message.name),
                ],
            },
        );
        Ok(Action {
            name: name.to_string(),
            hash: rihs01(name, &defs),
            goal,
            result,
            feedback,
            send_goal,
            get_result,
            feedback_message,
        })
    }

    /// The text of an interface file: `<pkg>/<kind>/<base>.<kind>` under
    /// `msg_paths`, else among `builtin`.
    fn interface_text(
        &self,
        name: &str,
        package: &str,
        base: &str,
        kind: &str,
        builtin: &[(&str, &str)],
    ) -> Result<String, String> {
        let file = format!("{base}.{kind}");
        for dir in &self.paths {
            for candidate in candidates(dir, package, kind, &file) {
                if candidate.is_file() {
                    return std::fs::read_to_string(&candidate)
                        .map_err(|e| format!("cannot read {}: {e}", candidate.display()));
                }
            }
        }
        match builtin.binary_search_by(|(n, _)| (*n).cmp(name)) {
            Ok(i) => Ok(builtin[i].1.to_string()),
            Err(_) => Err(format!(
                "unknown {} type `{name}`{}: not built in (add the folder holding \
                 {package}/{kind}/{file} to [ros2] msg_paths)",
                if kind == "srv" { "service" } else { kind },
                crate::suggest::hint(name, builtin.iter().map(|(n, _)| *n))
            )),
        }
    }

    fn service_text(&self, name: &str, package: &str, base: &str) -> Result<String, String> {
        self.interface_text(name, package, base, "srv", BUILTIN_SERVICES)
    }

    fn load_type(&self, name: &str) -> Result<Message, String> {
        if !msg::is_type_name(name) {
            return Err(format!(
                "`{name}` is not a message type (expected `package/msg/Name`, e.g. \
                 `sensor_msgs/msg/Range`)"
            ));
        }
        let def = self.definition(name)?;
        self.load_with(name, def)
    }

    /// `root` (the definition of `name`) with every type it refers to.
    fn load_with(&self, name: &str, root: MessageDef) -> Result<Message, String> {
        self.load_beside(name, root, BTreeMap::new())
    }

    /// As [`MessageTypes::load_with`], where `known` already holds some of
    /// the types it refers to (the parts of an action).
    fn load_beside(
        &self,
        name: &str,
        root: MessageDef,
        known: BTreeMap<String, MessageDef>,
    ) -> Result<Message, String> {
        let mut defs = known;
        let mut stack = Vec::new();
        for field in &root.fields {
            if let Base::Nested(nested) = &field.base {
                stack.push(nested.clone());
            }
        }
        defs.insert(name.to_string(), root);
        while let Some(next) = stack.pop() {
            if defs.contains_key(&next) {
                continue;
            }
            let def = self.definition(&next).map_err(|e| {
                if next == name {
                    e
                } else {
                    format!("{e} (used by {name})")
                }
            })?;
            for field in &def.fields {
                if let Base::Nested(nested) = &field.base {
                    stack.push(nested.clone());
                }
            }
            defs.insert(next, def);
        }
        refuse_cycles(name, &defs, &mut Vec::new())?;
        Ok(Message {
            name: name.to_string(),
            hash: rihs01(name, &defs),
            defs,
        })
    }

    fn definition(&self, name: &str) -> Result<MessageDef, String> {
        let mut parts = name.split('/');
        let (package, file) = match (parts.next(), parts.next(), parts.next()) {
            (Some(p), Some(_), Some(n)) => (p, format!("{n}.msg")),
            _ => return Err(format!("`{name}` is not a message type")),
        };
        for dir in &self.paths {
            for candidate in candidates(dir, package, "msg", &file) {
                if candidate.is_file() {
                    let text = std::fs::read_to_string(&candidate)
                        .map_err(|e| format!("cannot read {}: {e}", candidate.display()))?;
                    return msg::parse(name, &text)
                        .map_err(|e| format!("{} ({})", e, candidate.display()));
                }
            }
        }
        match BUILTIN.binary_search_by(|(n, _)| (*n).cmp(name)) {
            Ok(i) => msg::parse(name, BUILTIN[i].1),
            Err(_) => Err(format!(
                "unknown message type `{name}`: not built in{} (add its .msg file's folder to \
                 [ros2] msg_paths)",
                if self.paths.is_empty() {
                    String::new()
                } else {
                    format!(
                        ", and no {package}/msg/{file} under {}",
                        self.paths
                            .iter()
                            .map(|p| p.display().to_string())
                            .collect::<Vec<_>>()
                            .join(", ")
                    )
                }
            )),
        }
    }
}

/// `pkg/<kind>/Name` as its package and its name, or an error that says
/// what was expected (`what`: `a service`; `example`: a type of the kind).
fn interface_name<'a>(
    name: &'a str,
    kind: &str,
    what: &str,
    example: &str,
) -> Result<(&'a str, &'a str), String> {
    let parts: Vec<&str> = name.split('/').collect();
    match parts.as_slice() {
        [package, k, base] if *k == kind && msg::is_type_name(&format!("{package}/msg/{base}")) => {
            Ok((package, base))
        }
        _ => Err(format!(
            "`{name}` is not {what} type (expected `package/{kind}/Name`, e.g. `{example}`)"
        )),
    }
}

/// An interface file's lines, in the sections its `---` lines part.
fn sections(text: &str) -> Vec<Vec<&str>> {
    let mut sections = vec![Vec::new()];
    for line in text.lines() {
        if line.trim() == "---" {
            sections.push(Vec::new());
        } else if let Some(section) = sections.last_mut() {
            section.push(line);
        }
    }
    sections
}

/// `name` and every type it refers to, through any number of others.
fn referred(name: &str, defs: &BTreeMap<String, MessageDef>) -> std::collections::BTreeSet<String> {
    let mut seen = std::collections::BTreeSet::new();
    let mut stack = vec![name.to_string()];
    while let Some(next) = stack.pop() {
        if !seen.insert(next.clone()) {
            continue;
        }
        for field in defs
            .get(&next)
            .map(|d| d.fields.as_slice())
            .unwrap_or_default()
        {
            if let Base::Nested(nested) = &field.base {
                stack.push(nested.clone());
            }
        }
    }
    seen
}

/// A type that contains itself, through any number of others, has no
/// finite form: refused, naming the loop.
fn refuse_cycles(
    name: &str,
    defs: &BTreeMap<String, MessageDef>,
    path: &mut Vec<String>,
) -> Result<(), String> {
    if path.iter().any(|p| p == name) {
        path.push(name.to_string());
        return Err(format!(
            "message types that contain themselves: {}",
            path.join(" → ")
        ));
    }
    path.push(name.to_string());
    for field in &defs[name].fields {
        if let Base::Nested(nested) = &field.base {
            refuse_cycles(nested, defs, path)?;
        }
    }
    path.pop();
    Ok(())
}

/// `<dir>/<pkg>/<kind>/<file>` (a `share` folder), or `<dir>/<kind>/<file>`
/// when `dir` is the package itself (`kind`: `msg`, `srv`).
fn candidates(dir: &Path, package: &str, kind: &str, file: &str) -> Vec<PathBuf> {
    let mut found = vec![dir.join(package).join(kind).join(file)];
    if dir.file_name().and_then(|n| n.to_str()) == Some(package) {
        found.push(dir.join(kind).join(file));
    }
    found
}

/// A service's RIHS01 hash: rosidl describes a service as a type with its
/// request, its response and its event (`service_msgs`' envelope of both).
fn service_hash(name: &str, request: &Message, response: &Message) -> String {
    rihs01(name, &service_defs(name, request, response))
}

/// The service as rosidl describes it, with every type it refers to.
fn service_defs(name: &str, request: &Message, response: &Message) -> BTreeMap<String, MessageDef> {
    let nested = |field: &str, ty: String, shape: Shape| msg::Field {
        name: field.to_string(),
        base: Base::Nested(ty),
        shape,
    };
    let plain = |field: &str, p: Primitive, shape: Shape| msg::Field {
        name: field.to_string(),
        base: Base::Primitive(p),
        shape,
    };
    let mut defs = request.defs.clone();
    defs.extend(response.defs.clone());
    let event = format!("{name}_Event");
    defs.insert(
        name.to_string(),
        MessageDef {
            name: name.to_string(),
            fields: vec![
                nested("request_message", request.name.clone(), Shape::One),
                nested("response_message", response.name.clone(), Shape::One),
                nested("event_message", event.clone(), Shape::One),
            ],
        },
    );
    let info = "service_msgs/msg/ServiceEventInfo".to_string();
    defs.insert(
        event.clone(),
        MessageDef {
            name: event,
            fields: vec![
                nested("info", info.clone(), Shape::One),
                nested("request", request.name.clone(), Shape::Bounded(1)),
                nested("response", response.name.clone(), Shape::Bounded(1)),
            ],
        },
    );
    let time = "builtin_interfaces/msg/Time".to_string();
    defs.insert(
        info.clone(),
        MessageDef {
            name: info,
            fields: vec![
                plain("event_type", Primitive::U8, Shape::One),
                nested("stamp", time.clone(), Shape::One),
                plain("client_gid", Primitive::U8, Shape::Array(16)),
                plain("sequence_number", Primitive::I64, Shape::One),
            ],
        },
    );
    defs.insert(
        time.clone(),
        MessageDef {
            name: time,
            fields: vec![
                plain("sec", Primitive::I32, Shape::One),
                plain("nanosec", Primitive::U32, Shape::One),
            ],
        },
    );
    defs
}

impl Message {
    /// This type's own definition.
    pub fn def(&self) -> &MessageDef {
        &self.defs[&self.name]
    }

    /// The WIT type a value of this message takes: a record with a field
    /// for each of the message's, named in WIT's way (`frame_id` is
    /// `frame-id`).
    pub fn payload_type(&self) -> PayloadType {
        self.record_type(&self.name)
    }

    pub(super) fn record_type(&self, name: &str) -> PayloadType {
        PayloadType::Record(
            self.defs[name]
                .fields
                .iter()
                .map(|f| (wit_name(&f.name), self.field_type(&f.base, f.shape)))
                .collect(),
        )
    }

    pub(super) fn field_type(&self, base: &Base, shape: Shape) -> PayloadType {
        let element = match base {
            Base::Primitive(p) => primitive_type(*p),
            Base::String { .. } => PayloadType::String,
            Base::Nested(name) => self.record_type(name),
        };
        match shape {
            Shape::One => element,
            _ => PayloadType::List(Box::new(element)),
        }
    }
}

/// A ROS field name as WIT spells it.
pub fn wit_name(field: &str) -> String {
    field.replace('_', "-")
}

pub(super) fn primitive_type(p: Primitive) -> PayloadType {
    match p {
        Primitive::Bool => PayloadType::Bool,
        Primitive::Byte | Primitive::Char | Primitive::U8 => PayloadType::U8,
        Primitive::I8 => PayloadType::S8,
        Primitive::I16 => PayloadType::S16,
        Primitive::U16 => PayloadType::U16,
        Primitive::I32 => PayloadType::S32,
        Primitive::U32 => PayloadType::U32,
        Primitive::I64 => PayloadType::S64,
        Primitive::U64 => PayloadType::U64,
        Primitive::F32 => PayloadType::F32,
        Primitive::F64 => PayloadType::F64,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_type_loads_with_what_it_refers_to() {
        let types = MessageTypes::default();
        for name in MessageTypes::builtin_names() {
            let message = types.load(name).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(message.hash.starts_with("RIHS01_") && message.hash.len() == 71);
        }
        let range = types.load("sensor_msgs/msg/Range").expect("works");
        assert!(range.defs.contains_key("builtin_interfaces/msg/Time"));
        assert_eq!(
            range.payload_type().to_string(),
            "record { header: record { stamp: record { sec: s32, nanosec: u32 }, frame-id: \
             string }, radiation-type: u8, field-of-view: f32, min-range: f32, max-range: f32, \
             range: f32, variance: f32 }"
        );
    }

    #[test]
    fn names_a_missing_type_and_who_uses_it() {
        let dir = std::env::temp_dir().join(format!("radar-msg-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("my_msgs/msg")).expect("works");
        std::fs::write(
            dir.join("my_msgs/msg/Probe.msg"),
            "Missing thing\nfloat32 x\n",
        )
        .expect("works");
        let types = MessageTypes::new(vec![dir.clone()]);
        let e = types.load("my_msgs/msg/Probe").expect_err("is refused");
        assert!(
            e.0.contains("unknown message type `my_msgs/msg/Missing`") && e.0.contains("used by"),
            "{e}"
        );
        std::fs::write(dir.join("my_msgs/msg/Loop.msg"), "Loop[] more\n").expect("works");
        let e = types.load("my_msgs/msg/Loop").expect_err("is refused");
        assert!(
            e.0.contains("contain themselves: my_msgs/msg/Loop → my_msgs/msg/Loop"),
            "{e}"
        );
        let e = types.load("nope").expect_err("is refused");
        assert!(e.0.contains("not a message type"), "{e}");
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn services_split_into_request_and_response_with_rosidls_hash() {
        let types = MessageTypes::default();
        // The hashes rosidl wrote into std_srvs' SetBool.json, Trigger.json
        // and Empty.json (Jazzy and Kilted).
        for (name, hash, request, response) in [
            (
                "std_srvs/srv/SetBool",
                "RIHS01_abe9e4bb6b41b40e6789712c00ec8871923e089af3f667a79992a428cff2da0a",
                "record { data: bool }",
                "record { success: bool, message: string }",
            ),
            (
                "std_srvs/srv/Trigger",
                "RIHS01_eeff2cd6fa5ad9d27cdf4dec64818317839b62f212a91e6b5304b634b2062c5f",
                "record { structure-needs-at-least-one-member: u8 }",
                "record { success: bool, message: string }",
            ),
            (
                "std_srvs/srv/Empty",
                "RIHS01_5888399dedec5ccc85ea6451949fd2c9f97bfdf963f9a588821639fcd31b5d19",
                "record { structure-needs-at-least-one-member: u8 }",
                "record { structure-needs-at-least-one-member: u8 }",
            ),
            // action_msgs' CancelGoal.json: an action's cancel on rmw_zenoh.
            (
                "action_msgs/srv/CancelGoal",
                "RIHS01_573d8b0a534451d7bc2ac8c5ffde8ac14b8593b7001175d0cd6516dcbeb8689a",
                "record { goal-info: record { goal-id: record { uuid: list<u8> }, stamp: record { sec: s32, nanosec: u32 } } }",
                "record { return-code: s8, goals-canceling: list<record { goal-id: record { uuid: list<u8> }, stamp: record { sec: s32, nanosec: u32 } }> }",
            ),
        ] {
            let service = types
                .load_service(name)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(service.hash, hash, "{name}");
            assert_eq!(service.request.payload_type().to_string(), request);
            assert_eq!(service.response.payload_type().to_string(), response);
            assert_eq!(service.request.name, format!("{name}_Request"));
        }
        let e = types
            .load_service("std_srvs/msg/SetBool")
            .expect_err("not a service");
        assert!(e.0.contains("not a service type"), "{e}");
        let e = types.load_service("my_srvs/srv/Nope").expect_err("unknown");
        assert!(e.0.contains("msg_paths"), "{e}");
    }

    #[test]
    fn actions_split_into_goal_result_and_feedback_with_rosidls_hashes() {
        let types = MessageTypes::default();
        let action = types
            .load_action("test_msgs/action/Fibonacci")
            .expect("loads");
        // The hashes rosidl wrote into test_msgs' Fibonacci.json (Kilted).
        let expected = [
            (
                &action.hash,
                "RIHS01_be9273e3557225044b4a040811112491f7079326e3a573f83258b0b4c30bd069",
            ),
            (
                &action.goal.hash,
                "RIHS01_e58ef5a8f4f039ab522a740823547c460b1d5aed8031c8b7825d33d345d90df8",
            ),
            (
                &action.result.hash,
                "RIHS01_0774b095467813c6904d475498b5486b7ebd4cda6a4569f97e8de8c862689049",
            ),
            (
                &action.feedback.hash,
                "RIHS01_7d1110f2efa019ad5ad8ad2244db98d862f39dc9fae8c976814b0065fa2f32d5",
            ),
            (
                &action.send_goal.hash,
                "RIHS01_d807633803e38e164276573cd97e9fbd71e109c290bbf4cc312a0a1c9da7bbd9",
            ),
            (
                &action.send_goal.request.hash,
                "RIHS01_dfe75c73dc2c090cbc8fd8c45039bfa279d16aa6aadd348f812c6adad26e669e",
            ),
            (
                &action.send_goal.response.hash,
                "RIHS01_1e7e84f7edf1fb020d9e51c7842bceef4cbdbd847f354125f3227cf4f314a683",
            ),
            (
                &action.get_result.hash,
                "RIHS01_5d30fdeb21d20e117aa5f36c7b4f0b6874f1a8cf7a9c038d58f1156c5737b209",
            ),
            (
                &action.get_result.response.hash,
                "RIHS01_ef88159d47a3d21d9bf4bec690cf668939d9542db28a9cfd77dbcd97eaf1add2",
            ),
            (
                &action.feedback_message.hash,
                "RIHS01_37487bae8cea358366b97003c1ef1ca7ce7c08df36f9e8cca496624226aee64e",
            ),
        ];
        for (ours, theirs) in expected {
            assert_eq!(ours, theirs);
        }
        // action_msgs' GoalStatusArray.json: an action's status topic.
        let status = types
            .load("action_msgs/msg/GoalStatusArray")
            .expect("built in");
        assert_eq!(
            status.hash,
            "RIHS01_6c1684b00f177d37438febe6e709fc4e2b0d4248dca4854946f9ed8b30cda83e"
        );
        assert_eq!(
            action.send_goal.request.payload_type().to_string(),
            "record { goal-id: record { uuid: list<u8> }, goal: record { order: s32 } }"
        );
        let e = types
            .load_action("test_msgs/action/Fibonaci")
            .expect_err("unknown");
        assert!(
            e.0.contains("did you mean `test_msgs/action/Fibonacci`"),
            "{e}"
        );
        let cancel = types
            .load_service("action_msgs/srv/CancelGoal")
            .expect("every action's cancel is built in");
        assert!(cancel
            .response
            .defs
            .contains_key("action_msgs/msg/GoalInfo"));
    }
}

//! The node's parameters (`docs/ros2.md#parameters`): each plugin's
//! config values as ROS 2 parameters of Radar's node, named
//! `<Plugin>.<key>` and typed as `radar.toml` writes them, with
//! `use_sim_time` as every ROS 2 node has it. They are answered on
//! rcl_interfaces' six parameter services, on either middleware, so `ros2
//! param list`, `ros2 param get` and rclpy's parameter client see them.
//!
//! A set (`ros2 param set`, rclpy's `set_parameters`) changes the
//! plugin's config value while it runs: it is an outside input, recorded
//! as `configured`, and every read of the plugin's config after it sees
//! the new value (`Radar::configure`). As rclpy does by default, a set
//! keeps a parameter's type; one that cannot be made (a name that is not
//! a parameter, another type, `use_sim_time`, any with `[ros2]
//! set_parameters = false`) is answered unsuccessful with the reason and
//! recorded as `refused`, so the trace says who tried. This file is the
//! table and its answers; `parameter_services` puts them on the wire.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, MutexGuard, PoisonError};

use serde_json::{json, Value as Json};

use crate::error::RadarError;

/// rcl_interfaces' `ParameterType` constants (byte arrays are only read,
/// in a set: a TOML array of small integers is an integer array).
const BOOL: u8 = 1;
const INTEGER: u8 = 2;
const DOUBLE: u8 = 3;
const STRING: u8 = 4;
const BYTE_ARRAY: u8 = 5;
const BOOL_ARRAY: u8 = 6;
const INTEGER_ARRAY: u8 = 7;
const DOUBLE_ARRAY: u8 = 8;
const STRING_ARRAY: u8 = 9;

/// The parameter that is not a plugin's config value.
const USE_SIM_TIME: &str = "use_sim_time";

/// The node's parameters: by name, each one's type and its
/// `ParameterValue` as JSON, as the last set left them.
pub(crate) struct Parameters {
    values: Mutex<BTreeMap<String, (u8, Json)>>,
    /// Whether sets are taken (`[ros2] set_parameters`).
    settable: AtomicBool,
}

/// A set of one parameter that can be made: the plugin, its config key,
/// and the value as the plugin reads it (text, as `radar.toml` would give
/// it).
#[derive(Debug, PartialEq)]
pub(super) struct Change {
    pub(super) plugin: String,
    pub(super) key: String,
    pub(super) text: String,
}

/// One of the six parameter services.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Call {
    List,
    Get,
    Describe,
    GetTypes,
    Set,
    SetAtomically,
}

impl Call {
    /// Each service: its name under the node, and its type.
    pub(super) const ALL: [(Call, &'static str, &'static str); 6] = [
        (Call::Describe, "describe_parameters", "DescribeParameters"),
        (Call::Get, "get_parameters", "GetParameters"),
        (Call::GetTypes, "get_parameter_types", "GetParameterTypes"),
        (Call::List, "list_parameters", "ListParameters"),
        (Call::Set, "set_parameters", "SetParameters"),
        (
            Call::SetAtomically,
            "set_parameters_atomically",
            "SetParametersAtomically",
        ),
    ];
}

impl Parameters {
    /// From each plugin's config, as `radar.toml` gives it, and the node's
    /// `use_sim_time`.
    pub(crate) fn new(
        config: &BTreeMap<String, BTreeMap<String, toml::Value>>,
        use_sim_time: bool,
    ) -> Self {
        let this = Self {
            values: Mutex::default(),
            settable: AtomicBool::new(true),
        };
        this.load(config, use_sim_time);
        this
    }

    /// Whether sets are taken (`[ros2] set_parameters`).
    pub(crate) fn settable(self, settable: bool) -> Self {
        self.settable.store(settable, Ordering::Relaxed);
        self
    }

    /// Takes each plugin's config and `use_sim_time` in place of what it
    /// had (the services and the tap hold this one).
    pub(crate) fn load(
        &self,
        config: &BTreeMap<String, BTreeMap<String, toml::Value>>,
        use_sim_time: bool,
    ) {
        let mut values = BTreeMap::new();
        values.insert(
            USE_SIM_TIME.to_string(),
            (BOOL, value(BOOL, json!(use_sim_time))),
        );
        for (plugin, table) in config {
            for (key, v) in table {
                let (ty, v) = typed(v);
                values.insert(format!("{plugin}.{key}"), (ty, value(ty, v)));
            }
        }
        *self.values() = values;
    }

    /// For tests: from TOML text with a table of config values per plugin.
    #[cfg(test)]
    pub(super) fn from_toml(text: &str) -> Self {
        let config: toml::Table = toml::from_str(text).expect("toml");
        let config = config
            .into_iter()
            .map(|(plugin, table)| {
                let table = table.as_table().expect("a table").clone();
                (plugin, table.into_iter().collect())
            })
            .collect();
        Parameters::new(&config, false)
    }

    fn values(&self) -> MutexGuard<'_, BTreeMap<String, (u8, Json)>> {
        self.values.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// What setting `parameter` (a `Parameter` as JSON) would do: the
    /// change, or why it cannot be made.
    pub(super) fn change(&self, parameter: &Json) -> Result<Change, String> {
        let name = parameter["name"].as_str().unwrap_or_default();
        if name == USE_SIM_TIME {
            return Err(
                "use_sim_time is fixed when the run starts: set it in radar.toml \
                        ([ros2] use_sim_time)"
                    .to_string(),
            );
        }
        if !self.settable.load(Ordering::Relaxed) {
            return Err("the plugins' config values are read-only from ROS 2 here \
                        ([ros2] set_parameters = false in radar.toml)"
                .to_string());
        }
        let values = self.values();
        let Some((declared, _)) = values.get(name) else {
            return Err(format!(
                "`{name}` is not a parameter of this node: its parameters are its plugins' \
                 config values, `<Plugin>.<key>` as radar.toml gives them"
            ));
        };
        let (plugin, key) = name.split_once('.').unwrap_or((name, ""));
        let ty = parameter["value"]["type"].as_u64().unwrap_or(0) as u8;
        if ty != *declared {
            let hint = match (*declared, ty) {
                (INTEGER, DOUBLE) => {
                    "; radar.toml writes it as an integer: write it with a decimal point \
                     there (`1.0`) to make it a double"
                }
                _ => "",
            };
            return Err(format!(
                "`{name}` is of type {}: setting it to {} is not allowed (Radar's parameters \
                 keep their type, as rclpy's do by default){hint}",
                type_name(*declared),
                type_name(ty)
            ));
        }
        let field = field_of(ty).map_or(&Json::Null, |f| &parameter["value"][f]);
        let text = config_text(field, matches!(ty, DOUBLE | DOUBLE_ARRAY))
            .ok_or_else(|| format!("`{name}` cannot take the value {field}"))?;
        Ok(Change {
            plugin: plugin.to_string(),
            key: key.to_string(),
            text,
        })
    }

    /// A `configured` record: plugin `plugin`'s `key` is now `text`,
    /// however it was set (a set here, `Radar::configure`, a replayed
    /// input); the one way a value changes, so `get_parameters` answers
    /// it from then on. A parameter keeps its type when the text reads as
    /// one (as a set here always does), else takes the type radar.toml
    /// would give the text; a key that is not a parameter stays one that
    /// is not.
    pub(super) fn configured(&self, plugin: &str, key: &str, text: &str) {
        let mut values = self.values();
        let Some(parameter) = values.get_mut(&format!("{plugin}.{key}")) else {
            return;
        };
        let parsed = toml::from_str::<toml::Table>(&format!("v = {text}"))
            .ok()
            .and_then(|mut table| table.remove("v"));
        let (ty, v) = match as_type(parameter.0, text, parsed.as_ref()) {
            Some(v) => (parameter.0, v),
            None => parsed.as_ref().map_or((STRING, json!(text)), typed),
        };
        *parameter = (ty, value(ty, v));
    }

    /// The answer to a call that reads (`request` and answer as JSON); a
    /// set is answered by [`set`].
    pub(super) fn answer(&self, call: Call, request: &Json) -> Json {
        let names = || -> Vec<&str> {
            request["names"]
                .as_array()
                .map(|n| n.iter().filter_map(Json::as_str).collect())
                .unwrap_or_default()
        };
        let values = self.values();
        // As rclpy answers: nothing at all if any name is not a parameter.
        let known = || -> Vec<(&str, &(u8, Json))> {
            let found: Option<Vec<_>> = names()
                .into_iter()
                .map(|n| values.get(n).map(|v| (n, v)))
                .collect();
            found.unwrap_or_default()
        };
        match call {
            Call::List => {
                let prefixes: Vec<&str> = request["prefixes"]
                    .as_array()
                    .map(|p| p.iter().filter_map(Json::as_str).collect())
                    .unwrap_or_default();
                let depth = request["depth"].as_u64().unwrap_or(0);
                json!({ "result": list(&values, &prefixes, depth) })
            }
            Call::Get => {
                let values: Vec<&Json> = known().into_iter().map(|(_, v)| &v.1).collect();
                json!({ "values": values })
            }
            Call::GetTypes => {
                let types: Vec<u8> = known().into_iter().map(|(_, v)| v.0).collect();
                json!({ "types": types })
            }
            Call::Describe => {
                let settable = self.settable.load(Ordering::Relaxed);
                let descriptors: Vec<Json> = known()
                    .into_iter()
                    .map(|(name, v)| describe(name, v.0, settable))
                    .collect();
                json!({ "descriptors": descriptors })
            }
            Call::Set | Call::SetAtomically => json!({}),
        }
    }
}

/// What a set does to the running system: [`Change`]s made (the plugins'
/// config values set at one place, recorded), or a set refused (recorded).
pub(super) trait Setter {
    /// Makes `changes`, all or none.
    fn configure(&self, changes: &[Change]) -> Result<(), RadarError>;
    /// Records that `command` was refused, and why.
    fn refused(&self, command: String, reason: &str);
}

/// The answer to a set (`Call::Set`: each parameter on its own;
/// `Call::SetAtomically`: all or none), made through `setter`.
pub(super) fn set(
    parameters: &Parameters,
    call: Call,
    request: &Json,
    setter: &dyn Setter,
) -> Json {
    let tried: Vec<&Json> = request["parameters"]
        .as_array()
        .map(|ps| ps.iter().collect())
        .unwrap_or_default();
    let outcome = |result: Result<(), String>| match result {
        Ok(()) => json!({ "successful": true, "reason": "" }),
        Err(reason) => json!({ "successful": false, "reason": reason }),
    };
    // All or none: checked, then made at one place in the run.
    let make = |changes: Result<Vec<Change>, String>| -> Result<(), String> {
        let changes = changes?;
        // The run's `configured` records update the table (the bridge's tap).
        setter
            .configure(&changes)
            .map_err(|e| format!("the run did not take it: {e}"))
    };
    if call == Call::Set {
        let results: Vec<Json> = tried
            .iter()
            .map(|parameter| {
                let result = make(parameters.change(parameter).map(|c| vec![c]));
                if let Err(reason) = &result {
                    setter.refused(format!("ros2 param set {}", shown(parameter)), reason);
                }
                outcome(result)
            })
            .collect();
        return json!({ "results": results });
    }
    let changes: Result<Vec<Change>, String> = tried.iter().map(|p| parameters.change(p)).collect();
    let result = make(changes).map_err(|reason| {
        let all: Vec<String> = tried.iter().map(|p| shown(p)).collect();
        let reason = format!("{reason}; none of the set was made");
        setter.refused(
            format!("ros2 param set (atomically) {}", all.join(", ")),
            &reason,
        );
        reason
    });
    json!({ "result": outcome(result) })
}

/// `text` (read as TOML: `parsed`) as a value of parameter type `ty`, if
/// it is one: the inverse of [`config_text`].
fn as_type(ty: u8, text: &str, parsed: Option<&toml::Value>) -> Option<Json> {
    use toml::Value as T;
    let double = |v: &T| match v {
        T::Float(f) if f.is_nan() => Some(json!("NaN")),
        T::Float(f) if f.is_infinite() => {
            Some(json!(if *f > 0.0 { "Infinity" } else { "-Infinity" }))
        }
        T::Float(f) => Some(json!(f)),
        T::Integer(i) => Some(json!(*i as f64)),
        _ => None,
    };
    let all = |of: &dyn Fn(&T) -> Option<Json>| -> Option<Json> {
        let items = parsed?.as_array()?;
        items
            .iter()
            .map(of)
            .collect::<Option<Vec<_>>>()
            .map(Json::from)
    };
    match ty {
        STRING => Some(json!(text)),
        BOOL => parsed?.as_bool().map(Json::from),
        INTEGER => parsed?.as_integer().map(Json::from),
        DOUBLE => double(parsed?),
        BOOL_ARRAY => all(&|v| v.as_bool().map(Json::from)),
        INTEGER_ARRAY => all(&|v| v.as_integer().map(Json::from)),
        DOUBLE_ARRAY => all(&double),
        STRING_ARRAY => all(&|v| v.as_str().map(Json::from)),
        _ => None,
    }
}

/// The name of parameter type `ty`, as `ros2 param` says it.
fn type_name(ty: u8) -> &'static str {
    match ty {
        BOOL => "bool",
        INTEGER => "integer",
        DOUBLE => "double",
        STRING => "string",
        BYTE_ARRAY => "byte array",
        BOOL_ARRAY => "bool array",
        INTEGER_ARRAY => "integer array",
        DOUBLE_ARRAY => "double array",
        STRING_ARRAY => "string array",
        _ => "not set",
    }
}

/// The field of a `ParameterValue` that holds a value of type `ty`.
fn field_of(ty: u8) -> Option<&'static str> {
    Some(match ty {
        BOOL => "bool-value",
        INTEGER => "integer-value",
        DOUBLE => "double-value",
        STRING => "string-value",
        BYTE_ARRAY => "byte-array-value",
        BOOL_ARRAY => "bool-array-value",
        INTEGER_ARRAY => "integer-array-value",
        DOUBLE_ARRAY => "double-array-value",
        STRING_ARRAY => "string-array-value",
        _ => return None,
    })
}

/// A parameter's value as a plugin reads it: as `radar.toml` would give
/// it (text as is, the rest written as TOML writes it). `doubles`: the
/// value is a double or doubles, where CDR's JSON form writes a NaN or an
/// infinity as text (`"NaN"`, `"-Infinity"`), which TOML writes `nan`,
/// `-inf`.
fn config_text(value: &Json, doubles: bool) -> Option<String> {
    let toml_of = |value: &Json| -> Option<toml::Value> {
        Some(match value {
            Json::Bool(b) => toml::Value::Boolean(*b),
            Json::Number(n) => match n.as_i64() {
                Some(i) if !doubles => toml::Value::Integer(i),
                _ => toml::Value::Float(n.as_f64()?),
            },
            Json::String(s) if doubles => toml::Value::Float(match s.as_str() {
                "NaN" => f64::NAN,
                "Infinity" => f64::INFINITY,
                "-Infinity" => f64::NEG_INFINITY,
                _ => return None,
            }),
            Json::String(s) => toml::Value::String(s.clone()),
            Json::Null | Json::Array(_) | Json::Object(_) => return None,
        })
    };
    match value {
        Json::String(s) if !doubles => Some(s.clone()),
        Json::Array(items) => {
            let items = items.iter().map(toml_of).collect::<Option<Vec<_>>>()?;
            Some(toml::Value::Array(items).to_string())
        }
        other => toml_of(other).map(|v| v.to_string()),
    }
}

/// `ListParameters` as rclpy answers it: the names under each prefix (all
/// of them with none), at most `depth` levels deep (0: all), and the
/// prefixes of those found.
fn list(values: &BTreeMap<String, (u8, Json)>, prefixes: &[&str], depth: u64) -> Json {
    let deep_enough = |rest: &str| depth == 0 || (rest.matches('.').count() as u64) < depth;
    let names: Vec<&str> = values
        .keys()
        .map(String::as_str)
        .filter(|name| {
            if prefixes.is_empty() {
                return deep_enough(name);
            }
            prefixes.iter().any(|prefix| {
                *name == *prefix
                    || name
                        .strip_prefix(prefix)
                        .and_then(|r| r.strip_prefix('.'))
                        .is_some_and(deep_enough)
            })
        })
        .collect();
    let found: std::collections::BTreeSet<&str> = names
        .iter()
        .filter_map(|n| n.rsplit_once('.').map(|(p, _)| p))
        .collect();
    json!({ "names": names, "prefixes": found })
}

/// A `ParameterValue` of type `ty` holding `v`, in the JSON form of
/// `cdr` (field names in kebab case, as WIT writes them).
fn value(ty: u8, v: Json) -> Json {
    let mut value = json!({
        "type": ty,
        "bool-value": false,
        "integer-value": 0,
        "double-value": 0.0,
        "string-value": "",
        "byte-array-value": [],
        "bool-array-value": [],
        "integer-array-value": [],
        "double-array-value": [],
        "string-array-value": [],
    });
    if let Some(field) = field_of(ty) {
        value[field] = v;
    }
    value
}

/// A config value's parameter type and value, as `radar.toml` writes it:
/// a number, a bool, text, or an array of one of them (integers among
/// floats count as floats); anything else as its TOML text.
fn typed(v: &toml::Value) -> (u8, Json) {
    use toml::Value as T;
    match v {
        T::Boolean(b) => (BOOL, json!(b)),
        T::Integer(i) => (INTEGER, json!(i)),
        // JSON has no infinity or NaN: said as text, as the plugin reads it.
        T::Float(f) if !f.is_finite() => (STRING, json!(v.to_string())),
        T::Float(f) => (DOUBLE, json!(f)),
        T::String(s) => (STRING, json!(s)),
        T::Array(items) if !items.is_empty() => {
            if let Some(all) = items.iter().map(T::as_bool).collect::<Option<Vec<_>>>() {
                (BOOL_ARRAY, json!(all))
            } else if let Some(all) = items.iter().map(T::as_integer).collect::<Option<Vec<_>>>() {
                (INTEGER_ARRAY, json!(all))
            } else if let Some(all) = items
                .iter()
                .map(|i| {
                    let f = i.as_float().or(i.as_integer().map(|n| n as f64));
                    f.filter(|f| f.is_finite())
                })
                .collect::<Option<Vec<_>>>()
            {
                (DOUBLE_ARRAY, json!(all))
            } else if let Some(all) = items.iter().map(T::as_str).collect::<Option<Vec<_>>>() {
                (STRING_ARRAY, json!(all))
            } else {
                (STRING, json!(v.to_string()))
            }
        }
        other => (STRING, json!(other.to_string())),
    }
}

/// A parameter's `ParameterDescriptor`: a plugin's config value can be
/// set (keeping its type) when the node takes sets, `use_sim_time` cannot.
fn describe(name: &str, ty: u8, settable: bool) -> Json {
    let (description, read_only) = match name.split_once('.') {
        Some((plugin, key)) => (
            format!("config value `{key}` of plugin `{plugin}` (radar.toml)"),
            !settable,
        ),
        None => (
            "whether the run follows /clock ([ros2] use_sim_time)".to_string(),
            true,
        ),
    };
    json!({
        "name": name,
        "type": ty,
        "description": description,
        "additional-constraints": "",
        "read-only": read_only,
        "dynamic-typing": false,
        "floating-point-range": [],
        "integer-range": [],
    })
}

/// A `Parameter` a set tried, as `name = value`.
fn shown(parameter: &Json) -> String {
    let name = parameter["name"].as_str().unwrap_or("?");
    let v = &parameter["value"];
    match field_of(v["type"].as_u64().unwrap_or(0) as u8) {
        Some(field) => format!("{name} = {}", v[field]),
        None => format!("{name} (unset)"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::RefCell;

    fn parameters() -> Parameters {
        Parameters::from_toml(
            "[Avoid]\ndistance = 0.5\nretries = 3\nname = \"left\"\nbrave = true\n\
             steps = [1, 2.5]\n\n[Dock]\nstation = \"home\"\n",
        )
    }

    #[test]
    fn config_values_are_listed_typed_and_got_as_ros2_parameters() {
        let p = parameters();
        let all = p.answer(Call::List, &json!({"prefixes": [], "depth": 0}));
        assert_eq!(
            all["result"]["names"],
            json!([
                "Avoid.brave",
                "Avoid.distance",
                "Avoid.name",
                "Avoid.retries",
                "Avoid.steps",
                "Dock.station",
                "use_sim_time"
            ])
        );
        assert_eq!(all["result"]["prefixes"], json!(["Avoid", "Dock"]));
        let dock = p.answer(Call::List, &json!({"prefixes": ["Dock"], "depth": 0}));
        assert_eq!(dock["result"]["names"], json!(["Dock.station"]));
        let top = p.answer(Call::List, &json!({"prefixes": [], "depth": 1}));
        assert_eq!(top["result"]["names"], json!(["use_sim_time"]));
        let names = json!({"names": ["Avoid.distance", "Avoid.retries", "Avoid.steps"]});
        let types = p.answer(Call::GetTypes, &names);
        assert_eq!(types["types"], json!([DOUBLE, INTEGER, DOUBLE_ARRAY]));
        let got = p.answer(Call::Get, &names);
        assert_eq!(got["values"][0]["double-value"], json!(0.5));
        assert_eq!(got["values"][1]["integer-value"], json!(3));
        assert_eq!(got["values"][2]["double-array-value"], json!([1.0, 2.5]));
        // A name that is not a parameter: nothing at all, as rclpy answers.
        let unknown = json!({"names": ["Avoid.distance", "nope"]});
        for (call, field) in [
            (Call::Get, "values"),
            (Call::GetTypes, "types"),
            (Call::Describe, "descriptors"),
        ] {
            assert_eq!(p.answer(call, &unknown)[field], json!([]), "{call:?}");
        }
        let described = p.answer(Call::Describe, &json!({"names": ["Avoid.name"]}));
        assert_eq!(described["descriptors"][0]["read-only"], json!(false));
        assert_eq!(described["descriptors"][0]["type"], json!(STRING));
    }

    /// What a set asked of the run; the changes made reach `parameters`
    /// as the run's `configured` records reach them through the tap.
    #[derive(Default)]
    struct Asked<'a> {
        parameters: Option<&'a Parameters>,
        made: RefCell<Vec<(String, String, String)>>,
        refused: RefCell<Vec<(String, String)>>,
    }

    impl<'a> Asked<'a> {
        fn on(parameters: &'a Parameters) -> Self {
            Self {
                parameters: Some(parameters),
                ..Self::default()
            }
        }
    }

    impl Setter for Asked<'_> {
        fn configure(&self, changes: &[Change]) -> Result<(), RadarError> {
            for change in changes {
                if let Some(parameters) = self.parameters {
                    parameters.configured(&change.plugin, &change.key, &change.text);
                }
                let made = (
                    change.plugin.clone(),
                    change.key.clone(),
                    change.text.clone(),
                );
                self.made.borrow_mut().push(made);
            }
            Ok(())
        }
        fn refused(&self, command: String, reason: &str) {
            self.refused
                .borrow_mut()
                .push((command, reason.to_string()));
        }
    }

    #[test]
    fn a_set_changes_the_plugins_config_value_as_radar_toml_would_write_it() {
        let p = parameters();
        let asked = Asked::on(&p);
        let request = json!({"parameters": [
            {"name": "Avoid.distance", "value": value(DOUBLE, json!(0.8))},
            {"name": "Avoid.brave", "value": value(BOOL, json!(false))},
            {"name": "Avoid.steps", "value": value(DOUBLE_ARRAY, json!([1.0, 3.5]))},
            {"name": "Dock.station", "value": value(STRING, json!("kitchen"))},
        ]});
        let reply = set(&p, Call::Set, &request, &asked);
        assert_eq!(
            reply["results"],
            json!(vec![json!({"successful": true, "reason": ""}); 4]),
            "{reply}"
        );
        let made = asked.made.borrow();
        let texts: Vec<&str> = made.iter().map(|(_, _, text)| text.as_str()).collect();
        assert_eq!(texts, ["0.8", "false", "[1.0, 3.5]", "kitchen"]);
        assert_eq!(made[0].0, "Avoid");
        assert_eq!(made[0].1, "distance");
        assert!(asked.refused.borrow().is_empty());
        // Read back as set.
        let got = p.answer(
            Call::Get,
            &json!({"names": ["Avoid.distance", "Dock.station"]}),
        );
        assert_eq!(got["values"][0]["double-value"], json!(0.8));
        assert_eq!(got["values"][1]["string-value"], json!("kitchen"));
    }

    #[test]
    fn a_set_that_cannot_be_made_is_refused_with_its_reason_and_recorded() {
        let p = parameters();
        let asked = Asked::on(&p);
        let request = json!({"parameters": [
            {"name": "Avoid.distance", "value": value(STRING, json!("far"))},
            {"name": "use_sim_time", "value": value(BOOL, json!(true))},
            {"name": "Avoid.speed", "value": value(DOUBLE, json!(1.0))},
            {"name": "Avoid.retries", "value": value(INTEGER, json!(5))},
        ]});
        let reply = set(&p, Call::Set, &request, &asked);
        let reasons: Vec<&str> = (0..4)
            .map(|i| reply["results"][i]["reason"].as_str().unwrap_or("?"))
            .collect();
        assert!(
            reasons[0].contains("is of type double: setting it to string"),
            "{reply}"
        );
        assert!(reasons[1].contains("fixed when the run starts"), "{reply}");
        assert!(
            reasons[2].contains("not a parameter of this node"),
            "{reply}"
        );
        assert_eq!(reply["results"][3]["successful"], json!(true));
        let refused = asked.refused.borrow();
        assert_eq!(refused.len(), 3);
        assert_eq!(refused[0].0, r#"ros2 param set Avoid.distance = "far""#);
        assert_eq!(asked.made.borrow().len(), 1, "each on its own");

        // Atomically: one refusal refuses all, and nothing is made.
        let asked = Asked::on(&p);
        let reply = set(&p, Call::SetAtomically, &request, &asked);
        assert_eq!(reply["result"]["successful"], json!(false));
        assert!(asked.made.borrow().is_empty());
        let refused = asked.refused.borrow();
        assert!(refused[0].0.starts_with("ros2 param set (atomically) "));
        assert!(refused[0].1.ends_with("none of the set was made"));
        let got = p.answer(Call::Get, &json!({"names": ["Avoid.distance"]}));
        assert_eq!(got["values"][0]["double-value"], json!(0.5), "unchanged");

        let asked = Asked::on(&p);
        set(&p, Call::Set, &json!({"parameters": []}), &asked);
        assert!(
            asked.refused.borrow().is_empty(),
            "a set of nothing is not recorded"
        );
    }

    #[test]
    fn a_node_that_takes_no_sets_refuses_each_and_says_its_parameters_are_read_only() {
        let p = parameters().settable(false);
        let asked = Asked::on(&p);
        let request = json!({"parameters": [
            {"name": "Avoid.distance", "value": value(DOUBLE, json!(0.8))},
        ]});
        let reply = set(&p, Call::Set, &request, &asked);
        assert_eq!(reply["results"][0]["successful"], json!(false));
        assert!(asked.made.borrow().is_empty());
        assert!(asked.refused.borrow()[0]
            .1
            .contains("set_parameters = false"));
        let described = p.answer(Call::Describe, &json!({"names": ["Avoid.distance"]}));
        assert_eq!(described["descriptors"][0]["read-only"], json!(true));
    }

    #[test]
    fn a_value_set_any_way_is_what_get_answers_typed_as_radar_toml_would_type_it() {
        let p = parameters();
        p.configured("Avoid", "distance", "0.25");
        p.configured("Avoid", "retries", "7");
        p.configured("Dock", "station", "0.5");
        p.configured("Avoid", "unknown", "1");
        let names = json!({"names": ["Avoid.distance", "Avoid.retries", "Dock.station"]});
        let got = p.answer(Call::Get, &names);
        assert_eq!(got["values"][0]["double-value"], json!(0.25));
        assert_eq!(got["values"][1]["integer-value"], json!(7));
        assert_eq!(
            got["values"][2]["string-value"],
            json!("0.5"),
            "a string stays one"
        );
        let listed = p.answer(Call::List, &json!({"prefixes": ["Avoid"], "depth": 0}));
        assert_eq!(listed["result"]["names"].as_array().map(Vec::len), Some(5));
    }

    #[test]
    fn a_value_set_keeps_its_parameters_type_when_its_text_reads_as_one() {
        let p = parameters();
        p.configured("Avoid", "distance", "1");
        p.configured("Avoid", "steps", "[]");
        p.configured("Avoid", "retries", "nan");
        p.configured("Avoid", "brave", "maybe");
        let names =
            json!({"names": ["Avoid.distance", "Avoid.steps", "Avoid.retries", "Avoid.brave"]});
        let types = p.answer(Call::GetTypes, &names);
        assert_eq!(
            types["types"],
            json!([DOUBLE, DOUBLE_ARRAY, STRING, STRING])
        );
        let got = p.answer(Call::Get, &names);
        assert_eq!(got["values"][0]["double-value"], json!(1.0));
        assert_eq!(got["values"][1]["double-array-value"], json!([]));
        assert_eq!(got["values"][3]["string-value"], json!("maybe"));
        // The text a NaN set gives reads back as the same double.
        assert_eq!(
            as_type(DOUBLE, "nan", Some(&toml::Value::Float(f64::NAN))),
            Some(json!("NaN"))
        );
    }

    #[test]
    fn a_double_that_is_not_finite_reaches_the_plugin_as_toml_writes_it() {
        assert_eq!(config_text(&json!("NaN"), true).as_deref(), Some("nan"));
        assert_eq!(
            config_text(&json!("-Infinity"), true).as_deref(),
            Some("-inf")
        );
        assert_eq!(
            config_text(&json!([1.0, "Infinity"]), true).as_deref(),
            Some("[1.0, inf]")
        );
        assert_eq!(config_text(&json!(2), true).as_deref(), Some("2.0"));
        assert_eq!(config_text(&json!("NaN"), false).as_deref(), Some("NaN"));
        assert_eq!(config_text(&json!("nope"), true), None);
    }
}

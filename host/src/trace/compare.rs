//! Comparing a trace with an expected one, and saying where they part.
//!
//! `radar test` and `radar run --replay --expect` compare whole traces; what
//! a user needs from a failure is the first record that differs, the records
//! just before it (what led there) and both versions of it. Records are
//! compared as JSON objects, so an expected file may hold kinds this build
//! does not know, and a scenario can choose which kinds matter.
//!
//! ```
//! # use radar::trace::compare::{compare, Comparison};
//! let expected = r#"{"t":0,"kind":"activate","plugin":"E"}
//! {"t":1000,"kind":"signal","plugin":"E","signal":"triggered","payload":1}"#;
//! let actual = r#"{"t":0,"kind":"activate","plugin":"E"}
//! {"t":1000,"kind":"signal","plugin":"E","signal":"triggered","payload":2}"#;
//! let parse = |t: &str| radar::trace::compare::parse_values(t).unwrap();
//! let d = compare(&parse(expected), &parse(actual), &Comparison::default()).unwrap();
//! assert_eq!(d.index, 1);
//! assert!(d.to_string().contains(r#""payload":2"#));
//! ```

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::fmt;

use serde_json::{Map, Value as Json};

use super::lines::{parse_lines, ParseError};

/// What counts as a difference.
#[derive(Clone, Debug)]
pub struct Comparison {
    /// Only records of these kinds are compared (`None`: all).
    pub kinds: Option<BTreeSet<String>>,
    /// Plugin versions (component hashes) in swap records compared as
    /// `v1`, `v2`, ... in order of appearance, so that an expected trace
    /// says which version ran, not which bytes a toolchain produced.
    pub versions_by_order: bool,
    /// Times may differ by this many nanoseconds (0: exactly equal), as
    /// when a real-clock recording is replayed under the virtual clock.
    pub time_tolerance: u64,
    /// Fields never compared (by default `backtrace`: it names code offsets
    /// of one build).
    pub ignore_fields: BTreeSet<String>,
}

impl Default for Comparison {
    fn default() -> Self {
        Self {
            kinds: None,
            versions_by_order: true,
            time_tolerance: 0,
            ignore_fields: BTreeSet::from(["backtrace".to_string()]),
        }
    }
}

/// Fields records gained after expected traces were first blessed
/// (`until_of` on an `until`'s connect, `queue` on a connect that queues,
/// `queued` on a start that waits):
/// compared only where the expected record has them, so that an expected
/// trace blessed by an earlier Radar still passes.
const ADDED_FIELDS: [&str; 3] = ["until_of", "queue", "queued"];

/// Fields of swap records that name versions.
const VERSION_FIELDS: [&str; 3] = ["version", "from", "to"];

impl Comparison {
    /// The records of `trace` this comparison looks at, in the form it
    /// compares them (kinds filtered, versions named by order, ignored
    /// fields removed): what `--bless` writes.
    pub fn normalize(&self, trace: &[Json]) -> Vec<Json> {
        // Versions swapped out are named first, in order: a plugin's first
        // version is `v1` even though a `swap-request` names the new one
        // before any record names the old.
        let mut versions: HashMap<String, usize> = HashMap::new();
        for record in trace.iter().filter(|r| r["kind"] == "swap") {
            if let Some(from) = record["from"].as_str() {
                let next = versions.len() + 1;
                versions.entry(from.to_string()).or_insert(next);
            }
        }
        trace
            .iter()
            .filter(|r| self.keeps(r))
            .map(|r| {
                let mut r = r.clone();
                if let Some(object) = r.as_object_mut() {
                    for field in &self.ignore_fields {
                        object.remove(field);
                    }
                    if self.versions_by_order && is_swap_kind(object) {
                        name_versions(object, &mut versions);
                    }
                }
                r
            })
            .collect()
    }

    /// An expected-trace file of `trace`: the compared records, one a line,
    /// `t` and `kind` first (what `--bless` writes).
    pub fn expected_text(&self, trace: &[Json]) -> String {
        self.normalize(trace)
            .iter()
            .map(|r| render(r) + "\n")
            .collect()
    }

    fn keeps(&self, record: &Json) -> bool {
        match (&self.kinds, record.get("kind").and_then(Json::as_str)) {
            (None, _) => true,
            (Some(kinds), Some(kind)) => kinds.contains(kind),
            (Some(_), None) => false,
        }
    }

    fn same(&self, expected: &Json, actual: &Json) -> bool {
        let (Some(e), Some(a)) = (expected.as_object(), actual.as_object()) else {
            return expected == actual;
        };
        let time = |o: &Map<String, Json>| o.get("t").and_then(Json::as_u64);
        let times_agree = match (time(e), time(a)) {
            (Some(x), Some(y)) => x.abs_diff(y) <= self.time_tolerance,
            (x, y) => x == y,
        };
        let fields = |o: &Map<String, Json>| -> Map<String, Json> {
            o.iter()
                .filter(|(k, _)| k.as_str() != "t")
                .filter(|(k, _)| !ADDED_FIELDS.contains(&k.as_str()) || e.contains_key(*k))
                .map(|(k, v)| (k.clone(), v.clone()))
                .collect()
        };
        times_agree && fields(e) == fields(a)
    }
}

/// Whether two traces that part hold the same records, only interleaved
/// differently: each plugin's records (and each connection's, and the
/// rest's) are the same, in the same order, and the traces are as long.
/// A real-clock run replayed may order records of unrelated plugins at
/// nearly the same time otherwise than the recording did.
pub fn only_interleaving_differs(expected: &[Json], actual: &[Json], how: &Comparison) -> bool {
    let expected = how.normalize(expected);
    let actual = how.normalize(actual);
    if expected.len() != actual.len() {
        return false;
    }
    let threads = |trace: &[Json]| -> BTreeMap<String, Vec<Json>> {
        let mut threads: BTreeMap<String, Vec<Json>> = BTreeMap::new();
        for record in trace {
            threads
                .entry(thread_of(record))
                .or_default()
                .push(record.clone());
        }
        threads
    };
    let (expected, actual) = (threads(&expected), threads(&actual));
    expected.len() == actual.len()
        && expected.iter().all(|(key, records)| {
            actual.get(key).is_some_and(|other| {
                records.len() == other.len()
                    && records.iter().zip(other).all(|(e, a)| how.same(e, a))
            })
        })
}

/// What a record belongs to, for [`only_interleaving_differs`]: its
/// plugin, else the plugin of the slot it reaches, else its connection.
fn thread_of(record: &Json) -> String {
    if let Some(plugin) = record["plugin"].as_str() {
        return format!("plugin {plugin}");
    }
    if let Some(to) = record["to"].as_str() {
        return format!("plugin {}", to.split('.').next().unwrap_or(to));
    }
    match record["id"].as_u64() {
        Some(id) => format!("connection {id}"),
        None => "system".to_string(),
    }
}

fn is_swap_kind(object: &Map<String, Json>) -> bool {
    object
        .get("kind")
        .and_then(Json::as_str)
        .is_some_and(|k| k.starts_with("swap"))
}

fn name_versions(object: &mut Map<String, Json>, names: &mut HashMap<String, usize>) {
    for field in VERSION_FIELDS {
        if let Some(Json::String(hash)) = object.get(field) {
            let next = names.len() + 1;
            let n = *names.entry(hash.clone()).or_insert(next);
            object.insert(field.to_string(), Json::String(format!("v{n}")));
        }
    }
}

/// Where two traces part: the first record (of the compared ones) that
/// differs, with what came before it and both versions of what follows.
#[derive(Clone, Debug)]
pub struct Divergence {
    /// Index of the first differing record among the compared records.
    pub index: usize,
    /// The compared records both traces agree on, just before it.
    pub before: Vec<Json>,
    /// The expected record there and a few after it (empty: the expected
    /// trace ended).
    pub expected: Vec<Json>,
    /// The actual record there and a few after it (empty: the actual trace
    /// ended).
    pub actual: Vec<Json>,
    /// Compared records on each side: expected, actual.
    pub lengths: (usize, usize),
}

/// How many records of context a divergence shows on each side.
const CONTEXT: usize = 3;

/// Compares two traces (JSON records); `None` if they agree.
pub fn compare(expected: &[Json], actual: &[Json], how: &Comparison) -> Option<Divergence> {
    let expected = how.normalize(expected);
    let actual = how.normalize(actual);
    let index = (0..expected.len().max(actual.len())).find(|&i| {
        match (expected.get(i), actual.get(i)) {
            (Some(e), Some(a)) => !how.same(e, a),
            _ => true,
        }
    })?;
    let after = |records: &[Json]| -> Vec<Json> {
        records.iter().skip(index).take(CONTEXT).cloned().collect()
    };
    Some(Divergence {
        index,
        before: expected[index.saturating_sub(CONTEXT)..index].to_vec(),
        expected: after(&expected),
        actual: after(&actual),
        lengths: (expected.len(), actual.len()),
    })
}

/// A record as one line, `t` and `kind` first as in a trace file.
pub fn render(record: &Json) -> String {
    let Some(object) = record.as_object() else {
        return record.to_string();
    };
    let mut parts = Vec::with_capacity(object.len());
    let first = ["t", "kind"];
    for key in first {
        if let Some(v) = object.get(key) {
            parts.push(format!("{}:{v}", Json::String(key.into())));
        }
    }
    for (key, v) in object.iter().filter(|(k, _)| !first.contains(&k.as_str())) {
        parts.push(format!("{}:{v}", Json::String(key.clone())));
    }
    format!("{{{}}}", parts.join(","))
}

fn time_of(record: Option<&Json>) -> Option<f64> {
    record
        .and_then(|r| r.get("t"))
        .and_then(Json::as_u64)
        .map(|t| t as f64 / 1e9)
}

impl fmt::Display for Divergence {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.write_as(f, ["expected", "produced", "expected", "actual"])
    }
}

impl Divergence {
    /// The divergence with its two sides named otherwise than expected
    /// and actual: `[count word of the left, count word of the right,
    /// left, right]`.
    pub fn named(&self, names: [&str; 4]) -> String {
        struct Named<'a>(&'a Divergence, [&'a str; 4]);
        impl fmt::Display for Named<'_> {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                self.0.write_as(f, self.1)
            }
        }
        Named(self, names).to_string()
    }

    fn write_as(&self, f: &mut fmt::Formatter<'_>, names: [&str; 4]) -> fmt::Result {
        let at = time_of(self.expected.first()).or_else(|| time_of(self.actual.first()));
        write!(f, "first difference at record {}", self.index + 1)?;
        if let Some(t) = at {
            write!(f, " (t = {t:.3} s)")?;
        }
        writeln!(
            f,
            "; {} records {}, {} {}",
            self.lengths.0, names[0], self.lengths.1, names[1]
        )?;
        let first = self.index + 1 - self.before.len();
        for (i, r) in self.before.iter().enumerate() {
            writeln!(f, "    {:>6}  {}", first + i, render(r))?;
        }
        let side = |f: &mut fmt::Formatter<'_>, mark: &str, records: &[Json]| -> fmt::Result {
            if records.is_empty() {
                return writeln!(f, "  {mark} {:>6}  (the trace ends here)", self.index + 1);
            }
            for (i, r) in records.iter().enumerate() {
                writeln!(f, "  {mark} {:>6}  {}", self.index + 1 + i, render(r))?;
            }
            Ok(())
        };
        writeln!(f, "  {}:", names[2])?;
        side(f, "-", &self.expected)?;
        writeln!(f, "  {}:", names[3])?;
        side(f, "+", &self.actual)
    }
}

/// Parses JSON Lines into JSON values (blank lines are skipped).
pub fn parse_values(text: &str) -> Result<Vec<Json>, ParseError> {
    Ok(parse_lines(text)?.into_iter().map(|(_, v)| v).collect())
}

/// Reads an expected trace file.
pub fn load_values(path: &std::path::Path) -> Result<Vec<Json>, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read expected trace {}: {e}", path.display()))?;
    parse_values(&text).map_err(|e| format!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn swap(version: &str) -> Json {
        json!({"t": 5, "kind": "swap-request", "plugin": "E", "version": version, "policy": "drain"})
    }

    #[test]
    fn equal_traces_agree_and_versions_compare_by_order() {
        let a = vec![swap("aaaa"), swap("bbbb"), swap("aaaa")];
        let b = vec![swap("cccc"), swap("dddd"), swap("cccc")];
        assert!(compare(&a, &b, &Comparison::default()).is_none());
        let c = vec![swap("cccc"), swap("dddd"), swap("dddd")];
        let d = compare(&a, &c, &Comparison::default()).expect("third differs");
        assert_eq!(d.index, 2);
        assert_eq!(d.expected[0]["version"], "v1");
        assert_eq!(d.actual[0]["version"], "v2");
        let exact = Comparison {
            versions_by_order: false,
            ..Comparison::default()
        };
        assert_eq!(compare(&a, &b, &exact).map(|d| d.index), Some(0));
    }

    #[test]
    fn fields_added_later_count_only_where_the_expected_record_has_them() {
        let old = vec![json!({"t":0,"kind":"deliver","id":1,"to":"R.start"})];
        let new = vec![json!({"t":0,"kind":"deliver","id":1,"to":"R.start","queued":2})];
        assert!(compare(&old, &new, &Comparison::default()).is_none());
        let other = vec![json!({"t":0,"kind":"deliver","id":1,"to":"R.start","queued":1})];
        assert!(compare(&new, &other, &Comparison::default()).is_some());
        assert!(compare(&new, &old, &Comparison::default()).is_some());
        // Any other field still counts.
        let more = vec![json!({"t":0,"kind":"deliver","id":1,"to":"R.start","x":1})];
        assert!(compare(&old, &more, &Comparison::default()).is_some());
    }

    #[test]
    fn a_shorter_trace_diverges_where_it_ends() {
        let a = vec![json!({"t":0,"kind":"activate","plugin":"E"}), swap("x")];
        let d = compare(&a, &a[..1], &Comparison::default()).expect("differs");
        assert_eq!((d.index, d.actual.len(), d.lengths), (1, 0, (2, 1)));
        assert!(d.to_string().contains("(the trace ends here)"));
    }

    #[test]
    fn kinds_filter_and_time_tolerance() {
        let a = vec![
            json!({"t":0,"kind":"log","plugin":"E","level":"info","message":"a"}),
            json!({"t":1_000_000,"kind":"activate","plugin":"E"}),
        ];
        let b = vec![json!({"t":1_000_400,"kind":"activate","plugin":"E"})];
        let only = Comparison {
            kinds: Some(BTreeSet::from(["activate".to_string()])),
            ..Comparison::default()
        };
        assert_eq!(compare(&a, &b, &only).map(|d| d.index), Some(0));
        let loose = Comparison {
            time_tolerance: 500,
            ..only
        };
        assert!(compare(&a, &b, &loose).is_none());
    }

    #[test]
    fn a_divergence_shows_context_and_both_sides() {
        let rec = |t: u64, p: &str| json!({"t": t, "kind": "activate", "plugin": p});
        let a: Vec<Json> = (0..6).map(|i| rec(i, "E")).collect();
        let mut b = a.clone();
        b[4] = rec(4, "F");
        let text = compare(&a, &b, &Comparison::default())
            .expect("differs")
            .to_string();
        assert!(text.starts_with("first difference at record 5"), "{text}");
        assert!(
            text.contains(r#"       4  {"t":3,"kind":"activate","plugin":"E"}"#),
            "{text}"
        );
        assert!(text.contains("-      5  "), "{text}");
        assert!(
            text.contains("+      5  ") && text.contains("\"F\""),
            "{text}"
        );
    }

    #[test]
    fn records_of_unrelated_plugins_in_another_order_are_only_interleaved() {
        let a = serde_json::json!({"t": 10, "kind": "signal", "plugin": "A", "signal": "triggered", "payload": 1});
        let b = serde_json::json!({"t": 11, "kind": "signal", "plugin": "B", "signal": "triggered", "payload": 2});
        let a2 = serde_json::json!({"t": 12, "kind": "signal", "plugin": "A", "signal": "exited", "payload": null});
        let how = Comparison {
            time_tolerance: 5,
            ..Comparison::default()
        };
        let expected = [a.clone(), b.clone(), a2.clone()];
        assert!(compare(&expected, &[b.clone(), a.clone(), a2.clone()], &how).is_some());
        assert!(only_interleaving_differs(
            &expected,
            &[b.clone(), a.clone(), a2.clone()],
            &how
        ));
        // One plugin's own order is not interleaving, nor is a lost record.
        assert!(!only_interleaving_differs(
            &expected,
            &[a2.clone(), b.clone(), a.clone()],
            &how
        ));
        assert!(!only_interleaving_differs(&expected, &[a, b], &how));
    }
}

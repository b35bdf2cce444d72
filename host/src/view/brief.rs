//! Values as a person reads them. A robot's values are large: a LaserScan
//! carries 360 ranges, an image 921,600 bytes. Printed whole, one scan
//! fills a terminal and 30 seconds of them drown every human view (the
//! timeline, its state blocks, `ctl read`, the graph, the live monitor).
//! Every human view prints a value through [`brief`]: a small value
//! exactly as its JSON, a large one summarised (a long list by its length,
//! its minimum, maximum and mean if it holds numbers, and its first items;
//! a long string by its start and length; a value the trace cut by its
//! size). The whole value stays one flag (`--full`) or one click (the
//! record's details in `radar view`) away; traces, recordings and the
//! network always carry values whole.

use serde_json::Value as Json;

/// Lists longer than this are summarised.
const MOST_ITEMS: usize = 8;
/// How many first items a summarised list shows.
const FIRST_ITEMS: usize = 3;
/// Strings longer than this (in characters) are cut.
const LONGEST_STRING: usize = 120;
/// Below this depth, a record or a list is shown as `{…}` or `[…]`.
const DEEPEST: usize = 4;
/// The longest a brief value gets, in characters: past it, it is cut.
const WIDEST: usize = 200;

/// `value` as one short line: its JSON when small, a summary when large.
pub fn brief(value: &Json) -> String {
    brief_within(value, WIDEST)
}

/// [`brief`], cut at `widest` characters (a graph's label is narrower
/// than a terminal's line).
pub fn brief_within(value: &Json, widest: usize) -> String {
    let mut out = String::new();
    write(value, 0, &mut out);
    if out.chars().count() > widest {
        // Too wide: what was summarised (a scan's ranges) is what matters
        // most, so it goes first, and records nested deeper fold.
        out.clear();
        write_tight(value, &mut out);
    }
    if out.chars().count() > widest {
        let cut: String = out.chars().take(widest.saturating_sub(1)).collect();
        return format!("{cut}…");
    }
    out
}

/// `value` as [`brief`] shows it, or whole when `full`.
pub fn shown(value: &Json, full: bool) -> String {
    if full {
        value.to_string()
    } else {
        brief(value)
    }
}

/// Whether `value` holds something [`write`] summarises: a long list, a
/// long string, a value the trace cut.
fn is_large(value: &Json) -> bool {
    match value {
        Json::Array(items) => items.len() > MOST_ITEMS || items.iter().any(is_large),
        Json::Object(fields) => cut_size(value).is_some() || fields.values().any(is_large),
        Json::String(text) => text.chars().count() > LONGEST_STRING,
        _ => false,
    }
}

fn write(value: &Json, depth: usize, out: &mut String) {
    match value {
        Json::Array(items) => {
            if depth >= DEEPEST && !items.is_empty() {
                out.push_str("[…]");
            } else if items.len() > MOST_ITEMS {
                write_long_list(items, depth, out);
            } else {
                out.push('[');
                for (i, item) in items.iter().enumerate() {
                    if i > 0 {
                        out.push(',');
                    }
                    write(item, depth + 1, out);
                }
                out.push(']');
            }
        }
        Json::Object(fields) => {
            if let Some(bytes) = cut_size(value) {
                out.push_str(&format!("‹{} bytes, cut from the trace›", thousands(bytes)));
            } else if depth >= DEEPEST && !fields.is_empty() {
                out.push_str("{…}");
            } else {
                out.push('{');
                for (i, (name, field)) in fields.iter().enumerate() {
                    if i > 0 {
                        out.push(',');
                    }
                    out.push_str(&Json::String(name.clone()).to_string());
                    out.push(':');
                    write(field, depth + 1, out);
                }
                out.push('}');
            }
        }
        Json::String(text) if text.chars().count() > LONGEST_STRING => {
            let start: String = text.chars().take(LONGEST_STRING - 20).collect();
            out.push_str(&Json::String(start).to_string());
            out.push_str(&format!(
                "… ({} chars)",
                thousands(text.chars().count() as u64)
            ));
        }
        other => out.push_str(&other.to_string()),
    }
}

/// A record too wide for its line: the fields [`write`] summarises
/// first, then the others, records inside it as `{…}`.
fn write_tight(value: &Json, out: &mut String) {
    let Json::Object(fields) = value else {
        return write(value, 0, out);
    };
    if cut_size(value).is_some() {
        return write(value, 0, out);
    }
    let ordered = fields
        .iter()
        .filter(|(_, v)| is_large(v))
        .chain(fields.iter().filter(|(_, v)| !is_large(v)));
    out.push('{');
    for (i, (name, field)) in ordered.enumerate() {
        if i > 0 {
            out.push(',');
        }
        out.push_str(&Json::String(name.clone()).to_string());
        out.push(':');
        // A record inside folds to `{…}`; a list keeps its summary.
        let depth = if field.is_object() { DEEPEST } else { 1 };
        write(field, depth, out);
    }
    out.push('}');
}

/// A list too long to print: `[360 numbers: min 0.1, max 10, mean 3.41;
/// 0.5, 0.51, 0.52, …]`, or `[24 items: …, …, …, …]`.
fn write_long_list(items: &[Json], depth: usize, out: &mut String) {
    // A float that is not finite is the string the trace writes for it
    // (`"Infinity"`, `"NaN"`): a LaserScan's out-of-range readings.
    let numbers: Option<Vec<f64>> = items.iter().map(as_number).collect();
    match numbers {
        Some(numbers) => {
            let finite: Vec<f64> = numbers.iter().copied().filter(|x| x.is_finite()).collect();
            let others = numbers.len() - finite.len();
            out.push_str(&format!("[{} numbers: ", thousands(items.len() as u64)));
            if !finite.is_empty() {
                let min = finite.iter().copied().fold(f64::INFINITY, f64::min);
                let max = finite.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                let mean = finite.iter().sum::<f64>() / finite.len() as f64;
                out.push_str(&format!(
                    "min {}, max {}, mean {}",
                    number(min),
                    number(max),
                    number(mean)
                ));
            }
            if others > 0 {
                if !finite.is_empty() {
                    out.push_str(", ");
                }
                out.push_str(&format!("{} not finite", thousands(others as u64)));
            }
            out.push_str("; ");
        }
        None => out.push_str(&format!("[{} items: ", thousands(items.len() as u64))),
    }
    for item in &items[..FIRST_ITEMS] {
        write(item, depth + 1, out);
        out.push_str(", ");
    }
    out.push_str("…]");
}

/// A number, or a float the trace wrote as a string because JSON has no
/// infinities or NaN.
fn as_number(value: &Json) -> Option<f64> {
    match value {
        Json::String(text) => match text.as_str() {
            "Infinity" => Some(f64::INFINITY),
            "-Infinity" => Some(f64::NEG_INFINITY),
            "NaN" => Some(f64::NAN),
            _ => None,
        },
        other => other.as_f64(),
    }
}

/// The size the trace noted for a value it cut (`{"$cut": {"bytes": N}}`).
fn cut_size(value: &Json) -> Option<u64> {
    let fields = value.as_object()?;
    if fields.len() != 1 {
        return None;
    }
    fields.get("$cut")?.get("bytes")?.as_u64()
}

/// A statistic, to four significant figures or so.
fn number(x: f64) -> String {
    if !x.is_finite() {
        return x.to_string();
    }
    let magnitude = x.abs();
    if magnitude != 0.0 && !(1e-3..1e6).contains(&magnitude) {
        return format!("{x:.3e}");
    }
    let text = format!("{x:.3}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    if text == "-0" {
        "0".to_string()
    } else {
        text.to_string()
    }
}

/// `921600` as `921,600`.
fn thousands(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn a_small_value_is_its_json() {
        for value in [
            json!(0.2),
            json!("stopped"),
            json!({"linear": {"x": -0.2, "y": 0.0, "z": 0.0}}),
            json!([1, 2, 3, 4, 5, 6, 7, 8]),
            json!(null),
        ] {
            assert_eq!(brief(&value), value.to_string());
            assert!(!is_large(&value));
        }
    }

    #[test]
    fn a_long_list_of_numbers_shows_its_length_range_mean_and_first_items() {
        let ranges: Vec<f64> = (0..360).map(|i| 0.5 + f64::from(i) * 0.01).collect();
        assert_eq!(
            brief(&json!({"ranges": ranges})),
            r#"{"ranges":[360 numbers: min 0.5, max 4.09, mean 2.295; 0.5, 0.51, 0.52, …]}"#
        );
    }

    #[test]
    fn readings_out_of_range_are_counted_apart_from_the_statistics() {
        let mut ranges = vec![json!(2.0); 10];
        ranges[3] = json!("Infinity");
        ranges[4] = json!("NaN");
        assert_eq!(
            brief(&json!(ranges)),
            "[10 numbers: min 2, max 2, mean 2, 2 not finite; 2.0, 2.0, 2.0, …]"
        );
    }

    #[test]
    fn other_long_lists_show_their_length_and_first_items() {
        let names: Vec<String> = (0..20).map(|i| format!("n{i}")).collect();
        assert_eq!(brief(&json!(names)), r#"[20 items: "n0", "n1", "n2", …]"#);
    }

    #[test]
    fn a_long_string_is_cut_with_its_length() {
        let text = "x".repeat(200);
        assert_eq!(
            brief(&json!(text)),
            format!("\"{}\"… (200 chars)", "x".repeat(100))
        );
    }

    #[test]
    fn a_value_the_trace_cut_shows_its_size() {
        assert_eq!(
            brief(&json!({"$cut": {"bytes": 921_600}})),
            "‹921,600 bytes, cut from the trace›"
        );
    }

    #[test]
    fn a_record_too_wide_shows_what_it_summarised_first() {
        let ranges = vec![1.5; 360];
        let scan = json!({"angle-min": 0.0, "header": {"frame-id": "laser", "stamp": {"sec": 1}},
            "ranges": ranges, "range-max": 12.0, "time-increment": 0.0, "scan-time": 0.1,
            "angle-increment": 0.017453, "angle-max": 6.2657, "range-min": 0.12});
        let text = brief(&scan);
        assert!(
            text.starts_with(r#"{"ranges":[360 numbers: min 1.5, max 1.5, mean 1.5; "#),
            "{text}"
        );
        assert!(text.contains(r#""header":{…}"#), "{text}");
    }

    #[test]
    fn nothing_brief_is_wider_than_the_limit() {
        let wide: Vec<String> = (0..8).map(|i| format!("{i}").repeat(60)).collect();
        let text = brief(&json!({"a": wide, "b": wide}));
        assert_eq!(text.chars().count(), WIDEST);
        assert!(text.ends_with('…'));
    }

    #[test]
    fn statistics_read_well() {
        assert_eq!(number(3.0), "3");
        assert_eq!(number(-0.0001), "-1.000e-4");
        assert_eq!(number(2.29512), "2.295");
        assert_eq!(thousands(1_234_567), "1,234,567");
    }
}

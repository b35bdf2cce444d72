//! `radar view`: a run as one self-contained HTML page (`docs/view.md`).
//!
//! The page (`page/view.html`, `view.css`, `brief.js`, `fold.js`, `view.js`) is built into
//! `radar`; writing a view inlines its style, its script and the trace's
//! records, so the file needs no network and no other file. The live
//! monitor serves the same page with no records, and streams them.

use std::io::Write;

use crate::trace::Record;

const HTML: &str = include_str!("page/view.html");
const CSS: &str = include_str!("page/view.css");
const BRIEF: &str = include_str!("page/brief.js");
const FOLD: &str = include_str!("page/fold.js");
const JS: &str = include_str!("page/view.js");

/// The page's text around the records: what comes before them and after.
fn halves(title: &str, live: bool) -> (String, String) {
    let title = title
        .replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;");
    let page = HTML
        .replace("/*CSS*/", CSS)
        .replace("/*LIVE*/", if live { "true" } else { "false" })
        .replace("/*JS*/", &format!("{BRIEF}\n{FOLD}\n{JS}"));
    // The title goes in last, and only before the records: whatever it
    // holds cannot stand for a place in the page.
    let (before, after) = page.split_once("/*TRACE*/").unwrap_or((&page, ""));
    (before.replace("/*TITLE*/", &title), after.to_string())
}

/// The live monitor's page: the view with no records, which it asks the
/// server for (`/events`).
pub fn live_page(title: &str) -> String {
    let (before, after) = halves(title, true);
    format!("{before}[]{after}")
}

/// Writes the view of `records` as one HTML page titled `title` (the
/// trace's file name) to `out`.
pub fn write_view(records: &[Record], title: &str, out: impl Write) -> std::io::Result<()> {
    let lines: Vec<String> = records.iter().map(Record::to_json_line).collect();
    write_view_of_lines(lines.iter().map(String::as_str), title, out)
}

/// [`write_view`] of records already rendered as JSON lines (the live
/// monitor's history, for its `/snapshot`).
pub fn write_view_of_lines<'a>(
    lines: impl Iterator<Item = &'a str>,
    title: &str,
    mut out: impl Write,
) -> std::io::Result<()> {
    let (before, after) = halves(title, false);
    out.write_all(before.as_bytes())?;
    out.write_all(b"[")?;
    for (i, line) in lines.enumerate() {
        if i > 0 {
            out.write_all(b",\n")?;
        }
        out.write_all(inline(line).as_bytes())?;
    }
    out.write_all(b"]")?;
    out.write_all(after.as_bytes())?;
    out.flush()
}

/// A line of JSON made safe inside a `<script>` element: a `<` can only be
/// in a string, where `\u003c` means the same (no `</script>` ends it
/// early).
fn inline(json: &str) -> std::borrow::Cow<'_, str> {
    if json.contains('<') {
        json.replace('<', "\\u003c").into()
    } else {
        json.into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::parse_json_lines;

    #[test]
    fn inlines_everything_and_no_record_can_end_the_script() {
        let records = parse_json_lines(
            r#"{"t":0,"kind":"log","plugin":"E","level":"info","message":"</script><b>"}"#,
        )
        .expect("a trace");
        let mut page = Vec::new();
        write_view(&records, "run <1>.jsonl", &mut page).expect("written");
        let page = String::from_utf8(page).expect("utf-8");
        assert!(
            page.contains(r#""message":"\u003c/script>\u003cb>""#),
            "{page}"
        );
        assert_eq!(
            page.matches("</script>").count(),
            3,
            "three scripts, closed once each"
        );
        assert!(page.contains("run &lt;1&gt;.jsonl"));
        assert!(page.contains("const RADAR_LIVE = false;"));
        assert!(!page.contains("/*JS*/") && !page.contains("/*CSS*/"));
        assert!(!page.contains("src=\"http") && !page.contains("href=\"http"));
        assert!(live_page("x").contains("const RADAR_LIVE = true;"));
    }
}

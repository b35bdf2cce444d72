//! "Did you mean": the known name closest to a mistyped one, so that an
//! error about a name can say the fix.

/// The candidate most like `name`, if one is close enough to be what was
/// meant (a typo, a letter case, a missing or extra letter).
pub fn closest<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    candidates
        .into_iter()
        .map(|c| {
            (
                strsim::jaro_winkler(&name.to_lowercase(), &c.to_lowercase()),
                c,
            )
        })
        .filter(|(score, c)| *score >= 0.85 && *c != name)
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, c)| c)
}

/// ` (did you mean `X`?)` when a candidate is close to `name`; else
/// nothing.
pub fn hint<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> String {
    closest(name, candidates)
        .map(|close| format!(" (did you mean `{close}`?)"))
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suggests_the_close_name_or_lists_them() {
        let names = ["LowBattery", "Dock", "Bumper"];
        assert_eq!(closest("LowBatery", names), Some("LowBattery"));
        assert_eq!(closest("dock", names), Some("Dock"));
        assert_eq!(closest("Camera", names), None);
        assert_eq!(hint("LowBatery", names), " (did you mean `LowBattery`?)");
        assert_eq!(hint("Camera", names), "");
    }
}

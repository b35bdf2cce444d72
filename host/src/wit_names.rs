//! Names as WIT spells them, shared by what writes WIT for users: `radar
//! new` (a plugin `BackOff` gets the folder and world `back-off`) and
//! `radar ros2 show --wit` (a `LaserScan` message is `record laser-scan`,
//! a field named `type` is `%type`).

/// WIT's keywords: a name that is one is written `%name`.
const KEYWORDS: [&str; 45] = [
    "as",
    "async",
    "bool",
    "borrow",
    "char",
    "constructor",
    "enum",
    "error-context",
    "export",
    "f32",
    "f64",
    "flags",
    "float32",
    "float64",
    "from",
    "func",
    "future",
    "import",
    "include",
    "interface",
    "list",
    "option",
    "own",
    "package",
    "record",
    "resource",
    "result",
    "s16",
    "s32",
    "s64",
    "s8",
    "static",
    "stream",
    "string",
    "tuple",
    "type",
    "u16",
    "u32",
    "u64",
    "u8",
    "use",
    "variant",
    "with",
    "world",
    "_",
];

/// `name` as an identifier in WIT text: escaped if it is a keyword.
pub(crate) fn ident(name: &str) -> String {
    if KEYWORDS.contains(&name) {
        format!("%{name}")
    } else {
        name.to_string()
    }
}

/// `name` (`BackOff`, `LaserScan`, `UInt32`, `MultiDOFJointState`,
/// `my_event`) in WIT's kebab case (`back-off`, `laser-scan`, `u-int32`,
/// `multi-dof-joint-state`, `my-event`): a word begins at each capital
/// after a lowercase letter or a digit, and at the last capital of a run
/// followed by a lowercase letter; `_` is `-`.
pub(crate) fn kebab(name: &str) -> String {
    let chars: Vec<char> = name.chars().collect();
    let mut out = String::new();
    for (i, &c) in chars.iter().enumerate() {
        if c.is_ascii_uppercase() && i > 0 {
            let before = chars[i - 1];
            let next_lower = chars.get(i + 1).is_some_and(char::is_ascii_lowercase);
            if before.is_ascii_lowercase()
                || before.is_ascii_digit()
                || (before.is_ascii_uppercase() && next_lower)
            {
                out.push('-');
            }
        }
        out.push(if c == '_' {
            '-'
        } else {
            c.to_ascii_lowercase()
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_become_kebab_case() {
        for (name, wit) in [
            ("LaserScan", "laser-scan"),
            ("UInt32", "u-int32"),
            ("Vector3", "vector3"),
            ("Float32MultiArray", "float32-multi-array"),
            ("MultiDOFJointState", "multi-dof-joint-state"),
            ("std_msgs", "std-msgs"),
            ("BackOff", "back-off"),
            ("TestEvent2", "test-event2"),
            ("HTTPServer", "http-server"),
            ("hello-event", "hello-event"),
        ] {
            assert_eq!(kebab(name), wit, "{name}");
        }
    }

    #[test]
    fn keywords_are_escaped() {
        assert_eq!(ident("type"), "%type");
        assert_eq!(ident("string"), "%string");
        assert_eq!(ident("frame-id"), "frame-id");
    }
}

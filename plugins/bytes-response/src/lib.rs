//! Test fixture: `start(bytes)` returns how many bytes it was given, so
//! that a payload is lowered into a plugin's memory and a result comes
//! back (the receiving end of `benches/payloads.rs`).
radar_guest::plugin!(
    r#"
    package radar-fixtures:bytes-response;
    world bytes-response {
        include radar:reactive/response@0.1.0;
        export start: func(payload: list<u8>) -> u32;
    }
"#
);

struct BytesResponse;

impl Guest for BytesResponse {
    fn start(payload: Vec<u8>) -> u32 {
        payload.len() as u32
    }
}

export!(BytesResponse);

//! A plugin's standard error, kept so that a fault can say why.
//!
//! A Python or JavaScript plugin that raises an uncaught exception prints
//! the traceback to stderr and then traps with `unreachable`: the trap says
//! nothing, the traceback everything. Each instance writes its stderr here;
//! only the last few KiB are kept (a chatty plugin never fills anything or
//! fails a write), and a fault adds the last line written during the call
//! (`ZeroDivisionError: division by zero`).

use std::collections::VecDeque;
use std::pin::Pin;
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll};

use bytes::Bytes;
use wasmtime_wasi::cli::{IsTerminal, StdoutStream};
use wasmtime_wasi::p2::{OutputStream, Pollable, StreamError};

/// How much of a plugin's stderr is kept.
const KEPT: usize = 4096;

/// The tail of one instance's stderr (cheap to clone: one buffer).
#[derive(Clone, Default)]
pub(crate) struct StderrTail(Arc<Mutex<VecDeque<u8>>>);

impl StderrTail {
    fn push(&self, bytes: &[u8]) {
        let mut kept = self.0.lock().unwrap_or_else(|e| e.into_inner());
        kept.extend(bytes);
        let excess = kept.len().saturating_sub(KEPT);
        kept.drain(..excess);
    }

    /// Forgets what was written so far (a new call begins).
    pub fn clear(&self) {
        self.0.lock().unwrap_or_else(|e| e.into_inner()).clear();
    }

    /// What the plugin said last since the last `clear`: the last non-empty
    /// line before a Rust panic report (componentize-py's runtime panics
    /// after printing the Python traceback), else the panic's message.
    pub fn last_line(&self) -> Option<String> {
        let mut kept = self.0.lock().unwrap_or_else(|e| e.into_inner());
        let text = String::from_utf8_lossy(kept.make_contiguous()).into_owned();
        let lines: Vec<&str> = text.lines().map(str::trim).collect();
        let panic = lines
            .iter()
            .position(|l| l.starts_with("thread '") && l.contains("panicked at"));
        let said = |lines: &[&str]| {
            lines
                .iter()
                .rev()
                .find(|l| !l.is_empty())
                .map(|l| l.to_string())
        };
        let line = match panic {
            Some(at) => said(&lines[..at]).or_else(|| {
                lines[at + 1..]
                    .iter()
                    .find(|l| !l.is_empty() && !l.starts_with("note: run with"))
                    .map(|l| l.to_string())
            }),
            None => said(&lines),
        }?;
        let line = js_exception(&line).unwrap_or(line);
        Some(line.chars().take(300).collect())
    }
}

/// The QuickJS engine of componentize-js reports an uncaught exception as
/// a Rust debug print: `Failed to call 'check': Exception(Exception {
/// message: Some("..."), stack: Some("    at check (/app.js:4:15)\n") })`.
/// This says it as `Error: ... (at check (/app.js:4:15))`.
fn js_exception(line: &str) -> Option<String> {
    let quoted = |after: &str| -> Option<String> {
        let start = line.find(after)? + after.len();
        let rest = &line[start..];
        let end = rest.find("\")")?;
        Some(rest[..end].replace("\\n", " ").trim().to_string())
    };
    let message = quoted("message: Some(\"")?;
    Some(match quoted("stack: Some(\"") {
        Some(stack) if !stack.is_empty() => format!("Error: {message} ({stack})"),
        _ => format!("Error: {message}"),
    })
}

impl IsTerminal for StderrTail {
    fn is_terminal(&self) -> bool {
        false
    }
}

impl StdoutStream for StderrTail {
    fn async_stream(&self) -> Box<dyn tokio::io::AsyncWrite + Send + Sync> {
        Box::new(self.clone())
    }

    fn p2_stream(&self) -> Box<dyn OutputStream> {
        Box::new(self.clone())
    }
}

impl tokio::io::AsyncWrite for StderrTail {
    fn poll_write(
        self: Pin<&mut Self>,
        _cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<std::io::Result<usize>> {
        self.push(buf);
        Poll::Ready(Ok(buf.len()))
    }

    fn poll_flush(self: Pin<&mut Self>, _cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Poll::Ready(Ok(()))
    }

    fn poll_shutdown(self: Pin<&mut Self>, _cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Poll::Ready(Ok(()))
    }
}

#[async_trait::async_trait]
impl OutputStream for StderrTail {
    fn write(&mut self, bytes: Bytes) -> Result<(), StreamError> {
        self.push(&bytes);
        Ok(())
    }

    fn flush(&mut self) -> Result<(), StreamError> {
        Ok(())
    }

    fn check_write(&mut self) -> Result<usize, StreamError> {
        Ok(64 * 1024)
    }
}

#[async_trait::async_trait]
impl Pollable for StderrTail {
    async fn ready(&mut self) {}
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_the_tail_and_finds_the_last_line() {
        let tail = StderrTail::default();
        assert_eq!(tail.last_line(), None);
        tail.push(b"Traceback (most recent call last):\n  File \"app.py\"\n");
        tail.push(b"ZeroDivisionError: division by zero\n\n");
        tail.push(b"thread '<unnamed>' (1) panicked at runtime/src/lib.rs:1280:25:\n");
        tail.push(b"Python function threw an unexpected exception\n");
        tail.push(b"note: run with `RUST_BACKTRACE=1` environment variable\n");
        assert_eq!(
            tail.last_line().as_deref(),
            Some("ZeroDivisionError: division by zero")
        );
        tail.clear();
        tail.push(b"thread '<unnamed>' panicked at src/lib.rs:9:5:\nno sensor\nnote: run with `RUST_BACKTRACE=1`\n");
        assert_eq!(tail.last_line().as_deref(), Some("no sensor"));
        tail.push(&vec![b'x'; 3 * KEPT]);
        assert_eq!(tail.0.lock().expect("lock").len(), KEPT);
        tail.clear();
        assert_eq!(tail.last_line(), None);
        tail.push(b"Failed to call 'check': Exception(Exception { message: Some(\"no reading\"), stack: Some(\"    at check (/app.js:4:15)\\n\") })\n");
        assert_eq!(
            tail.last_line().as_deref(),
            Some("Error: no reading (at check (/app.js:4:15))")
        );
    }
}

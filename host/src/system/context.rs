//! What the parts of a running system share besides the scheduler's
//! channel: which system a thread is a native context of (see the module
//! docs of `system`), the instance set-ups a swap needs, and names.

use std::cell::Cell;
use std::collections::HashMap;
use std::sync::atomic::AtomicU64;
use std::sync::{Arc, Mutex};

use crate::plugin::InstanceSetup;

/// What a new instance of each plugin needs, published when the run
/// begins: `Radar::swap` makes the new version's instance on the caller's
/// thread with it.
pub(super) type SharedSetups = Arc<Mutex<HashMap<String, InstanceSetup>>>;

/// Distinguishes the systems of one process, for [`NATIVE_CONTEXT`].
pub(super) static NEXT_SYSTEM: AtomicU64 = AtomicU64::new(1);

thread_local! {
    /// The system whose native context this thread is (0: none): calls made
    /// here take part in that system's lockstep (see the module docs).
    pub(super) static NATIVE_CONTEXT: Cell<u64> = const { Cell::new(0) };
}
/// The name a deliberative component has in the trace (its log lines).
pub(crate) const PROGRAM_NAME: &str = "(deliberative)";

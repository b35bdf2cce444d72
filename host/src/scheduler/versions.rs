//! New versions of plugins on their way in: what `Radar::swap` hands the
//! scheduler, what waits for a plugin's safe point, and the transitions an
//! actor takes there (see `swap`).

use std::rc::Rc;

use crate::plugin::{Fault, PluginCode, PluginInstance};
use crate::ports::SwapPolicy;

/// A new version of a plugin on its way to the scheduler: the compiled
/// code and, when the caller could make it, an instance already made for
/// this plugin (so the scheduler's thread only switches).
pub(crate) struct NewVersion {
    pub code: PluginCode,
    pub instance: Option<Result<PluginInstance, Fault>>,
}

/// An accepted swap waiting for its safe point.
pub(crate) struct PendingSwap {
    pub(super) code: Rc<PluginCode>,
    pub(super) instance: Option<Result<PluginInstance, Fault>>,
    pub(super) policy: SwapPolicy,
    /// An event's check was interrupted for it: its result is discarded.
    pub discard_check: bool,
}

/// What a plugin's new instance is for.
pub(crate) enum Transition {
    /// `reset` of a plugin in `error`: a fresh instance of the same code.
    Reset,
    /// A swap that reached the plugin's safe point.
    Swap(Box<PendingSwap>),
}

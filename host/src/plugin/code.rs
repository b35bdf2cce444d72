//! What a loaded plugin is: its compiled, validated component
//! ([`PluginCode`]), ready to instantiate, and its [`Kind`] with the WIT
//! types of its slots and signals.

use std::sync::Arc;

use sha2::{Digest, Sha256};
use wasmtime::component::{Component, ComponentExportIndex, InstancePre};

use super::store::PluginCtx;
use crate::capability::board::BoardPort;
use crate::payload::PayloadType;
use crate::ports::SignalName;

/// Whether a plugin is an event or a response, with its slot signatures.
#[derive(Clone, Debug)]
pub(crate) enum Kind {
    Event {
        /// The payload of `triggered`, if any.
        payload: Option<PayloadType>,
        /// The signals it declares, with their payloads.
        signals: Arc<[(SignalName, Option<PayloadType>)]>,
    },
    Response {
        start_param: Option<PayloadType>,
        start_result: Option<PayloadType>,
        interrupt_param: Option<PayloadType>,
        /// The signals it declares, with their payloads.
        signals: Arc<[(SignalName, Option<PayloadType>)]>,
    },
}

impl Kind {
    /// The signals the plugin declares (beyond the built-in ones).
    pub fn signals(&self) -> &[(SignalName, Option<PayloadType>)] {
        match self {
            Kind::Event { signals, .. } | Kind::Response { signals, .. } => signals,
        }
    }
}

/// A compiled, validated plugin component, ready to instantiate (cheap to
/// clone: the compiled code is shared).
#[derive(Clone)]
pub(crate) struct PluginCode {
    pub kind: Kind,
    /// The first 12 hex digits of the component's sha256 (`docs/hot-swap.md`).
    pub version: String,
    /// The component, ready to instantiate: none for a response backed by
    /// a server ([`super::backed`]).
    pub(super) pre: Option<InstancePre<PluginCtx>>,
    /// What backs a response that has no component.
    pub(crate) backed: Option<super::backed::Backed>,
    /// The blackboard entries it reads and writes.
    pub board: Arc<[BoardPort]>,
    /// Where each of [`super::call::EXPORTS`] is, resolved once at load.
    pub(super) exports: Arc<[Option<ComponentExportIndex>; 6]>,
    /// The component's own version, and the script a development runtime
    /// runs, if this is one (see [`crate::script`]).
    pub(crate) component_version: Arc<str>,
    pub(crate) script: Option<Arc<str>>,
    /// The component itself, shipped to an agent when the plugin is
    /// placed on one.
    pub(crate) bytes: Arc<[u8]>,
}

impl PluginCode {
    /// This development runtime running `script` (packed by
    /// [`crate::script::pack`]): a version of its own.
    pub fn with_script(&self, script: Arc<str>) -> PluginCode {
        let mut digest = Sha256::new();
        digest.update(self.component_version.as_bytes());
        digest.update([0]);
        digest.update(script.as_bytes());
        let mut code = self.clone();
        code.version = format!("{:x}", digest.finalize())[..12].to_string();
        code.script = Some(script);
        code
    }
}

/// Whether an exported instance is the interface a plugin may put its
/// functions in instead of the world's top level: `slots`, or an interface
/// named `slots` in the plugin's own package (`pkg:name/slots[@version]`).
/// componentize-py cannot export a top-level function named `exit` (it
/// clashes with libc's `exit` when linking), so Python responses need it.
pub(super) fn is_slots_interface(name: &str) -> bool {
    let name = name.split('@').next().unwrap_or(name);
    name == "slots" || name.ends_with("/slots")
}

/// Where `name` is exported: at the top level, else in the slots interface
/// called `slots`.
pub(super) fn export_index(
    component: &Component,
    slots: Option<&str>,
    name: &str,
) -> Option<ComponentExportIndex> {
    component.get_export_index(None, name).or_else(|| {
        let slots = component.get_export_index(None, slots?)?;
        component.get_export_index(Some(&slots), name)
    })
}

impl PluginCode {
    /// A response backed by a server: its slots' types are the server's
    /// request and reply; its version, what backs it. Its calls are counted
    /// from 1 in each system built (a `Backed` may be used for several).
    pub(crate) fn backed(mut backed: super::backed::Backed) -> Self {
        backed.answers = Arc::default();
        let mut what = format!("{}\n{:?}\n{:?}", backed.label, backed.request, backed.reply);
        if let Some(feedback) = &backed.feedback {
            what.push_str(&format!("\n{feedback:?}"));
        }
        let version = version_of(what.as_bytes());
        PluginCode {
            kind: Kind::Response {
                start_param: backed.request.clone(),
                start_result: backed.reply.clone(),
                interrupt_param: None,
                signals: backed.signals().into(),
            },
            version: version.clone(),
            pre: None,
            backed: Some(backed),
            board: Arc::new([]),
            exports: Arc::new([None, None, None, None, None, None]),
            component_version: version.into(),
            script: None,
            bytes: Arc::new([]),
        }
    }
}

/// A component's version: the first 12 hex digits of its sha256.
pub(crate) fn version_of(bytes: &[u8]) -> String {
    format!("{:x}", Sha256::digest(bytes))[..12].to_string()
}

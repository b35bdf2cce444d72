//! A line of an inputs file (a recording, a scenario's `inputs.jsonl`) as
//! what the scheduler applies at its time: the one place the file's form
//! meets the scheduler's.

use std::path::PathBuf;

use crate::plugin::Answer;
use crate::ports::{Mode, SwapPolicy};
use crate::scheduler::{ConfigChange, ConnId, LinkSpec, LinkTarget, StaticWhat};
use crate::trace::inputs::Input;

/// What `input` makes the scheduler do; `None` for a recording's own lines
/// (its clock, plugin versions, end), which are not inputs.
pub(super) fn static_what(input: &Input) -> Option<StaticWhat> {
    let what = match input {
        Input::Inject { to, payload } => StaticWhat::Inject {
            to: to.clone(),
            payload: payload.clone(),
        },
        Input::BoardWrite { entry, value, by } => StaticWhat::Write {
            entry: entry.clone(),
            value: value.clone(),
            by: by.clone(),
        },
        Input::Swap {
            plugin,
            wasm,
            policy,
            ..
        } => StaticWhat::Swap {
            plugin: plugin.clone(),
            path: PathBuf::from(wasm),
            policy: if policy == "restart" {
                SwapPolicy::Restart
            } else {
                SwapPolicy::Drain
            },
            code: None,
        },
        Input::Connect {
            from,
            to,
            mode,
            busy,
            until,
        } => {
            let mode = mode.parse().unwrap_or(Mode::Whenever);
            let busy = busy.parse().unwrap_or_default();
            StaticWhat::Connect(LinkSpec {
                from: from.clone(),
                to: LinkTarget::Slot(to.clone()),
                mode,
                busy,
                min_interval: None,
                until: until.clone(),
            })
        }
        Input::Disconnect { id } => StaticWhat::Disconnect(ConnId::new(*id)),
        Input::Reset { plugin } => StaticWhat::Reset(plugin.clone()),
        Input::NodeLost { node } => StaticWhat::NodeLost(node.clone()),
        Input::NodeBack { node } => StaticWhat::NodeBack(node.clone()),
        Input::Stop { why } => StaticWhat::Stop(why.clone()),
        Input::AgentExits { node, exits } => StaticWhat::AgentExits(node.clone(), exits.clone()),
        Input::Answer {
            plugin,
            call,
            reply,
            failed,
            accepted,
            feedback,
        } => StaticWhat::Answer {
            plugin: plugin.clone(),
            call: *call,
            // `inputs::parse` has checked it says one thing.
            answer: Answer::from_fields(reply.clone(), failed.clone(), *accepted, feedback.clone())
                .unwrap_or_else(Answer::Failed),
        },
        Input::Refused {
            command,
            from,
            reason,
        } => StaticWhat::Refused {
            command: command.clone(),
            from: from.clone(),
            reason: reason.clone(),
        },
        Input::Configure {
            plugin,
            key,
            value,
            from,
        } => StaticWhat::Configure {
            change: ConfigChange::new(plugin, key, value),
            from: from.clone(),
        },
        Input::Recording { .. } | Input::Plugin { .. } | Input::End { .. } => return None,
    };
    Some(what)
}

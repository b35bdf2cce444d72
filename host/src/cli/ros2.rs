//! `radar ros2`: the ROS 2 message types Radar knows, each as ROS 2 and
//! Radar see it (type hash, key expression, WIT type), and a message's
//! CDR bytes from its JSON value and back (`docs/ros2.md`).

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use radar::network::ros2::{cdr, MessageTypes};

use super::say;

/// `radar ros2 ...`.
#[derive(Args)]
pub struct Ros2Args {
    #[command(subcommand)]
    command: Ros2Command,
    /// A folder of `.msg` files (`<pkg>/msg/<Name>.msg`), read before the
    /// built-in types (repeatable).
    #[arg(long = "msg-path", global = true)]
    msg_paths: Vec<PathBuf>,
}

#[derive(Subcommand)]
enum Ros2Command {
    /// Lists the built-in message, service and action types.
    Types,
    /// Shows a type: its RIHS01 hash, its key expression, its fields, and
    /// its WIT records, ready to paste into a plugin's interface.
    Show {
        /// `pkg/msg/Name`, e.g. `sensor_msgs/msg/Range`, a service,
        /// `pkg/srv/Name`, or an action, `pkg/action/Name`.
        type_name: String,
        /// Prints only the WIT records, to paste into a plugin's interface.
        #[arg(long)]
        wit: bool,
    },
    /// Prints the CDR bytes (hex, little-endian) of a message given as
    /// JSON; fields left out are zero.
    Encode {
        /// `pkg/msg/Name`.
        type_name: String,
        /// The message, as JSON with WIT field names (`{"range": 0.4}`).
        json: String,
    },
    /// Prints the JSON of a message given as CDR bytes (hex, either
    /// byte order).
    Decode {
        /// `pkg/msg/Name`.
        type_name: String,
        /// The CDR bytes, in hex.
        hex: String,
    },
}

/// Runs `radar ros2`.
pub fn ros2(args: Ros2Args) -> Result<()> {
    let types = MessageTypes::new(args.msg_paths);
    match args.command {
        Ros2Command::Types => {
            let names = MessageTypes::builtin_names()
                .chain(MessageTypes::builtin_service_names())
                .chain(MessageTypes::builtin_action_names());
            for name in names {
                say(format_args!("{name}"));
            }
        }
        Ros2Command::Show { type_name, wit } if type_name.contains("/srv/") => {
            show_service(&types, &type_name, wit)?;
        }
        Ros2Command::Show { type_name, wit } if type_name.contains("/action/") => {
            show_action(&types, &type_name, wit)?;
        }
        Ros2Command::Show { type_name, wit } => {
            let message = types.load(&type_name).map_err(anyhow::Error::msg)?;
            if wit {
                print!("{}", message.wit_definitions());
                return Ok(());
            }
            say(format_args!("{}", message.name));
            say(format_args!("  hash  {}", message.hash));
            say(format_args!(
                "  key   <domain>/<topic>/{}/{}",
                radar::network::ros2::dds_type(&message.name),
                message.hash
            ));
            for field in &message.def().fields {
                say(format_args!("  field {field} {}", field.name));
            }
            say(format_args!(
                "\n// As WIT, to paste into a plugin's interface (`--wit` prints this alone):"
            ));
            print!("{}", message.wit_definitions());
        }
        Ros2Command::Encode { type_name, json } => {
            let message = types.load(&type_name).map_err(anyhow::Error::msg)?;
            let value: serde_json::Value =
                serde_json::from_str(&json).context("the message is not JSON")?;
            let bytes = cdr::encode(&message, &value).map_err(anyhow::Error::msg)?;
            let hex: String = bytes.iter().map(|b| format!("{b:02x}")).collect();
            say(format_args!("{hex}"));
        }
        Ros2Command::Decode { type_name, hex } => {
            let message = types.load(&type_name).map_err(anyhow::Error::msg)?;
            let hex = hex.trim();
            if hex.len() % 2 != 0 || !hex.chars().all(|c| c.is_ascii_hexdigit()) {
                anyhow::bail!("`{hex}` is not hex bytes");
            }
            let bytes: Vec<u8> = (0..hex.len())
                .step_by(2)
                .map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap_or(0))
                .collect();
            let value = cdr::decode(&message, &bytes)
                .map_err(|e| anyhow::anyhow!("not a {}: {e}", message.name))?;
            say(format_args!("{value}"));
        }
    }
    Ok(())
}

/// `radar ros2 show pkg/srv/Name`: the service's hash and key, its request
/// and reply, and their WIT records (what a response the service backs
/// takes in `start` and carries in `exited`).
fn show_service(types: &MessageTypes, name: &str, wit: bool) -> Result<()> {
    let service = types.load_service(name).map_err(anyhow::Error::msg)?;
    let records = format!(
        "{}{}",
        service.request.wit_definitions(),
        service.response.wit_definitions()
    );
    if wit {
        print!("{records}");
        return Ok(());
    }
    say(format_args!("{}", service.name));
    say(format_args!("  hash  {}", service.hash));
    say(format_args!(
        "  key   <domain>/<service>/{}/{}",
        radar::network::ros2::dds_type(&service.name),
        service.hash
    ));
    for (half, message) in [("request", &service.request), ("reply", &service.response)] {
        say(format_args!("  {half}"));
        for field in &message.def().fields {
            say(format_args!("    field {field} {}", field.name));
        }
    }
    say(format_args!(
        "\n// start takes the request and exited carries the reply of a response the \
         service backs\n// (`ros2 = {{ service = ..., type = \"{}\" }}`); as WIT (`--wit` \
         prints this alone):",
        service.name
    ));
    print!("{records}");
    Ok(())
}

/// `radar ros2 show pkg/action/Name`: the action's hash, its goal, result
/// and feedback, and their WIT records.
fn show_action(types: &MessageTypes, name: &str, wit: bool) -> Result<()> {
    let action = types.load_action(name).map_err(anyhow::Error::msg)?;
    let parts = [
        ("goal", &action.goal),
        ("result", &action.result),
        ("feedback", &action.feedback),
    ];
    let records: String = parts.iter().map(|(_, m)| m.wit_definitions()).collect();
    if wit {
        print!("{records}");
        return Ok(());
    }
    say(format_args!("{}", action.name));
    say(format_args!("  hash  {}", action.hash));
    for (part, message) in parts {
        say(format_args!("  {part}"));
        for field in &message.def().fields {
            say(format_args!("    field {field} {}", field.name));
        }
    }
    say(format_args!("\n// As WIT (`--wit` prints this alone):"));
    print!("{records}");
    Ok(())
}

//! `radar tool`: the steps of a C or C++ plugin's build that Radar does
//! itself (`guest-sdk/c/build` calls them; `docs/plugins-c.md`).

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use radar::workspace::c_toolchain::{c_bindings, component_new};

/// `radar tool ...`.
#[derive(Args)]
pub struct ToolArgs {
    #[command(subcommand)]
    command: ToolCommand,
}

#[derive(Subcommand)]
enum ToolCommand {
    /// Writes a world's C bindings (WORLD.h, WORLD.c and the world's type
    /// as WORLD_component_type.o), as `wit-bindgen c` does.
    BindgenC {
        /// The WIT folder (its dependencies under deps/) or file.
        wit: PathBuf,
        /// The world.
        #[arg(long)]
        world: String,
        /// Where to write them.
        #[arg(long)]
        out_dir: PathBuf,
    },
    /// Makes a component of a linked wasm32-wasi reactor module, with the
    /// WASI adapter of the wasmtime this Radar runs on, as `wasm-tools
    /// component new --adapt` does.
    ComponentNew {
        /// The core module.
        core: PathBuf,
        /// The component to write.
        #[arg(short, long)]
        output: PathBuf,
    },
}

/// Runs `radar tool`.
pub fn tool(args: ToolArgs) -> Result<()> {
    match args.command {
        ToolCommand::BindgenC {
            wit,
            world,
            out_dir,
        } => {
            c_bindings(&wit, &world, &out_dir)?;
            Ok(())
        }
        ToolCommand::ComponentNew { core, output } => {
            let component = component_new(&core)?;
            std::fs::write(&output, component)
                .with_context(|| format!("cannot write {}", output.display()))
        }
    }
}

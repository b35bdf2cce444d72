//! The two steps of a C or C++ plugin's build that are not compiling
//! (`radar tool`, called by `guest-sdk/c/build`): the world's C bindings,
//! and the component made of the linked core module.
//!
//! They live in Radar so that a C author needs no Rust toolchain: the
//! build installs clang (ziglang, from PyPI) and calls the `radar` it was
//! started by. The bindings come from wit-bindgen's C generator at the
//! version Radar's Rust guests use; the component gets the WASI adapter
//! of the wasmtime Radar runs on, so the two always match.

use std::path::{Path, PathBuf};

use wit_bindgen_core::Files;
use wit_parser::Resolve;

/// Why a C toolchain step made nothing.
#[derive(Debug, thiserror::Error)]
pub enum CToolError {
    /// The WIT folder does not parse, or has no such world.
    #[error("{}: {cause}", wit.display())]
    Wit {
        /// The folder or file given.
        wit: PathBuf,
        /// wit-parser's message, on one line.
        cause: String,
    },
    /// The generator refused the world.
    #[error("C bindings for world `{world}`: {cause}")]
    Bindings {
        /// The world.
        world: String,
        /// Why, on one line.
        cause: String,
    },
    /// No component can be made of the core module (not a module, or its
    /// imports and exports do not fit its world).
    #[error("{}: cannot make a component of it: {cause}", core.display())]
    Component {
        /// The core module's file.
        core: PathBuf,
        /// wit-component's message, on one line.
        cause: String,
    },
    /// Reading or writing a file failed.
    #[error("{}: {cause}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The error.
        cause: std::io::Error,
    },
}

/// An error chain on one line, as `radar` says errors; wit-parser's
/// messages span several lines, which are joined too.
fn one_line(e: &anyhow::Error) -> String {
    let chain = e.chain().map(|e| e as &(dyn std::error::Error + 'static));
    let line = crate::error::one_line(chain);
    line.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Writes the C bindings of `world` (found in the WIT folder or file
/// `wit`, its dependencies under `deps/`) into `out`: `WORLD.h`, `WORLD.c`
/// and `WORLD_component_type.o`, the world's type that the component is
/// made from. Gives the files written.
pub fn c_bindings(wit: &Path, world: &str, out: &Path) -> Result<Vec<PathBuf>, CToolError> {
    let wit_error = |e: anyhow::Error| CToolError::Wit {
        wit: wit.to_path_buf(),
        cause: one_line(&e),
    };
    let mut resolve = Resolve::default();
    let (package, _) = resolve.push_path(wit).map_err(wit_error)?;
    let world_id = resolve
        .select_world(&[package], Some(world))
        .map_err(wit_error)?;
    let mut files = Files::default();
    wit_bindgen_c::Opts::default()
        .build()
        .generate(&mut resolve, world_id, &mut files)
        .map_err(|e| CToolError::Bindings {
            world: world.to_string(),
            cause: one_line(&e),
        })?;
    std::fs::create_dir_all(out).map_err(|cause| CToolError::Io {
        path: out.to_path_buf(),
        cause,
    })?;
    let mut written = Vec::new();
    for (name, bytes) in files.iter() {
        let path = out.join(name);
        std::fs::write(&path, bytes).map_err(|cause| CToolError::Io {
            path: path.clone(),
            cause,
        })?;
        written.push(path);
    }
    Ok(written)
}

/// The component made of the core module `core` (a wasm32-wasi reactor
/// whose custom section holds its world's type, as the C bindings' object
/// file gives it), with the WASI preview 1 adapter of the wasmtime Radar
/// runs on.
pub fn component_new(core: &Path) -> Result<Vec<u8>, CToolError> {
    use wasi_preview1_component_adapter_provider::{
        WASI_SNAPSHOT_PREVIEW1_ADAPTER_NAME as ADAPTER_NAME,
        WASI_SNAPSHOT_PREVIEW1_REACTOR_ADAPTER as ADAPTER,
    };
    let bytes = std::fs::read(core).map_err(|cause| CToolError::Io {
        path: core.to_path_buf(),
        cause,
    })?;
    let component_error = |e: anyhow::Error| CToolError::Component {
        core: core.to_path_buf(),
        cause: one_line(&e),
    };
    wit_component::ComponentEncoder::default()
        .validate(true)
        .module(&bytes)
        .map_err(component_error)?
        .adapter(ADAPTER_NAME, ADAPTER)
        .map_err(component_error)?
        .encode()
        .map_err(component_error)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_world_and_a_bad_module_are_one_line_errors() {
        let dir = tempfile::tempdir().expect("temp dir");
        std::fs::write(
            dir.path().join("a.wit"),
            "package a:b;\nworld w {\n  export f: func();\n}\n",
        )
        .expect("written");
        let out = dir.path().join("out");
        let e = c_bindings(dir.path(), "nope", &out).expect_err("no such world");
        assert!(e.to_string().contains("nope"), "{e}");
        assert!(!e.to_string().contains('\n'), "{e}");

        let written = c_bindings(dir.path(), "w", &out).expect("bindings");
        let names: Vec<_> = written
            .iter()
            .map(|p| {
                p.file_name()
                    .expect("a name")
                    .to_string_lossy()
                    .into_owned()
            })
            .collect();
        assert!(names.contains(&"w.h".to_string()), "{names:?}");
        assert!(
            names.contains(&"w_component_type.o".to_string()),
            "{names:?}"
        );

        let core = dir.path().join("core.wasm");
        std::fs::write(&core, b"not wasm").expect("written");
        let e = component_new(&core).expect_err("not a module");
        assert!(e.to_string().contains("core.wasm"), "{e}");
        assert!(!e.to_string().contains('\n'), "{e}");
    }
}

//! The loader: one per system, it holds the engines and linkers and turns
//! component bytes into [`PluginCode`], compiling each component once
//! (in memory and in the disk cache, see [`super::cache`]) and checking its
//! world ([`super::world`]).

use super::shelf::{MemoryShelf, StackShelf};
use std::collections::HashMap;
use std::hash::{Hash, Hasher};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use sha2::{Digest, Sha256};
use wasmtime::component::{types, Component, Linker};
use wasmtime::{Config, Engine};

use super::cache::{cache_budget, compiling, load_artifact, prune_cache, write_atomically};
use super::call::EXPORTS;
use super::code::{export_index, is_slots_interface, PluginCode};
use super::store::PluginCtx;
use super::world::validate;
use crate::capability::{board, shared_types, signals};
use crate::error::RadarError;

/// Compiles and validates plugin components.
pub(crate) struct Loader {
    /// For small components (most Rust plugins): linear memory filled by
    /// copying, which keeps each instance's memory in two mappings.
    copied: EngineFlavour,
    /// For components of [`MAPPED_IMAGE_FROM`] bytes and more (Python and
    /// JavaScript interpreters with their pre-initialised heaps): linear
    /// memory mapped copy-on-write from the compiled artifact, so an
    /// instance shares the image until it writes a page.
    mapped: EngineFlavour,
    cache_dir: Option<PathBuf>,
    compiled: HashMap<String, Component>,
    /// Validated and linked, by content hash: loading the same component
    /// again (a swap to a version this system knows) is a lookup.
    prepared: HashMap<String, PluginCode>,
    /// The content hash of each file loaded, with what identified the file
    /// then: a file loaded again unchanged is not read or hashed again.
    hashed: HashMap<PathBuf, (FileStamp, String)>,
    /// Plugins that run scripts ([`crate::script`]): their development
    /// runtime with the script last loaded for them.
    scripted: HashMap<String, PluginCode>,
}

/// Components this large or larger get copy-on-write memory images.
///
/// Why two engines: a copy-on-write image is mapped into the middle of a
/// linear memory, which splits its mapping in three, and 10,000 running
/// responses of four mappings each already use most of the kernel's
/// default `vm.max_map_count` (65,530) once their fiber stacks are
/// counted. Copying a small plugin's data (16 KiB for a Rust plugin) costs
/// about 20 µs an instance; copying an interpreter's heap costs milliseconds
/// and its memory is no longer shared (measured by the `languages`
/// benchmark: a Python instance 0.8 ms mapped, 7.7 ms copied).
const MAPPED_IMAGE_FROM: usize = 1 << 20;

/// One engine, its linker, and the key its compiled artifacts are cached
/// under (artifacts load only into an engine with the same settings).
struct EngineFlavour {
    engine: Engine,
    linker: Linker<PluginCtx>,
    key: u64,
}

impl EngineFlavour {
    fn new(copy_on_write: bool, compact: bool) -> Result<Self, RadarError> {
        let mut config = Config::new();
        config.consume_fuel(true);
        config.memory_init_cow(copy_on_write);
        // The guard region before each linear memory is defence in depth
        // against compiler bugs, never touched by correct code; without it
        // a memory is one mapping fewer (the guard after it stays, so
        // bounds checks are still elided).
        config.guard_before_linear_memory(false);
        if compact && !copy_on_write {
            // A memory exactly its size, with no reservation or guard
            // region after it: one mapping (adjacent ones even merge)
            // instead of two, at the cost of an explicit bounds check on
            // each access (see `Loader::new`).
            config.memory_reservation(0);
            config.memory_guard_size(0);
            config.memory_reservation_for_growth(0);
        }
        // So that a call that computes can be stopped from outside it
        // (a signal, a stall: see `crate::watchdog`).
        config.epoch_interruption(true);
        // Stacks, and the fixed-size memories of small components, come
        // from the process's shelf (see `shelf.rs`), so that a swap or a
        // reset seldom maps or unmaps anything.
        config.with_host_stack(std::sync::Arc::new(StackShelf::default()));
        if !copy_on_write && !compact {
            config.with_host_memory(std::sync::Arc::new(MemoryShelf::default()));
        }
        let engine = Engine::new(&config).map_err(|e| RadarError::Engine { cause: e.into() })?;
        crate::watchdog::watch_engine(&engine);
        let mut linker = Linker::new(&engine);
        crate::capability::linking::add_to_linker(&mut linker)
            .map_err(|e| RadarError::Engine { cause: e.into() })?;
        let mut hasher = std::collections::hash_map::DefaultHasher::new();
        engine.precompile_compatibility_hash().hash(&mut hasher);
        copy_on_write.hash(&mut hasher);
        compact.hash(&mut hasher);
        Ok(Self {
            engine,
            linker,
            key: hasher.finish(),
        })
    }
}

/// What changes when a file is written or replaced: its size, modification
/// time and, on Unix, its inode and status-change time (a rename changes
/// those even when it keeps the modification time).
#[derive(Clone, PartialEq, Eq)]
struct FileStamp {
    len: u64,
    modified: Option<std::time::SystemTime>,
    #[cfg(unix)]
    inode: (u64, u64, i64, i64),
}

impl FileStamp {
    fn of(path: &Path) -> Option<Self> {
        let meta = std::fs::metadata(path).ok()?;
        #[cfg(unix)]
        use std::os::unix::fs::MetadataExt;
        Some(Self {
            len: meta.len(),
            modified: meta.modified().ok(),
            #[cfg(unix)]
            inode: (meta.dev(), meta.ino(), meta.ctime(), meta.ctime_nsec()),
        })
    }
}

const COMPONENT_LAYER: [u8; 4] = [0x0d, 0x00, 0x01, 0x00];

impl Loader {
    /// A loader with its engines. `compact`: for a large system, small
    /// components' memories take one memory mapping each, not two, so that
    /// tens of thousands of instances stay under the kernel's
    /// `vm.max_map_count` (65,530 by default); their code then checks
    /// bounds on each memory access instead of relying on a guard region.
    pub fn new(cache_dir: Option<PathBuf>, compact: bool) -> Result<Self, RadarError> {
        Ok(Self {
            copied: EngineFlavour::new(false, compact)?,
            mapped: EngineFlavour::new(true, compact)?,
            cache_dir,
            compiled: HashMap::new(),
            prepared: HashMap::new(),
            hashed: HashMap::new(),
            scripted: HashMap::new(),
        })
    }

    /// `runtime` (a development runtime) running the script whose main
    /// file is `main`, noted as `plugin`'s: later versions of the plugin
    /// keep its script, later scripts its runtime.
    pub fn with_script(
        &mut self,
        plugin: &str,
        runtime: &PluginCode,
        main: &Path,
    ) -> Result<PluginCode, RadarError> {
        let code = runtime.with_script(crate::script::pack(plugin, main)?);
        self.scripted.insert(plugin.to_string(), code.clone());
        Ok(code)
    }

    /// A new version of `plugin` from `path`: a script for a plugin that
    /// runs one (its runtime stays), else a component (which, for such a
    /// plugin, runs the plugin's script). `builtin` is a built-in
    /// component's bytes, if `path` named one.
    pub fn load_version(
        &mut self,
        plugin: &str,
        path: &Path,
        builtin: Option<&[u8]>,
    ) -> Result<PluginCode, RadarError> {
        if builtin.is_none() && crate::script::is_script(path) {
            let Some(runtime) = self.scripted.get(plugin).cloned() else {
                return Err(RadarError::BadSetting {
                    plugin: plugin.into(),
                    cause: format!(
                        "{} is a script, but the plugin runs no development runtime \
                         (give it `source` in the manifest)",
                        path.display()
                    ),
                });
            };
            return self.with_script(plugin, &runtime, path);
        }
        let code = match builtin {
            Some(bytes) => self.load_bytes(plugin, bytes)?,
            None => self.load_file(plugin, path)?,
        };
        match self.scripted.get(plugin).and_then(|c| c.script.clone()) {
            Some(script) => {
                let code = code.with_script(script);
                self.scripted.insert(plugin.to_string(), code.clone());
                Ok(code)
            }
            None => Ok(code),
        }
    }

    fn flavour(&self, component_bytes: usize) -> &EngineFlavour {
        if component_bytes >= MAPPED_IMAGE_FROM {
            &self.mapped
        } else {
            &self.copied
        }
    }

    /// Reads, compiles (or fetches from the cache) and validates a plugin.
    pub fn load_file(&mut self, plugin: &str, path: &Path) -> Result<PluginCode, RadarError> {
        let stamp = FileStamp::of(path);
        if let (Some(stamp), Some((seen, digest))) = (&stamp, self.hashed.get(path)) {
            if stamp == seen {
                if let Some(code) = self.prepared.get(digest) {
                    return Ok(code.clone());
                }
            }
        }
        let bytes = std::fs::read(path).map_err(|cause| RadarError::Read {
            plugin: plugin.into(),
            path: path.into(),
            cause,
        })?;
        let digest = format!("{:x}", Sha256::digest(&bytes));
        let code = self.load_hashed(plugin, &bytes, digest.clone())?;
        if let Some(stamp) = stamp {
            self.hashed.insert(path.to_path_buf(), (stamp, digest));
        }
        Ok(code)
    }

    /// Compiles (or fetches from the cache) a deliberative component (the
    /// system floor checks its world).
    pub fn compile_program(
        &mut self,
        name: &str,
        bytes: &[u8],
    ) -> Result<wasmtime::component::Component, RadarError> {
        let digest = format!("{:x}", Sha256::digest(bytes));
        self.compile(name, bytes, &digest)
    }

    pub fn load_bytes(&mut self, plugin: &str, bytes: &[u8]) -> Result<PluginCode, RadarError> {
        let digest = format!("{:x}", Sha256::digest(bytes));
        self.load_hashed(plugin, bytes, digest)
    }

    fn load_hashed(
        &mut self,
        plugin: &str,
        bytes: &[u8],
        digest: String,
    ) -> Result<PluginCode, RadarError> {
        if let Some(code) = self.prepared.get(&digest) {
            return Ok(code.clone());
        }
        let component = self.compile(plugin, bytes, &digest)?;
        let wrong = |cause: String| RadarError::WrongWorld {
            plugin: plugin.into(),
            cause,
        };
        let engine = component.engine();
        let declared = signals::declared(engine, &component).map_err(wrong)?;
        let board_ports = board::declared(engine, &component).map_err(wrong)?;
        let ports = board_ports.as_ref().map_or(&[][..], |b| &b.ports);
        if let Some((port, what)) = ports
            .iter()
            .find_map(|p| p.ty.unsupported().map(|what| (p, what)))
        {
            return Err(wrong(format!(
                "its blackboard entry `{}` is a {what}; entries hold values, so a resource, a \
                 stream or a future cannot be one",
                port.entry
            )));
        }
        let kind = validate(
            plugin,
            &component,
            declared.as_ref().map_or(&[][..], |d| &d.signals),
        )?;
        // A plugin's own signals and blackboard entries are typed by its
        // world: linked for it alone.
        let types_only = shared_types::imports(engine, &component);
        let pre = if declared.is_none() && board_ports.is_none() && types_only.is_empty() {
            self.flavour(bytes.len()).linker.instantiate_pre(&component)
        } else {
            let mut linker = self.flavour(bytes.len()).linker.clone();
            let linked = declared
                .as_ref()
                .map_or(Ok(()), |d| {
                    signals::link(&mut linker, &d.import, &d.signals)
                })
                .and_then(|()| {
                    board_ports
                        .as_ref()
                        .map_or(Ok(()), |b| board::link(&mut linker, b))
                });
            linked
                .and_then(|()| shared_types::link(&mut linker, &types_only))
                .and_then(|()| linker.instantiate_pre(&component))
        }
        .map_err(|e| wrong(format!("{e:#}")))?;
        let slots = component
            .component_type()
            .exports(engine)
            .find(|(name, item)| {
                matches!(item.ty, types::ComponentItem::ComponentInstance(_))
                    && is_slots_interface(name)
            })
            .map(|(name, _)| name.to_string());
        let exports =
            Arc::new(EXPORTS.map(|name| export_index(&component, slots.as_deref(), name)));
        let code = PluginCode {
            kind,
            version: digest[..12].to_string(),
            pre: Some(pre),
            backed: None,
            board: board_ports.map(|b| b.ports).unwrap_or_default().into(),
            exports,
            component_version: digest[..12].into(),
            script: None,
            bytes: bytes.into(),
        };
        self.prepared.insert(digest, code.clone());
        Ok(code)
    }

    fn compile(
        &mut self,
        plugin: &str,
        bytes: &[u8],
        digest: &str,
    ) -> Result<Component, RadarError> {
        let not_component = |cause: String| RadarError::NotAComponent {
            plugin: plugin.into(),
            cause,
        };
        if bytes.len() < 8 || &bytes[..4] != b"\0asm" {
            return Err(not_component(
                "the file does not start with the wasm magic number".into(),
            ));
        }
        if bytes[4..8] != COMPONENT_LAYER {
            return Err(not_component(
                "it is a core wasm module; build it as a component (target wasm32-wasip2, \
                 or `wasm-tools component new`)"
                    .into(),
            ));
        }
        let flavour = self.flavour(bytes.len());
        let key = format!("{digest}-{:016x}", flavour.key);
        if let Some(c) = self.compiled.get(&key) {
            return Ok(c.clone());
        }
        let cached = self
            .cache_dir
            .as_ref()
            .map(|d| d.join(format!("{key}.cwasm")));
        if let Some(c) = cached
            .as_ref()
            .and_then(|p| load_artifact(&flavour.engine, p))
        {
            // Its modification time is its last use, for pruning.
            if let Some(path) = &cached {
                let _ = std::fs::File::options()
                    .append(true)
                    .open(path)
                    .and_then(|f| f.set_modified(std::time::SystemTime::now()));
            }
            self.compiled.insert(key, c.clone());
            return Ok(c);
        }
        compiling(plugin, bytes.len());
        let component =
            Component::new(&flavour.engine, bytes).map_err(|e| not_component(format!("{e:#}")))?;
        if let (Some(path), Ok(artifact)) = (cached, component.serialize()) {
            // The cache only saves time: failing to write it is not an error.
            let _ = write_atomically(&path, &artifact);
            if let Some(dir) = path.parent() {
                prune_cache(dir, cache_budget(), &path);
            }
        }
        self.compiled.insert(key, component.clone());
        Ok(component)
    }
}

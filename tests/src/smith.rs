//! Random guest code (wasm-smith) behind a
//! plugin's interface, so that the component is valid and loads, and what
//! runs is arbitrary.

use arbitrary::Unstructured;
use wasm_encoder::{
    CodeSection, ComponentBuilder, ComponentExportKind, ExportKind, ExportSection, FunctionSection,
    Module, PrimitiveValType, TypeSection, ValType,
};

/// A core module that exports what an event's core module must:
/// `check: [] -> [i32]`, the lowered `check: func() -> bool`.
fn required_exports() -> Vec<u8> {
    let mut module = Module::new();
    let mut types = TypeSection::new();
    types.ty().function([], [ValType::I32]);
    module.section(&types);
    let mut funcs = FunctionSection::new();
    funcs.function(0);
    module.section(&funcs);
    let mut exports = ExportSection::new();
    exports.export("check", ExportKind::Func, 0);
    module.section(&exports);
    let mut code = CodeSection::new();
    let mut body = wasm_encoder::Function::new([]);
    body.instructions().i32_const(0).end();
    code.function(&body);
    module.section(&code);
    module.finish()
}

/// An event component whose `check` is a random core function: wasm-smith
/// draws a module from `data` (exporting `check`, importing nothing, with
/// the proposals Radar's engine has), and a component lifts it as `check:
/// func() -> bool`.
pub fn event_component(data: &[u8]) -> Option<Vec<u8>> {
    let mut u = Unstructured::new(data);
    let mut config = wasm_smith::Config {
        max_imports: 0,
        exports: Some(required_exports()),
        max_memories: 1,
        max_memory32_bytes: 1 << 24,
        ..wasm_smith::Config::default()
    };
    config.threads_enabled = false;
    config.gc_enabled = false;
    config.exceptions_enabled = false;
    config.memory64_enabled = false;
    config.custom_page_sizes_enabled = false;
    config.wide_arithmetic_enabled = false;
    config.relaxed_simd_enabled = false;
    let core = wasm_smith::Module::new(config, &mut u).ok()?.to_bytes();
    let mut component = ComponentBuilder::default();
    let module = component.core_module_raw(None, &core);
    let instance =
        component.core_instantiate(None, module, Vec::<(&str, wasm_encoder::ModuleArg)>::new());
    let check = component.core_alias_export(None, instance, "check", ExportKind::Func);
    let (ty, encoder) = component.ty(None);
    encoder
        .function()
        .params(Vec::<(&str, wasm_encoder::ComponentValType)>::new())
        .result(Some(PrimitiveValType::Bool.into()));
    let lifted = component.lift_func(None, check, ty, Vec::<wasm_encoder::CanonicalOption>::new());
    component.export("check", ComponentExportKind::Func, lifted, None);
    Some(component.finish())
}

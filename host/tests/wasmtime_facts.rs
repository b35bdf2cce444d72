//! The facts about wasmtime that Radar's design rests on
//! (docs/architecture.md, "What wasmtime gives"), checked against the
//! wasmtime Radar links, so that an upgrade that changes one fails here
//! rather than somewhere in the scheduler.

use std::future::Future;
use std::pin::pin;
use std::task::{Context, Poll, Waker};

use wasmtime::component::{Component, Linker, Val};
use wasmtime::{Config, Engine, Store};

/// A component with an export that traps, one that returns 7, and one that
/// calls the host's `wait` (which, when async, never returns).
const COMPONENT: &str = r#"
(component
  (import "wait" (func $wait))
  (core func $wait_lowered (canon lower (func $wait)))
  (core module $m
    (import "host" "wait" (func $wait))
    (func (export "trap") unreachable)
    (func (export "seven") (result i32) i32.const 7)
    (func (export "waits") call $wait))
  (core instance $i (instantiate $m
    (with "host" (instance (export "wait" (func $wait_lowered))))))
  (func (export "trap") (canon lift (core func $i "trap")))
  (func (export "seven") (result u32) (canon lift (core func $i "seven")))
  (func (export "waits") (canon lift (core func $i "waits"))))
"#;

fn engine(fuel: bool) -> Engine {
    let mut config = Config::new();
    config.consume_fuel(fuel);
    Engine::new(&config).expect("an engine")
}

/// Polls `future` to its end on this thread (its host calls are ready at
/// once).
fn block_on<F: Future>(future: F) -> F::Output {
    let mut future = pin!(future);
    let mut cx = Context::from_waker(Waker::noop());
    loop {
        if let Poll::Ready(out) = future.as_mut().poll(&mut cx) {
            return out;
        }
    }
}

/// A store with the component instantiated, its `wait` import async and
/// never ready.
fn instance(engine: &Engine) -> (Store<()>, wasmtime::component::Instance) {
    let component = Component::new(engine, COMPONENT).expect("the component compiles");
    let mut linker: Linker<()> = Linker::new(engine);
    linker
        .root()
        .func_wrap_async("wait", |_, (): ()| {
            Box::new(async {
                std::future::pending::<()>().await;
                Ok(())
            })
        })
        .expect("wait linked");
    let mut store = Store::new(engine, ());
    store.set_fuel(u64::MAX).expect("fuel");
    let instance =
        block_on(linker.instantiate_async(&mut store, &component)).expect("instantiates");
    (store, instance)
}

fn call(
    store: &mut Store<()>,
    instance: &wasmtime::component::Instance,
    name: &str,
) -> wasmtime::Result<Vec<Val>> {
    let func = instance.get_func(&mut *store, name).expect("the export");
    let results = func.ty(&*store).results().len();
    let mut out = vec![Val::Bool(false); results];
    block_on(func.call_async(&mut *store, &[], &mut out))?;
    Ok(out)
}

#[test]
fn a_trap_leaves_the_store_unusable_so_a_reset_is_a_fresh_store() {
    let engine = engine(true);
    let (mut store, instance) = instance(&engine);
    assert_eq!(
        call(&mut store, &instance, "seven").expect("a call"),
        [Val::U32(7)]
    );
    assert!(call(&mut store, &instance, "trap").is_err(), "the trap");
    assert!(
        call(&mut store, &instance, "seven").is_err(),
        "wasmtime let an instance that trapped be entered again: Radar's reset could keep its store"
    );
}

#[test]
fn a_call_dropped_in_the_middle_leaves_the_store_unusable_so_interruption_is_cooperative() {
    let engine = engine(true);
    let (mut store, instance) = instance(&engine);
    {
        let func = instance.get_func(&mut store, "waits").expect("the export");
        let mut future = Box::pin(func.call_async(&mut store, &[], &mut []));
        let mut cx = Context::from_waker(Waker::noop());
        assert!(
            future.as_mut().poll(&mut cx).is_pending(),
            "the call waits in its host import"
        );
        // Dropped here, in the middle of the call.
    }
    assert!(
        call(&mut store, &instance, "seven").is_err(),
        "wasmtime let a store whose call was dropped be entered again"
    );
}

#[test]
fn a_store_with_async_imports_takes_only_async_calls() {
    let engine = engine(true);
    let (mut store, instance) = instance(&engine);
    let func = instance.get_func(&mut store, "seven").expect("the export");
    let mut out = [Val::Bool(false)];
    assert!(
        func.call(&mut store, &[], &mut out).is_err(),
        "a synchronous call into a store with async imports was allowed"
    );
}

#[test]
#[allow(unsafe_code)] // deserializing what this test itself serialized
fn a_compiled_component_loads_only_into_an_engine_with_the_same_settings() {
    let with_fuel = engine(true);
    let bytes = Component::new(&with_fuel, COMPONENT)
        .and_then(|c| c.serialize())
        .expect("compiled and serialized");
    // SAFETY: the bytes were made by `serialize` just above.
    let same = unsafe { Component::deserialize(&with_fuel, &bytes) };
    assert!(same.is_ok(), "the same engine loads it");
    // SAFETY: as above; the other engine must refuse them.
    let other = unsafe { Component::deserialize(&engine(false), &bytes) };
    assert!(
        other.is_err(),
        "an engine without fuel loaded a component compiled with it: the cache's key could drop the engine's settings"
    );
}

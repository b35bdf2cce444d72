//! A test fixture: a deliberative component that uses every construct of
//! the `system` interface (anonymous slots included) on a system of E
//! (TestEvent counting to 2), F (a timer event, 3 s) and R (TestResponse
//! counting 2 s), logs what it saw, and fails (`run` returns the error)
//! when anything is not what the semantics say.
use radar_guest::deliberative::*;

fn check(what: &str, ok: bool) -> Result<(), Error> {
    if ok {
        info(&format!("ok: {what}"));
        Ok(())
    } else {
        Err(Error(format!("failed: {what}")))
    }
}

fn main() -> Result<(), Error> {
    check("R starts idle", plugin_state("R")? == "idle")?;
    check("E is inactive", plugin_state("E")? == "inactive")?;
    // waitfor with a timeout that passes first, then without one.
    check(
        "waitfor times out at 1.5 s",
        waitfor::<u32>("E", Some(Duration::from_millis(1500)))?.is_none(),
    )?;
    let count: Option<u32> = waitfor("E.triggered", None)?;
    check("waitfor returns E's payload", count == Some(2))?;
    check("at 2 s", now() == Duration::from_secs(2))?;
    {
        // A scoped whenever with a queue: ends with the block.
        let c = connect(Link::whenever("E", "R.start").busy(Busy::Queue(1)))?;
        check("a connection has its id", c.ids().len() == 1)?;
        sleep(Duration::from_secs(4))?;
        check("R runs meanwhile", plugin_state("R")? == "running")?;
    }
    // A kept connection outlives its guard; once ... until.
    once("F", Interrupt, "R")?.keep();
    let _until = once_until("E", "R", "F")?;
    inject("R.start", &7u32)?;
    let exited: Option<Json> = waitfor("R.exited", Some(Duration::from_secs(10)))?;
    check("R exited", exited.is_some())?;
    check(
        "a bad slot is an error",
        inject("R.nothing", &1u32).is_err_and(|e| e.0.contains("nothing")),
    )?;
    check(
        "config reaches the program",
        config_or("greeting", String::new()) == "hello",
    )?;
    // An anonymous slot: its handler runs at each delivery, while the
    // program waits.
    let seen = std::rc::Rc::new(std::cell::Cell::new(0u32));
    let counter = seen.clone();
    let slot = on("E", move |payload| {
        info(&format!(
            "anonymous slot: E.triggered({payload}) at {:?}",
            now()
        ));
        counter.set(counter.get() + 1);
    })?;
    sleep(Duration::from_secs(5))?;
    check("the anonymous slot ran twice", seen.get() == 2)?;
    // A waitfor meanwhile still sees its own signal.
    let count: Option<u32> = waitfor("E", Some(Duration::from_secs(3)))?;
    check("waitfor beside an anonymous slot", count == Some(2))?;
    // The slot's delivery of that same emission runs at the next wait.
    sleep(Duration::ZERO)?;
    check("the slot ran for that one too", seen.get() == 3)?;
    drop(slot);
    Ok(())
}

radar_guest::program!(main);

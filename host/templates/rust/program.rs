//! `{{plugin}}`: a deliberative program. It wires the system at run time, as
//! the paper's Listing 2 does: whenever Trigger triggers, Responder starts;
//! and it waits for Responder's first run to end and logs its result.
use radar_guest::deliberative::*;

fn main() -> Result<(), Error> {
    // whenever Trigger start Responder, for the rest of the run (without
    // keep(), a connection ends when its guard is dropped).
    whenever("Trigger", Start, "Responder")?.keep();
    // waitfor: the first run's end, or None after 30 s.
    let exited: Option<Json> = waitfor("Responder.exited", Some(Duration::from_secs(30)))?;
    info(&format!(
        "Responder exited with {}",
        exited.unwrap_or(Json::Null)
    ));
    Ok(())
}

radar_guest::program!(main);

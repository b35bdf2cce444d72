//! The soak (`docs/testing.md#soak`): Radar run long, to find what only
//! time shows (a leak, a count that wraps, a law broken once an hour).
//!
//! ```sh
//! cargo run --release -p radar-tests --example soak -- virtual            # 1 h of virtual time, 1,000 plugins
//! cargo run --release -p radar-tests --example soak -- real               # 10 min, an agent killed every minute
//! cargo run --release -p radar-tests --example soak -- virtual --for 5m --plugins 200
//! ```
//!
//! `virtual`: a random system of events and responses (half and half) under
//! a deliberative program that, all along, connects and disconnects them
//! (every mode and busy policy), swaps them for other builds (some that
//! fit, some that do not), injects starts and resets what faulted; every
//! response has faults injected (traps, a failed reset). The laws are
//! checked on the whole trace as it is made, without keeping it; resident
//! memory is printed as the run begins, every ten minutes, and at the end.
//!
//! `real`: `radar run` of a system on the network whose responses run on
//! the agent `base`, under the real clock; the agent is killed and started
//! again every minute. The trace file is checked against the laws, and the
//! coordinator's resident memory printed as it goes.
//!
//! Either exits 1 if a law is broken, a record lost, or memory grew by more
//! than a quarter after the first minute.

use std::collections::BTreeMap;
use std::io::BufRead;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use radar::testing::simulate::Stream;
use radar::trace::{Laws, Record, TraceSink};
use radar::{Busy, FaultKind, InjectedFault, Link, Plugin, PluginState, SwapPolicy, System};
use radar_fixtures::plugins;

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mode = args.first().map_or("virtual", String::as_str);
    let value = |flag: &str| {
        args.iter()
            .position(|a| a == flag)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    let duration = |default: Duration| -> Result<Duration> {
        value("--for").map_or(Ok(default), |v| {
            radar::manifest::parse_duration(&v).map_err(anyhow::Error::msg)
        })
    };
    match mode {
        "virtual" => {
            let plugins: usize = value("--plugins").map_or(Ok(1000), |v| v.parse())?;
            let seed: u64 = value("--seed").map_or(Ok(1), |v| v.parse())?;
            virtual_soak(plugins.max(2), duration(Duration::from_secs(3600))?, seed)
        }
        "real" => real_soak(duration(Duration::from_secs(600))?),
        other => bail!("`{other}`: the soak is `virtual` or `real`"),
    }
}

/// Resident memory of process `pid` (`self` for this one), in MiB.
fn rss_mib(pid: &str) -> f64 {
    std::fs::read_to_string(format!("/proc/{pid}/status"))
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmRSS:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<f64>().ok())
        })
        .map_or(0.0, |kb| kb / 1024.0)
}

/// The laws, checked as records come, shared with the code that reads them
/// after the run.
#[derive(Clone, Default)]
struct Checked(Arc<Mutex<(Laws, BTreeMap<String, u64>)>>);

impl TraceSink for Checked {
    fn record(&mut self, record: &Record) {
        let mut inner = self.0.lock().unwrap_or_else(|e| e.into_inner());
        inner.0.observe(record);
        let kind = serde_json::to_value(&record.entry)
            .ok()
            .and_then(|v| v["kind"].as_str().map(str::to_string))
            .unwrap_or_default();
        *inner.1.entry(kind).or_default() += 1;
    }
}

fn virtual_soak(count: usize, run_for: Duration, seed: u64) -> Result<()> {
    let began = Instant::now();
    let (events, responses) = (count / 2, count - count / 2);
    let mut choose = Stream::new(seed, "soak system");
    let mut builder = System::builder().keep_trace(false).memory_budget(8 << 30);
    for e in 0..events {
        let interval = [0.5, 1.0, 2.0][choose.below(3) as usize];
        builder = builder.plugin(
            Plugin::file(format!("E{e}"), plugins::COUNTER_EVENT)
                .config("interval_s", interval.to_string()),
        );
    }
    for r in 0..responses {
        let name = format!("R{r}");
        let plugin = if choose.below(2) == 0 {
            Plugin::file(&name, plugins::TEST_RESPONSE)
                .config("interval_s", "0.5")
                .config(
                    "count_for_s",
                    ["0.5", "1.0", "2.0"][choose.below(3) as usize],
                )
        } else {
            Plugin::file(&name, plugins::COUNT_UP).config("count_to", "3")
        };
        builder = builder.plugin(plugin);
        // Faults all along: a trap every few hundred calls, each reset
        // 2 s later; every third reset or so (its 3rd, 6th and 9th
        // instantiation) fails, and is tried again 1 s later.
        let mut at = 0;
        for n in 0..12 {
            at += choose.between(50, 600);
            builder = builder.fault(
                &name,
                InjectedFault {
                    kind: FaultKind::Trap,
                    at,
                    reset_after: Some(Duration::from_secs(2)),
                },
            );
            if n % 4 == 3 {
                builder = builder.fault(
                    &name,
                    InjectedFault {
                        kind: FaultKind::Instantiation,
                        at: 3 * (n / 4 + 1),
                        reset_after: Some(Duration::from_secs(1)),
                    },
                );
            }
        }
    }
    let checked = Checked::default();
    let system = builder.trace_to(checked.clone()).build()?;
    let rss_start = rss_mib("self");
    println!(
        "soak (virtual): {count} plugins ({events} events, {responses} responses), {} s of \
         virtual time, seed {seed}; built in {:.1} s; resident {rss_start:.1} MiB",
        run_for.as_secs(),
        began.elapsed().as_secs_f64()
    );
    let samples = Arc::new(Mutex::new(Vec::<(u64, f64, usize)>::new()));
    let actions = Arc::new(Mutex::new(BTreeMap::<&'static str, u64>::new()));
    let (program_samples, program_actions, program_checked) =
        (samples.clone(), actions.clone(), checked.clone());
    let ran = Instant::now();
    let report = system.run_with(Some(run_for), move |radar| -> Result<(), radar::RadarError> {
        let mut choose = Stream::new(seed, "soak program");
        let mut live: Vec<radar::Connection> = Vec::new();
        let mut next_sample = Duration::ZERO;
        let count = |what: &'static str| {
            *program_actions
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .entry(what)
                .or_default() += 1;
        };
        loop {
            let now = radar.now()?;
            if now >= next_sample {
                let records = program_checked
                    .0
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .0
                    .records();
                let rss = rss_mib("self");
                program_samples
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .push((now.as_secs(), rss, records));
                println!(
                    "  t = {:>5} s  resident {rss:>8.1} MiB  records {records:>10}  connections {:>5}",
                    now.as_secs(),
                    live.len()
                );
                // The first minute's end, every ten minutes, and the run's
                // last second.
                let last = run_for.saturating_sub(Duration::from_secs(1));
                next_sample = if now < Duration::from_secs(60) {
                    Duration::from_secs(60)
                } else if now < last {
                    (next_sample + Duration::from_secs(600)).min(last)
                } else {
                    Duration::MAX
                };
            }
            radar.sleep(Duration::from_millis(choose.between(5, 200)))?;
            let e = format!("E{}", choose.below(events as u64));
            let r = format!("R{}", choose.below(responses as u64));
            // The live connections stay about 400 (a steady state: what
            // grows over the hour is a leak, not the system).
            let action = match choose.below(100) {
                0..=34 if live.len() >= 400 => 35,
                n => n,
            };
            match action {
                0..=34 => {
                    let busy = match choose.below(3) {
                        0 => Busy::Drop,
                        1 => Busy::Queue(1 + choose.below(3) as usize),
                        _ => Busy::Restart,
                    };
                    let from = format!("{e}.triggered");
                    let to = format!("{r}.start");
                    let link = if choose.below(4) == 0 {
                        Link::once(&from, &to)
                    } else {
                        Link::whenever(&from, &to)
                    };
                    if let Ok(connection) = radar.connect(link.busy(busy)) {
                        live.push(connection);
                        count("connect");
                    }
                }
                35..=64 if !live.is_empty() => {
                    let i = choose.below(live.len() as u64) as usize;
                    drop(live.swap_remove(i));
                    count("disconnect");
                }
                65..=74 => {
                    let (plugin, path) = if choose.below(2) == 0 {
                        let v2 = choose.below(2) == 0;
                        (e, if v2 { plugins::COUNTER_EVENT_V2 } else { plugins::COUNTER_EVENT })
                    } else {
                        let up = choose.below(2) == 0;
                        (r, if up { plugins::COUNT_UP } else { plugins::TEST_RESPONSE })
                    };
                    let policy = if choose.below(2) == 0 {
                        SwapPolicy::Drain
                    } else {
                        SwapPolicy::Restart
                    };
                    // Refused when it does not fit: that is exercised too.
                    count(if radar.swap(&plugin, path, policy).is_ok() {
                        "swap"
                    } else {
                        "swap refused"
                    });
                }
                75..=89 => {
                    if radar.inject(&format!("{r}.start"), serde_json::json!(7)).is_ok() {
                        count("inject");
                    }
                }
                _ => {
                    if radar.plugin_state(&r)? == PluginState::Error && radar.reset(&r).is_ok() {
                        count("reset");
                    }
                }
            }
        }
    })?;
    let wall = ran.elapsed();
    let rss_after = rss_mib("self");
    let (laws, kinds) = std::mem::take(&mut *checked.0.lock().unwrap_or_else(|e| e.into_inner()));
    let records = laws.records();
    let violations = laws.finish();
    println!(
        "ran {:.1} s of virtual time in {:.1} s of wall time: {records} records ({:.0} a second)",
        report.ended_at.as_secs_f64(),
        wall.as_secs_f64(),
        records as f64 / wall.as_secs_f64()
    );
    println!(
        "program: {:?}",
        actions.lock().unwrap_or_else(|e| e.into_inner())
    );
    let pick = |k: &str| kinds.get(k).copied().unwrap_or(0);
    println!(
        "records: {} signals, {} deliveries, {} dropped, {} faults, {} resets, {} swaps, {} \
         refused swaps, {} rolled back",
        pick("signal"),
        pick("deliver"),
        pick("dropped"),
        pick("fault"),
        pick("reset"),
        pick("swap"),
        pick("swap-refused"),
        pick("swap-rolled-back")
    );
    let samples = samples.lock().unwrap_or_else(|e| e.into_inner()).clone();
    let after_warmup = samples
        .iter()
        .find(|(t, _, _)| *t >= 60)
        .map_or(rss_start, |(_, rss, _)| *rss);
    let rss_end = samples.last().map_or(rss_after, |(_, rss, _)| *rss);
    println!(
        "resident memory: {rss_start:.1} MiB before the run, {after_warmup:.1} MiB after its \
         first minute, {rss_end:.1} MiB in its last second ({:.2}× the first minute's), \
         {rss_after:.1} MiB after it",
        rss_end / after_warmup.max(1.0)
    );
    judge(
        &violations,
        &report.trace_errors,
        rss_end,
        after_warmup,
        &report.program,
    )
}

/// The verdict: laws, lost records, memory.
fn judge(
    violations: &[radar::trace::Violation],
    trace_errors: &[String],
    rss_end: f64,
    rss_warm: f64,
    program: &Option<Result<(), radar::ProgramFailure>>,
) -> Result<()> {
    for v in violations.iter().take(10) {
        println!("law broken: {v}");
    }
    if !violations.is_empty() {
        bail!("{} violation(s) of the laws", violations.len());
    }
    if let Some(e) = trace_errors.first() {
        bail!("records lost: {e}");
    }
    if let Some(Err(e)) = program {
        bail!("the soak's program failed: {e}");
    }
    if rss_end > rss_warm * 1.25 + 16.0 {
        bail!("resident memory grew from {rss_warm:.1} MiB to {rss_end:.1} MiB");
    }
    println!("the laws hold on the whole trace, nothing was lost, memory stayed flat");
    Ok(())
}

/// The `radar` binary beside this example (`target/release/radar`).
fn radar_binary() -> Result<PathBuf> {
    let exe = std::env::current_exe()?;
    let dir = exe
        .parent()
        .and_then(Path::parent)
        .context("where the example runs from")?;
    let radar = dir.join("radar");
    if !radar.exists() {
        bail!(
            "{} is not built: cargo build --release -p radar first",
            radar.display()
        );
    }
    Ok(radar)
}

fn free_port() -> Result<u16> {
    Ok(std::net::TcpListener::bind("127.0.0.1:0")?
        .local_addr()?
        .port())
}

fn agent(radar: &Path, endpoint: &str) -> Result<Child> {
    Ok(Command::new(radar)
        .args(["agent", "--name", "base", "--connect", endpoint])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()?)
}

fn real_soak(run_for: Duration) -> Result<()> {
    let radar = radar_binary()?;
    let dir = tempfile::tempdir()?;
    let port = free_port()?;
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let mut manifest = format!(
        "[network]\nsystem = \"soak{port}\"\nlisten = [\"{endpoint}\"]\ncontrol = \"local\"\n\n"
    );
    for i in 0..20 {
        manifest.push_str(&format!(
            "[plugins.E{i}]\nwasm = \"{}\"\nconfig = {{ interval_s = {} }}\n\n\
             [plugins.R{i}]\nwasm = \"{}\"\nconfig = {{ interval_s = 0.2, count_for_s = 0.6 }}\n{}\n\
             [[connect]]\nmode = \"whenever\"\nfrom = \"E{i}.triggered\"\nto = \"R{i}.start\"\nbusy = \"queue\"\nqueue = 2\n\n",
            plugins::COUNTER_EVENT,
            [0.3, 0.5, 1.0][i % 3],
            plugins::TEST_RESPONSE,
            if i % 2 == 0 { "node = \"base\"\n" } else { "" }
        ));
    }
    let manifest_path = dir.path().join("radar.toml");
    std::fs::write(&manifest_path, manifest)?;
    let trace = dir.path().join("trace.jsonl");
    let runtime = dir.path().join("run");
    std::fs::create_dir_all(&runtime)?;
    let mut agent_process = agent(&radar, &endpoint)?;
    let mut run = Command::new(&radar)
        .arg("run")
        .arg(&manifest_path)
        .args(["--clock", "real", "--for"])
        .arg(format!("{}s", run_for.as_secs()))
        .args(["-q", "--allow-faults", "--trace"])
        .arg(&trace)
        .env("XDG_RUNTIME_DIR", &runtime)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()?;
    let pid = run.id().to_string();
    println!(
        "soak (real): 40 plugins, 10 of them on agent base, {} s; the agent is killed every minute",
        run_for.as_secs()
    );
    let began = Instant::now();
    let mut samples: Vec<(u64, f64)> = Vec::new();
    let mut kills = 0;
    let mut next_kill = Duration::from_secs(60);
    let mut next_sample = Duration::from_secs(5);
    while run.try_wait()?.is_none() {
        std::thread::sleep(Duration::from_millis(200));
        let t = began.elapsed();
        if t >= next_sample {
            let rss = rss_mib(&pid);
            samples.push((t.as_secs(), rss));
            if t.as_secs() % 60 < 10 {
                println!(
                    "  t = {:>4} s  coordinator resident {rss:.1} MiB",
                    t.as_secs()
                );
            }
            next_sample += Duration::from_secs(10);
        }
        if t >= next_kill && t + Duration::from_secs(20) < run_for {
            let _ = agent_process.kill();
            let _ = agent_process.wait();
            kills += 1;
            std::thread::sleep(Duration::from_secs(2));
            agent_process = agent(&radar, &endpoint)?;
            next_kill += Duration::from_secs(60);
        }
        if t > run_for + Duration::from_secs(60) {
            let _ = run.kill();
            bail!("the run did not end by itself");
        }
    }
    let _ = agent_process.kill();
    let _ = agent_process.wait();
    let out = run.wait_with_output()?;
    let status = out.status;
    if !status.success() {
        bail!(
            "radar run failed ({status}): {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let mut laws = Laws::default();
    let mut kinds: BTreeMap<String, u64> = BTreeMap::new();
    let mut lost = 0;
    for line in std::io::BufReader::new(std::fs::File::open(&trace)?).lines() {
        let line = line?;
        let record: Record = serde_json::from_str(&line).context("a trace line")?;
        laws.observe(&record);
        let kind = serde_json::from_str::<serde_json::Value>(&line)?["kind"]
            .as_str()
            .unwrap_or_default()
            .to_string();
        if kind == "fault" && line.contains("node-lost") {
            lost += 1;
        }
        *kinds.entry(kind).or_default() += 1;
    }
    let records = laws.records();
    let violations = laws.finish();
    let warm = samples
        .iter()
        .find(|(t, _)| *t >= 60)
        .map_or(0.0, |(_, r)| *r);
    let end = samples.last().map_or(0.0, |(_, r)| *r);
    println!(
        "agent killed {kills} times: {lost} node-lost faults, {} resets; {records} records, {} \
         signals",
        kinds.get("reset").copied().unwrap_or(0),
        kinds.get("signal").copied().unwrap_or(0)
    );
    println!(
        "coordinator resident memory: {warm:.1} MiB after the first minute, {end:.1} MiB at the \
         end ({:.2}×)",
        end / warm.max(1.0)
    );
    if kills > 0 && lost == 0 {
        bail!("the agent was killed but no plugin faulted node-lost");
    }
    judge(&violations, &[], end, warm.max(1.0), &None)
}

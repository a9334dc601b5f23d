//! A ROS 2 subscriber of the alerts of `rockwatch node`: `/pbr/alerts`, type
//! `pbr_msgs/msg/PbrAlert`, with the QoS the node publishes it with (reliable, transient
//! local: a subscriber that joins late still gets the alerts already raised).
//!
//! It joins the DDS domain the way the node does (`ROS_DOMAIN_ID`,
//! `ROS_AUTOMATIC_DISCOVERY_RANGE`), prints each alert as a line of text or of JSON, and ends
//! cleanly on SIGINT/SIGTERM, after `--count` alerts or after `--timeout`. See README.md beside
//! this file for how to run it.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, Context};
use clap::Parser;
use nix::sys::signal::{SigSet, Signal};
use rockwatch::ros2::{
    alerts_qos, msg, network_plan_from_env, Naming, NetworkPlan, Ros2Config, Ros2Session,
    ALERTS_TOPIC, READER_ENCLAVE,
};
use rockwatch_core::record::mseed::format_time_ns;
use ros2_client::dds::rustdds::mio1::{Events, Interest, Poll, Token};
use ros2_client::NodeOptions;

/// Longest wait between two looks at the stop flag, the deadline and the subscription.
const CYCLE: Duration = Duration::from_millis(100);

/// Print the alerts of a running `rockwatch node`, as they are raised, from its ROS 2 topic
/// /pbr/alerts (pbr_msgs/msg/PbrAlert).
///
/// One line per alert on standard output: data time (UTC), level, block, station, mode and
/// the figures that raised it; with --json one JSON object per line instead. Diagnostics go to
/// standard error.
///
/// The topic is reliable and transient local (the node keeps its last 1000 alerts), so
/// alerts raised before this subscriber started are printed first. The DDS domain is
/// ROS_DOMAIN_ID (default 0); ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST (or OFF) keeps the
/// participant on the loopback interface, as for the node: give both the same values. With
/// DDS Security (ROS_SECURITY_ENABLE=true, ROS_SECURITY_KEYSTORE, ROS_SECURITY_STRATEGY) it
/// uses the enclave /rockwatch/reader of launch-scripts/keystore.sh, which may read
/// /pbr/alerts (ROS_SECURITY_ENCLAVE_OVERRIDE picks another).
///
/// Ends after --count alerts (exit 1 if --timeout passes first), after --timeout seconds, or
/// on SIGINT/SIGTERM (exit 0), printing how many alerts it received to standard error.
#[derive(Debug, Parser)]
#[command(name = "ros2-alert-subscriber", version)]
struct Args {
    /// Print each alert as one JSON object per line (keys: data_time_ns, data_time, level,
    /// level_code, pbr_id, station, mode, mode_code, theta_over_alpha, slide_m,
    /// overturn_probability, pga_mps2, pgv_mps, message, episode). One alert per (pbr_id,
    /// episode, level): de-duplicate by that triple.
    #[arg(long)]
    json: bool,
    /// Stop after N alerts.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    count: Option<u64>,
    /// Stop after S seconds; with --count, not having N alerts by then is an error.
    #[arg(long, value_name = "S")]
    timeout: Option<f64>,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    // The libraries' errors (iceoryx2, RustDDS log through `log`) on stderr, as the node's.
    rockwatch::logging::init(&rockwatch::logging::LogOptions::default())?;
    let deadline = match args.timeout {
        Some(s) if s.is_finite() && s >= 0.0 => Some(Instant::now() + Duration::from_secs_f64(s)),
        Some(s) => {
            return Err(anyhow!("--timeout must be a number of seconds ≥ 0, got {s}").into())
        }
        None => None,
    };
    // ROS_DOMAIN_ID and ROS_AUTOMATIC_DISCOVERY_RANGE, resolved exactly as the node does.
    let plan = network_plan_from_env(&Ros2Config::default(), READER_ENCLAVE)?;
    let stop = stop_on_signals()?;

    // The participant's threads must never take SIGINT/SIGTERM: open it with them blocked.
    let (_session, mut subscription) = with_termination_signals_blocked(|| {
        // In the root namespace: ALERTS_TOPIC (`pbr/alerts`) resolves to /pbr/alerts.
        let naming = Naming::new("/", "rockwatch_alert_subscriber", Vec::new())?;
        let mut session = Ros2Session::open(
            &plan,
            &naming,
            // No parameter services: nothing to set, and none to grant under DDS Security.
            NodeOptions::new()
                .enable_rosout(false)
                .start_parameter_services(false),
        )?;
        // The node's QoS for /pbr/alerts: reliable, transient local, keep last 1000.
        let subscription = session.subscription::<msg::PbrAlert>(
            ALERTS_TOPIC,
            msg::PACKAGE,
            "PbrAlert",
            alerts_qos(),
        )?;
        anyhow::Ok((session, subscription))
    })??;
    eprintln!(
        "ros2-alert-subscriber: listening on {ALERTS_TOPIC} ({})",
        describe(&plan)
    );

    // Sleep in a poll on the subscription, never longer than CYCLE.
    let mut poll = Poll::new().context("cannot create a poller")?;
    poll.registry()
        .register(&mut subscription, Token(0), Interest::READABLE)
        .context("cannot register the subscription with the poller")?;
    let mut events = Events::with_capacity(4);
    let mut received = 0u64;
    let end = 'receive: loop {
        while let Some((alert, _info)) = subscription
            .take()
            .map_err(|e| anyhow!("{ALERTS_TOPIC}: cannot take an alert: {e:?}"))?
        {
            println!(
                "{}",
                if args.json {
                    json_line(&alert)
                } else {
                    text_line(&alert)
                }
            );
            received += 1;
            if args.count == Some(received) {
                break 'receive End::Count;
            }
        }
        if stop.load(Ordering::Relaxed) {
            break End::Signal;
        }
        let wait = match deadline {
            Some(d) => match d.checked_duration_since(Instant::now()) {
                Some(left) => left.min(CYCLE),
                None => break End::Timeout,
            },
            None => CYCLE,
        };
        // An interrupted poll (EINTR: a signal arrived) just means "look again".
        let _ = poll.poll(&mut events, Some(wait));
    };
    eprintln!(
        "ros2-alert-subscriber: {received} alerts received ({})",
        end.as_str()
    );
    if let Some(count) = args.count {
        if received < count && end == End::Timeout {
            return Err(anyhow!(
                "received {received} of {count} alerts within {} s: is `rockwatch node` running \
                 with the same ROS_DOMAIN_ID and ROS_AUTOMATIC_DISCOVERY_RANGE ({})?",
                args.timeout.unwrap_or_default(),
                describe(&plan)
            )
            .into());
        }
    }
    Ok(())
}

/// Why the subscriber stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum End {
    /// --count alerts were received.
    Count,
    /// SIGINT or SIGTERM.
    Signal,
    /// --timeout passed.
    Timeout,
}

impl End {
    fn as_str(self) -> &'static str {
        match self {
            End::Count => "count reached",
            End::Signal => "stopped by a signal",
            End::Timeout => "timeout",
        }
    }
}

/// Sets the returned flag on SIGINT or SIGTERM (signal-hook, as `rockwatch node` does).
fn stop_on_signals() -> anyhow::Result<Arc<AtomicBool>> {
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop))
            .with_context(|| format!("cannot handle signal {signal}"))?;
    }
    Ok(stop)
}

/// Runs `open` with SIGINT and SIGTERM blocked on this thread, so that the threads it starts
/// (RustDDS's event loops, the ROS 2 spinner) inherit the mask and never take them: RustDDS
/// 0.15.1 ends an event loop whose poll is interrupted (EINTR), and the subscription would go
/// deaf. Afterwards they are unblocked here again: this thread alone takes them (and sets the
/// stop flag), and its own poll just returns early.
fn with_termination_signals_blocked<T>(open: impl FnOnce() -> T) -> anyhow::Result<T> {
    let mut signals = SigSet::empty();
    signals.add(Signal::SIGINT);
    signals.add(Signal::SIGTERM);
    signals
        .thread_block()
        .context("cannot block SIGINT/SIGTERM")?;
    let opened = open();
    signals
        .thread_unblock()
        .context("cannot unblock SIGINT/SIGTERM")?;
    Ok(opened)
}

/// "domain 0, interfaces 127.0.0.1" or "domain 0, all interfaces".
fn describe(plan: &NetworkPlan) -> String {
    let interfaces = match &plan.only_networks {
        Some(networks) => format!(
            "interfaces {}",
            networks
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ),
        None => "all interfaces".into(),
    };
    format!("domain {}, {interfaces}", plan.domain_id)
}

/// The name of a `PbrAlert.level` code (`msg/pbr_msgs/msg/PbrAlert.msg`; RESET: an operator
/// reset of a fallen block).
fn level_name(code: u8) -> &'static str {
    msg::level_name(code)
}

/// The name of a `PbrAlert.mode` code (`msg/pbr_msgs/msg/PbrAlert.msg`).
fn mode_name(code: u8) -> &'static str {
    match code {
        msg::MODE_REST => "rest",
        msg::MODE_SLIDE => "slide",
        msg::MODE_ROCK => "rock",
        msg::MODE_SLIDE_ROCK => "slide-rock",
        msg::MODE_OVERTURNED => "overturned",
        msg::MODE_FLIGHT => "flight",
        _ => "unknown",
    }
}

/// One alert for people.
fn text_line(alert: &msg::PbrAlert) -> String {
    format!(
        "{} {:<17} {:<24} {} mode {:<10} θ/α {:+6.3} slide {:7.4} m P(overturn) {:.2} PGA {:.2} m/s² PGV {:.3} m/s",
        format_time_ns(alert.header.stamp.to_nanos()),
        level_name(alert.level),
        alert.pbr_id,
        alert.station,
        mode_name(alert.mode),
        alert.theta_over_alpha,
        alert.slide,
        alert.overturn_probability,
        alert.pga,
        alert.pgv
    )
}

/// One alert for programs, with units in the key names.
fn json_line(alert: &msg::PbrAlert) -> String {
    let data_time_ns = alert.header.stamp.to_nanos();
    serde_json::json!({
        "data_time_ns": data_time_ns,
        "data_time": format_time_ns(data_time_ns),
        "level": level_name(alert.level),
        "level_code": alert.level,
        "pbr_id": alert.pbr_id,
        "station": alert.station,
        "mode": mode_name(alert.mode),
        "mode_code": alert.mode,
        "theta_over_alpha": alert.theta_over_alpha,
        "slide_m": alert.slide,
        "overturn_probability": alert.overturn_probability,
        "pga_mps2": alert.pga,
        "pgv_mps": alert.pgv,
        "message": alert.message,
        "episode": alert.episode,
    })
    .to_string()
}

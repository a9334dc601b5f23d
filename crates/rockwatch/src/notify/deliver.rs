//! One delivery attempt of an alert to a receiver: run a command, or POST to a webhook.
//! Blocking; called on the receiver's own thread only.

use std::io::Write;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use super::config::{NotifyConfig, NotifyKind};

/// How often a running `exec` command is looked at while waiting for it.
const EXEC_POLL: Duration = Duration::from_millis(10);

/// A receiver, ready to deliver.
pub(crate) enum Target {
    /// Program and arguments.
    Exec(Vec<String>),
    Webhook {
        url: String,
        agent: ureq::Agent,
    },
}

impl Target {
    pub(crate) fn new(config: &NotifyConfig) -> Target {
        match config.kind {
            NotifyKind::Exec => Target::Exec(config.command.clone()),
            NotifyKind::Webhook => {
                let agent = ureq::Agent::config_builder()
                    .timeout_global(Some(Duration::from_secs_f64(config.timeout_s)))
                    // A non-2xx status is a failed attempt, not an error of the client.
                    .http_status_as_error(false)
                    .user_agent(concat!("rockwatch/", env!("CARGO_PKG_VERSION")))
                    .build()
                    .into();
                Target::Webhook {
                    url: config.url.clone().unwrap_or_default(),
                    agent,
                }
            }
        }
    }

    /// One attempt to deliver `body` (the alert JSON), within `timeout`. Ok: acknowledged
    /// (exit status 0, HTTP 2xx); Err: why not, in a few words.
    pub(crate) fn deliver(&self, body: &[u8], timeout: Duration) -> Result<(), String> {
        match self {
            Target::Exec(command) => exec(command, body, timeout),
            Target::Webhook { url, agent } => {
                let response = agent
                    .post(url)
                    .header("Content-Type", "application/json")
                    .send(body)
                    .map_err(|e| e.to_string())?;
                let status = response.status();
                if status.is_success() {
                    Ok(())
                } else {
                    Err(format!("HTTP status {status}"))
                }
            }
        }
    }
}

/// Runs `command` with `body` and a newline on its stdin (stdout discarded, stderr the
/// node's); a command still running after `timeout` is killed.
fn exec(command: &[String], body: &[u8], timeout: Duration) -> Result<(), String> {
    let (program, args) = command.split_first().ok_or("no command")?;
    let mut child = Command::new(program)
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .map_err(|e| format!("cannot run {program}: {e}"))?;
    if let Some(mut stdin) = child.stdin.take() {
        // An alert is far smaller than a pipe's buffer: this does not block. A command that
        // exits without reading its input is judged by its exit status only.
        let _ = stdin.write_all(body).and_then(|()| stdin.write_all(b"\n"));
    }
    let deadline = Instant::now() + timeout;
    loop {
        match child.try_wait() {
            Ok(Some(status)) if status.success() => return Ok(()),
            Ok(Some(status)) => return Err(format!("{program}: {status}")),
            Ok(None) if Instant::now() >= deadline => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(format!(
                    "{program}: still running after timeout_s = {} s: killed",
                    timeout.as_secs_f64()
                ));
            }
            Ok(None) => std::thread::sleep(EXEC_POLL),
            Err(e) => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(format!("{program}: cannot wait for it: {e}"));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sh(script: &str) -> Vec<String> {
        vec!["sh".into(), "-c".into(), script.into()]
    }

    #[test]
    fn exec_acknowledges_on_status_zero_and_gets_the_body_on_stdin() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        let cmd = sh(&format!("cat > '{}'", out.display()));
        exec(&cmd, b"{\"a\":1}", Duration::from_secs(10)).unwrap();
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "{\"a\":1}\n");
        let e = exec(&sh("exit 3"), b"{}", Duration::from_secs(10)).unwrap_err();
        assert!(e.contains("exit status: 3"), "{e}");
        let e = exec(&["/no/such/program".into()], b"{}", Duration::from_secs(1)).unwrap_err();
        assert!(e.contains("cannot run"), "{e}");
    }

    #[test]
    fn exec_children_start_with_no_signal_blocked() {
        // The node blocks its stop and reload signals on every thread (signals.rs): a command
        // must not inherit that mask (it could then never be stopped by SIGTERM, issue 24
        // item 8). The mask is blocked here on this test's thread, as the node's workers have it.
        use nix::sys::signal::{SigSet, Signal};
        let mut set = SigSet::empty();
        for s in [Signal::SIGINT, Signal::SIGTERM, Signal::SIGHUP] {
            set.add(s);
        }
        set.thread_block().unwrap();
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("status");
        let cmd = sh(&format!(
            "grep -E '^Sig(Blk|Ign)' /proc/self/status > '{}'",
            out.display()
        ));
        let result = exec(&cmd, b"{}", Duration::from_secs(10));
        set.thread_unblock().unwrap();
        result.unwrap();
        let status = std::fs::read_to_string(&out).unwrap();
        for line in status.lines() {
            let mask = u64::from_str_radix(line.split_whitespace().nth(1).unwrap(), 16).unwrap();
            // SIGHUP 1, SIGINT 2, SIGTERM 15: bits 0, 1, 14.
            assert_eq!(mask & 0b100_0000_0000_0011, 0, "{status}");
        }
    }

    #[test]
    fn exec_kills_a_command_that_outlives_its_timeout() {
        let start = Instant::now();
        let e = exec(&sh("exec sleep 30"), b"{}", Duration::from_millis(300)).unwrap_err();
        let took = start.elapsed();
        assert!(e.contains("killed"), "{e}");
        // Killed at the timeout: 0.3 s plus one poll and the kill (generous for a loaded CI
        // machine), far below the command's own 30 s.
        assert!(
            took >= Duration::from_millis(300) && took < Duration::from_secs(5),
            "{took:?}"
        );
    }
}

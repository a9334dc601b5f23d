//! Running the rockwatch binary under test: [`Rockwatch`] (its path, passed in by the test
//! crate that has it: [`rockwatch_bin!`](crate::rockwatch_bin)), one invocation with the
//! common options ([`Invocation`]: arguments, environment, stdin, a deadline, a memory cap) and
//! its output, and the long-running children (a node, a child whose stderr is read as it comes).

use std::ffi::OsStr;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Output, Stdio};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crate::fixtures::{records_dir, RINALDI_AT2, RINALDI_UP_AT2};

/// The rockwatch binary under test. Its path exists only in the rockwatch package's integration
/// tests (`env!("CARGO_BIN_EXE_rockwatch")`), so they pass it in: `rockwatch_bin!()`.
#[derive(Debug, Clone, Copy)]
pub struct Rockwatch {
    path: &'static str,
}

impl AsRef<OsStr> for Rockwatch {
    fn as_ref(&self) -> &OsStr {
        OsStr::new(self.path)
    }
}

impl AsRef<Path> for Rockwatch {
    fn as_ref(&self) -> &Path {
        Path::new(self.path)
    }
}

impl Rockwatch {
    /// The binary at `path` (`env!("CARGO_BIN_EXE_rockwatch")`).
    #[must_use]
    pub const fn new(path: &'static str) -> Rockwatch {
        Rockwatch { path }
    }

    /// The binary's path.
    #[must_use]
    pub fn path(&self) -> &Path {
        Path::new(self.path)
    }

    /// The binary's path for a shell script or a message.
    #[must_use]
    pub fn display(&self) -> std::path::Display<'_> {
        self.path().display()
    }

    /// `rockwatch ARGS…`, to be given more options and run.
    pub fn run(&self, args: &[&str]) -> Invocation {
        Invocation {
            program: self.path.into(),
            args: args.iter().map(|a| (*a).to_owned()).collect(),
            env: Vec::new(),
            stdin: None,
            deadline: None,
            memory_limit_kib: None,
        }
    }

    /// `rockwatch ARGS…` run to its end: its exit status and output.
    #[must_use]
    pub fn output(&self, args: &[&str]) -> Output {
        self.run(args).output()
    }

    /// Starts `rockwatch node --config CONFIG --state-dir STATE`, stderr to `stderr_path`.
    #[must_use]
    pub fn start_node(&self, config: &Path, state_dir: &Path, stderr_path: PathBuf) -> NodeProcess {
        let stderr = std::fs::File::create(&stderr_path).expect("create the node's stderr file");
        let child = Command::new(self.path)
            .arg("node")
            .arg("--config")
            .arg(config)
            .arg("--state-dir")
            .arg(state_dir)
            .stdout(Stdio::null())
            .stderr(stderr)
            .spawn()
            .expect("start rockwatch node");
        NodeProcess { child, stderr_path }
    }

    /// `rockwatch node --config CONFIG` in its own network namespace (loopback up: its ROS 2
    /// side opens DDS; iceoryx2 uses shared memory, which the namespace does not separate).
    #[must_use]
    pub fn spawn_node_in_netns(&self, config: &Path) -> LoggedChild {
        LoggedChild::spawn(
            Command::new("unshare")
                .args([
                    "-n",
                    "sh",
                    "-c",
                    "ip link set lo up && exec \"$0\" node --config \"$1\"",
                ])
                .arg(self.path)
                .arg(config),
        )
    }

    /// `rockwatch replay --transport iceoryx2` of the bundled Rinaldi record (228° + vertical)
    /// as station CI.RRS.00, at 20× with 5 s of quiet after it, to the node of `config`.
    #[must_use]
    pub fn replay_rinaldi_iox(&self, config: &Path) -> Output {
        let data = records_dir();
        Command::new(self.path)
            .args(["replay", "--config"])
            .arg(config)
            .arg("--record")
            .arg(data.join(RINALDI_AT2))
            .arg("--vertical")
            .arg(data.join(RINALDI_UP_AT2))
            .args([
                "--azimuth",
                "228",
                "--station",
                "CI.RRS.00",
                "--transport",
                "iceoryx2",
                "--speed",
                "20",
                "--tail",
                "5",
            ])
            .output()
            .expect("run rockwatch replay")
    }

    /// The alert records journaled in the state directory `state`, in journal order, as the
    /// shared alert JSON (`rockwatch alerts --format json`).
    #[must_use]
    pub fn journaled_alerts(&self, state: &Path) -> Vec<serde_json::Value> {
        let out = Command::new(self.path)
            .args(["alerts", "--format", "json", "--state-dir"])
            .arg(state)
            .output()
            .expect("run rockwatch alerts");
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let records: Vec<serde_json::Value> =
            serde_json::from_slice(&out.stdout).expect("rockwatch alerts prints JSON");
        records
            .into_iter()
            .filter(|r| r["type"] == "alert")
            .collect()
    }

    /// (pbr, episode, level) of every alert journaled in the state directory `state`, in
    /// journal order.
    #[must_use]
    pub fn alert_history(&self, state: &Path) -> Vec<(String, u64, String)> {
        self.journaled_alerts(state)
            .iter()
            .map(|a| {
                (
                    a["pbr_id"].as_str().expect("pbr_id").to_string(),
                    a["episode"].as_u64().expect("episode"),
                    a["level"].as_str().expect("level").to_string(),
                )
            })
            .collect()
    }
}

/// The rockwatch binary of the calling test crate (a rockwatch package's integration test):
/// `Rockwatch::new(env!("CARGO_BIN_EXE_rockwatch"))`.
#[macro_export]
macro_rules! rockwatch_bin {
    () => {
        $crate::process::Rockwatch::new(env!("CARGO_BIN_EXE_rockwatch"))
    };
}

/// One run of a program (built by [`Rockwatch::run`]): arguments, environment, stdin, and
/// optionally a deadline and a memory cap.
#[derive(Debug)]
#[must_use]
pub struct Invocation {
    program: String,
    args: Vec<String>,
    env: Vec<(String, String)>,
    stdin: Option<Vec<u8>>,
    deadline: Option<Duration>,
    memory_limit_kib: Option<u64>,
}

/// A finished run's exit and output as text.
#[derive(Debug)]
pub struct Ran {
    /// Whether it exited with status 0.
    pub success: bool,
    /// Its exit code (None if a signal ended it).
    pub code: Option<i32>,
    pub stdout: String,
    pub stderr: String,
}

impl Invocation {
    /// Sets the environment variable `key` to `value` for this run.
    pub fn env(mut self, key: &str, value: &str) -> Invocation {
        self.env.push((key.to_owned(), value.to_owned()));
        self
    }

    /// Sets each `(key, value)` of `vars` (see [`Invocation::env`]).
    pub fn envs(self, vars: &[(&str, &str)]) -> Invocation {
        vars.iter().fold(self, |run, (k, v)| run.env(k, v))
    }

    /// Writes `bytes` to the program's stdin, then closes it (without, stdin is empty).
    pub fn stdin(mut self, bytes: &[u8]) -> Invocation {
        self.stdin = Some(bytes.to_vec());
        self
    }

    /// Kills the program and fails the test if it runs longer than `deadline` (unbounded work).
    pub fn deadline(mut self, deadline: Duration) -> Invocation {
        self.deadline = Some(deadline);
        self
    }

    /// Caps the program's virtual memory at `kib` KiB (through the shell's `ulimit -v`), so a
    /// runaway allocation aborts instead of swapping the machine.
    pub fn memory_limit_kib(mut self, kib: u64) -> Invocation {
        self.memory_limit_kib = Some(kib);
        self
    }

    /// Runs the program to its end: its exit status and output (stdout and stderr are read as
    /// they come: a full pipe would block the child, which would then look like a hang).
    #[must_use]
    pub fn output(self) -> Output {
        let mut command = match self.memory_limit_kib {
            Some(kib) => {
                let mut sh = Command::new("sh");
                sh.arg("-c")
                    .arg(format!("ulimit -v {kib}; exec \"$0\" \"$@\""))
                    .arg(&self.program);
                sh
            }
            None => Command::new(&self.program),
        };
        command
            .args(&self.args)
            .envs(self.env.iter().map(|(k, v)| (k, v)))
            .stdin(if self.stdin.is_some() {
                Stdio::piped()
            } else {
                Stdio::null()
            })
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        let mut child = command
            .spawn()
            .unwrap_or_else(|e| panic!("{} {:?} does not start: {e}", self.program, self.args));
        let writer = child.stdin.take().zip(self.stdin).map(|(mut pipe, bytes)| {
            std::thread::spawn(move || {
                // The program may exit without reading it all: a broken pipe is its business.
                let _ = pipe.write_all(&bytes);
            })
        });
        let stdout = read_on_a_thread(child.stdout.take());
        let stderr = read_on_a_thread(child.stderr.take());
        let status = match self.deadline {
            None => child.wait().expect("wait for the program"),
            Some(deadline) => wait_until(&mut child, deadline).unwrap_or_else(|| {
                panic!(
                    "rockwatch {:?} still running after {deadline:?}: unbounded work",
                    self.args
                )
            }),
        };
        if let Some(writer) = writer {
            let _ = writer.join();
        }
        Output {
            status,
            stdout: stdout.join().expect("stdout reader"),
            stderr: stderr.join().expect("stderr reader"),
        }
    }

    /// [`Invocation::output`] as text (lossy UTF-8).
    #[must_use]
    pub fn text(self) -> Ran {
        let out = self.output();
        Ran {
            success: out.status.success(),
            code: out.status.code(),
            stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
            stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        }
    }

    /// The standard output of a run that must succeed: fails the test, with the arguments and
    /// the stderr, if the program exits non-zero or prints other than UTF-8.
    #[must_use]
    pub fn success_stdout(self) -> String {
        let args = self.args.clone();
        let out = self.output();
        assert!(
            out.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8(out.stdout).expect("stdout is UTF-8")
    }
}

/// Everything `pipe` yields, read on a thread.
fn read_on_a_thread(pipe: Option<impl Read + Send + 'static>) -> JoinHandle<Vec<u8>> {
    std::thread::spawn(move || {
        let mut bytes = Vec::new();
        if let Some(mut pipe) = pipe {
            let _ = pipe.read_to_end(&mut bytes);
        }
        bytes
    })
}

/// The child's exit status, or None (the child killed) if it runs past `deadline`.
fn wait_until(child: &mut Child, deadline: Duration) -> Option<ExitStatus> {
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().expect("wait for the program") {
            return Some(status);
        }
        if start.elapsed() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// A `rockwatch node` child process, killed (SIGKILL) if still running when dropped.
pub struct NodeProcess {
    pub child: Child,
    pub stderr_path: PathBuf,
}

impl NodeProcess {
    /// What the node has written on stderr so far.
    #[must_use]
    pub fn stderr(&self) -> String {
        std::fs::read_to_string(&self.stderr_path).unwrap_or_default()
    }

    /// Sends `signal` (e.g. "TERM", "KILL") and waits up to `timeout` for the exit.
    pub fn signal_and_wait(&mut self, signal: &str, timeout: Duration) -> Option<ExitStatus> {
        let pid = self.child.id().to_string();
        let _ = Command::new("kill")
            .arg(format!("-{signal}"))
            .arg(&pid)
            .status();
        let deadline = Instant::now() + timeout;
        loop {
            if let Ok(Some(status)) = self.child.try_wait() {
                return Some(status);
            }
            if Instant::now() >= deadline {
                return None;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for NodeProcess {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// A child process whose stderr a thread reads as it comes. A pipe nobody reads fills at
/// 64 KiB, and then every thread of the child that logs blocks in `write`: the whole process
/// stalls (a DDS participant's event loop included), which looks like a failure of the
/// process under test.
pub struct LoggedChild {
    pub child: Child,
    /// What the child has written on stderr so far.
    text: std::sync::Arc<std::sync::Mutex<String>>,
    reader: Option<std::thread::JoinHandle<()>>,
}

impl LoggedChild {
    /// Spawns `cmd` with its stderr piped to the reading thread.
    pub fn spawn(cmd: &mut Command) -> LoggedChild {
        let mut child = cmd.stderr(Stdio::piped()).spawn().unwrap();
        let pipe = child.stderr.take().expect("piped");
        let text = std::sync::Arc::new(std::sync::Mutex::new(String::new()));
        let theirs = std::sync::Arc::clone(&text);
        let reader = Some(std::thread::spawn(move || {
            use std::io::BufRead;
            for line in std::io::BufReader::new(pipe).lines().map_while(Result::ok) {
                let mut text = theirs
                    .lock()
                    .unwrap_or_else(std::sync::PoisonError::into_inner);
                text.push_str(&line);
                text.push('\n');
            }
        }));
        LoggedChild {
            child,
            text,
            reader,
        }
    }

    /// What the child has written on stderr so far.
    pub fn stderr_so_far(&self) -> String {
        self.text
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .clone()
    }

    /// SIGTERM, then up to `grace` for the process to end (SIGKILL after): its exit status
    /// and everything it wrote on stderr.
    pub fn stop(mut self, grace: Duration) -> (ExitStatus, String) {
        let _ = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status();
        let deadline = Instant::now() + grace;
        while self.child.try_wait().unwrap().is_none() && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(50));
        }
        let _ = self.child.kill();
        let status = self.child.wait().unwrap();
        if let Some(reader) = self.reader.take() {
            let _ = reader.join();
        }
        (status, self.stderr_so_far())
    }
}

/// SIGTERM to a node of [`Rockwatch::spawn_node_in_netns`]; its exit status and stderr.
pub fn stop_node(node: LoggedChild) -> (ExitStatus, String) {
    node.stop(Duration::from_secs(60))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arguments_environment_and_stdin_reach_the_program_and_its_output_comes_back() {
        let ran = Rockwatch::new("sh")
            .run(&["-c", "cat; echo \"$HARNESS_TEST_VAR $0\" >&2; exit 3"])
            .env("HARNESS_TEST_VAR", "set")
            .stdin(b"from stdin")
            .text();
        assert!(!ran.success);
        assert_eq!(ran.code, Some(3));
        assert_eq!(ran.stdout, "from stdin");
        assert_eq!(ran.stderr, "set sh\n");
    }

    #[test]
    #[should_panic(expected = "still running after")]
    fn a_run_past_its_deadline_is_killed_and_fails_the_test() {
        let _ = Rockwatch::new("sleep")
            .run(&["30"])
            .deadline(Duration::from_millis(200))
            .output();
    }

    #[test]
    fn the_memory_cap_applies_to_the_program() {
        // `ulimit -v` as the program sees it: the cap in KiB.
        let out = Rockwatch::new("sh")
            .run(&["-c", "ulimit -v"])
            .memory_limit_kib(500_000)
            .success_stdout();
        assert_eq!(out.trim(), "500000");
    }

    #[test]
    #[should_panic(expected = "[\"-c\", \"exit 1\"]")]
    fn success_stdout_fails_the_test_on_a_failed_run_naming_its_arguments() {
        let _ = Rockwatch::new("sh").run(&["-c", "exit 1"]).success_stdout();
    }
}

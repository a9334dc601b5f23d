//! Another user of the host against rockwatch's iceoryx2 services (issue 11, finding 6):
//! before, iceoryx2's world-writable management segment let any user break the creation of
//! every later iceoryx2 node (`UnableToGenerateUniqueNodeId`), and a user who created the
//! (shared, default) root directory first owned the services the node then used.
//!
//! The other user is an unused numeric uid (no account is created, so there is nothing to
//! clean up in /etc/passwd) entered with `setpriv --reuid --regid --clear-groups`; it runs a
//! copy of this test binary, which then acts as a plain iceoryx2 0.10.0 client of that user,
//! without rockwatch's checks (as a Python or C++ client would). Needs root and setpriv:
//! skipped without them locally, FAILS under CI=true (CI runs as root).
//!
//! Each test uses its own iceoryx2 prefix and root directory (derived from
//! config/iceoryx2.toml), and removes its segments at the end.

use rockwatch_test_harness::fixtures::repo;
use rockwatch_test_harness::peers::peer_available;
use rockwatch_test_harness::process::{stop_node, LoggedChild};
use rockwatch_test_harness::rockwatch_bin;

use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use iceoryx2::prelude::*;
use rockwatch::iox::{AccelHeader, AccelSample, IoxAlertSubscriber, IoxConfig};

/// Set in the copy of this binary run as the other user: what it does (see [`attacker`]).
const ROLE_ENV: &str = "ROCKWATCH_IOX_OTHER_USER";
/// Its iceoryx2 configuration file, service name and target path.
const CONFIG_ENV: &str = "ROCKWATCH_IOX_OTHER_CONFIG";
const SERVICE_ENV: &str = "ROCKWATCH_IOX_OTHER_SERVICE";
const TARGET_ENV: &str = "ROCKWATCH_IOX_OTHER_TARGET";

/// The other user's actions, one result each on stdout (`@@ DONE …` if it succeeded,
/// `@@ REFUSED …` if the system stopped it).
fn attacker(role: &str) {
    let var = |k: &str| std::env::var(k).unwrap_or_default();
    match role {
        "publish" => {
            let file = var(CONFIG_ENV);
            let config = match FilePath::new(file.as_bytes()).map(|p| Config::from_file(&p)) {
                Ok(Ok(c)) => c,
                other => return println!("@@ REFUSED config {other:?}"),
            };
            let node = match NodeBuilder::new().config(&config).create::<ipc::Service>() {
                Ok(n) => n,
                Err(e) => return println!("@@ REFUSED node {e:?}"),
            };
            println!("@@ DONE node");
            let name = ServiceName::new(&var(SERVICE_ENV)).unwrap();
            let service = match node
                .service_builder(&name)
                .publish_subscribe::<[AccelSample]>()
                .user_header::<AccelHeader>()
                .open()
            {
                Ok(s) => s,
                Err(e) => return println!("@@ REFUSED service {e:?}"),
            };
            let publisher = match service.publisher_builder().create() {
                Ok(p) => p,
                Err(e) => return println!("@@ REFUSED publisher {e:?}"),
            };
            let sent = publisher.loan_slice_uninit(1).map(|mut s| {
                *s.user_header_mut() = AccelHeader::default();
                s.write_from_slice(&[AccelSample::default()]).send()
            });
            println!("@@ DONE publish {sent:?}");
        }
        "overwrite" => {
            // Every file of the deployment's prefix: open for writing, overwrite with garbage.
            let target = var(TARGET_ENV);
            for entry in std::fs::read_dir("/dev/shm").unwrap().flatten() {
                let name = entry.file_name().to_string_lossy().into_owned();
                if !name.starts_with(&target) {
                    continue;
                }
                match std::fs::OpenOptions::new().write(true).open(entry.path()) {
                    Ok(f) => {
                        use std::io::Write;
                        let _ = (&f).write_all(&[0xff; 16]);
                        println!("@@ DONE overwrite {name}");
                    }
                    Err(e) => println!("@@ REFUSED overwrite {name} {e}"),
                }
            }
        }
        "create-in" => {
            let target = PathBuf::from(var(TARGET_ENV)).join("services/forged.service");
            match std::fs::write(&target, "forged") {
                Ok(()) => println!("@@ DONE create-in"),
                Err(e) => println!("@@ REFUSED create-in {e}"),
            }
        }
        "mkdir" => match std::fs::create_dir(var(TARGET_ENV)) {
            Ok(()) => println!("@@ DONE mkdir"),
            Err(e) => println!("@@ REFUSED mkdir {e}"),
        },
        "squat" => {
            // A world-writable file named like the segment, with garbage in it.
            let path = var(TARGET_ENV);
            let done = std::fs::write(&path, [0xffu8; 16]).and_then(|()| {
                std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o666))
            });
            println!(
                "@@ {} squat {done:?}",
                if done.is_ok() { "DONE" } else { "REFUSED" }
            );
        }
        other => panic!("unknown role {other}"),
    }
}

/// Runs this test's copy of the binary as the other user; its stdout.
struct OtherUser {
    uid: u32,
    exe: PathBuf,
}

impl OtherUser {
    /// An unused uid and an executable copy of this binary in `dir` (readable by everyone:
    /// the checkout may be under a home directory the other user cannot enter). `None` (and
    /// a panic under CI=true) without root or setpriv.
    fn new(dir: &Path) -> Option<OtherUser> {
        let root = std::fs::read_to_string("/proc/self/status")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find_map(|l| l.strip_prefix("Uid:"))
                    .map(|ids| ids.split_whitespace().nth(1) == Some("0"))
            })
            .unwrap_or(false);
        let setpriv = Command::new("setpriv")
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success());
        if !peer_available(
            root && setpriv,
            "root and setpriv (to act as a second user)",
            "run the tests as root; setpriv is in util-linux, installed by .ci/run",
        ) {
            return None;
        }
        let passwd = std::fs::read_to_string("/etc/passwd").unwrap_or_default();
        let used: Vec<u32> = passwd
            .lines()
            .filter_map(|l| l.split(':').nth(2)?.parse().ok())
            .collect();
        let uid = (0..1000)
            .map(|i| 61_000 + (std::process::id() + i) % 1000)
            .find(|u| !used.contains(u))
            .expect("a free uid in 61000..62000");
        let exe = dir.join("other-user");
        std::fs::copy(std::env::current_exe().unwrap(), &exe).unwrap();
        std::fs::set_permissions(&exe, std::fs::Permissions::from_mode(0o755)).unwrap();
        Some(OtherUser { uid, exe })
    }

    fn run(&self, test: &str, role: &str, envs: &[(&str, String)]) -> String {
        let uid = self.uid.to_string();
        let out: Output = Command::new("setpriv")
            .args([
                &format!("--reuid={uid}"),
                &format!("--regid={uid}"),
                "--clear-groups",
                "--",
            ])
            .arg(&self.exe)
            .args(["--exact", test, "--nocapture", "--test-threads=1"])
            .env(ROLE_ENV, role)
            .envs(envs.iter().map(|(k, v)| (k, v)))
            .current_dir("/")
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
        assert!(
            out.status.success(),
            "other user ({role}) failed: {stdout}\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        // `@@ ` starts each result (libtest may print its own text before it on a line).
        stdout
            .split("@@ ")
            .skip(1)
            .map(|r| r.lines().next().unwrap_or(""))
            .collect::<Vec<_>>()
            .join("\n")
    }
}

/// A deployment of its own: iceoryx2 prefix, root directory, iceoryx2 and node configuration
/// files in a directory everyone can read. Drop removes its segments.
struct Deployment {
    dir: tempfile::TempDir,
    prefix: String,
    root: PathBuf,
    iox_file: PathBuf,
    node_file: PathBuf,
    accel: String,
}

impl Deployment {
    fn new(tag: &str) -> Deployment {
        let dir = tempfile::tempdir().unwrap();
        std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o755)).unwrap();
        let id = std::process::id();
        let prefix = format!("rwu{id}{tag}_");
        // Below a directory like /tmp (everyone may create in it, sticky), where another user
        // can create the root directory first.
        let shared = dir.path().join("tmp");
        std::fs::create_dir(&shared).unwrap();
        std::fs::set_permissions(&shared, std::fs::Permissions::from_mode(0o1777)).unwrap();
        let root = shared.join("iox-root");
        // config/iceoryx2.toml with this deployment's prefix and root-path.
        let shipped = std::fs::read_to_string(repo().join("config/iceoryx2.toml")).unwrap();
        let mut replaced = 0;
        let text: String = shipped
            .lines()
            .map(|l| {
                if l.starts_with("prefix = ") {
                    replaced += 1;
                    format!("prefix = \"{prefix}\"\n")
                } else if l.starts_with("root-path = ") {
                    replaced += 1;
                    format!("root-path = \"{}/\"\n", root.display())
                } else {
                    format!("{l}\n")
                }
            })
            .collect();
        assert_eq!(
            replaced, 2,
            "config/iceoryx2.toml sets prefix and root-path"
        );
        let iox_file = dir.path().join("iceoryx2.toml");
        std::fs::write(&iox_file, text).unwrap();
        let accel = format!("rockwatch-users/{id}/{tag}/accel");
        let node_file = dir.path().join("node.toml");
        std::fs::write(
            &node_file,
            format!(
                "catalogue = \"{}\"\n[ros2]\ndiscovery_range = \"LOCALHOST\"\n[iceoryx2]\nconfig_file = \"{}\"\naccel_service = \"{accel}\"\nalerts_service = \"rockwatch-users/{id}/{tag}/alerts\"\n",
                repo().join("config/catalogue.toml").display(),
                iox_file.display()
            ),
        )
        .unwrap();
        Deployment {
            dir,
            prefix,
            root,
            iox_file,
            node_file,
            accel,
        }
    }

    fn iox_config(&self) -> IoxConfig {
        IoxConfig {
            config_file: Some(self.iox_file.clone()),
            accel_service: self.accel.clone(),
            alerts_service: self.accel.replace("/accel", "/alerts"),
            ..IoxConfig::default()
        }
    }

    /// This deployment's files in /dev/shm.
    fn segments(&self) -> Vec<PathBuf> {
        std::fs::read_dir("/dev/shm")
            .unwrap()
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().starts_with(&self.prefix))
            .map(|e| e.path())
            .collect()
    }

    fn management_segment(&self) -> PathBuf {
        self.segments()
            .into_iter()
            .find(|p| p.to_string_lossy().ends_with("_node.0_10_0.global_mgmt"))
            .unwrap_or_else(|| panic!("no management segment among {:?}", self.segments()))
    }

    /// The node, once it runs (its start line is written: its signals are taken, so a
    /// SIGTERM stops it cleanly) and its services exist (its alerts service can be opened;
    /// alone this may hold before the node runs, the previous node's service still seen).
    fn start_node(&self) -> Node {
        let mut node = rockwatch_bin!().spawn_node_in_netns(&self.node_file);
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            let started = node.stderr_so_far().contains("on DDS domain");
            match IoxAlertSubscriber::new(&self.iox_config()) {
                Ok(_) if started => return Node(Some(node)),
                Ok(_) | Err(_) if Instant::now() < deadline => {
                    if let Ok(Some(status)) = node.child.try_wait() {
                        let (_, stderr) = stop_node(node);
                        panic!("node exited {status:?}: {stderr}");
                    }
                    std::thread::sleep(Duration::from_millis(100));
                }
                Ok(_) => {
                    let _ = node.child.kill();
                    panic!(
                        "the node never wrote its start line: {}",
                        node.stderr_so_far()
                    );
                }
                Err(e) => {
                    let _ = node.child.kill();
                    panic!("the node's services never appeared: {e:#}");
                }
            }
        }
    }

    /// `rockwatch node` that must refuse to start: its exit status and stderr.
    fn refused_node(&self) -> (std::process::ExitStatus, String) {
        let mut node = rockwatch_bin!().spawn_node_in_netns(&self.node_file);
        let deadline = Instant::now() + Duration::from_secs(20);
        while node.child.try_wait().unwrap().is_none() {
            if Instant::now() > deadline {
                let (_, stderr) = stop_node(node);
                panic!("the node did not refuse to start: {stderr}");
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        stop_node(node)
    }
}

impl Drop for Deployment {
    fn drop(&mut self) {
        for segment in self.segments() {
            let _ = std::fs::remove_file(segment);
        }
    }
}

/// A running node, killed if the test fails before stopping it.
struct Node(Option<LoggedChild>);

impl Node {
    /// SIGTERM; its exit status and stderr.
    fn stop(mut self) -> (std::process::ExitStatus, String) {
        stop_node(self.0.take().expect("running"))
    }
}

impl Drop for Node {
    fn drop(&mut self) {
        if let Some(mut node) = self.0.take() {
            let _ = node.child.kill();
            let _ = node.child.wait();
        }
    }
}

fn mode(path: &Path) -> u32 {
    std::fs::symlink_metadata(path).unwrap().mode() & 0o7777
}

/// The one error line of a refused start, and that it is the only line.
fn one_error_line(status: std::process::ExitStatus, stderr: &str) -> &str {
    assert_eq!(status.code(), Some(1), "{stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    let errors: Vec<&&str> = lines
        .iter()
        .filter(|l| l.starts_with("rockwatch: error:"))
        .collect();
    assert_eq!(errors.len(), 1, "one error line expected:\n{stderr}");
    errors[0]
}

/// The finding as it was, on iceoryx2 alone: the management segment it creates is writable by
/// everyone, and garbage written into it by another user makes every later node creation fail.
#[test]
fn without_the_checks_another_user_breaks_iceoryx2_node_creation() {
    const TEST: &str = "without_the_checks_another_user_breaks_iceoryx2_node_creation";
    if let Ok(role) = std::env::var(ROLE_ENV) {
        return attacker(&role);
    }
    let d = Deployment::new("raw");
    let Some(other) = OtherUser::new(d.dir.path()) else {
        return;
    };
    let file = FilePath::new(d.iox_file.to_str().unwrap().as_bytes()).unwrap();
    let config = Config::from_file(&file).unwrap();
    let create = || NodeBuilder::new().config(&config).create::<ipc::Service>();
    drop(create().unwrap());
    let mgmt = d.management_segment();
    assert_eq!(
        mode(&mgmt),
        0o666,
        "iceoryx2 0.10.0 creates it for everyone"
    );
    let out = other.run(TEST, "overwrite", &[(TARGET_ENV, d.prefix.clone())]);
    assert!(out.contains("DONE overwrite"), "{out}");
    let Err(e) = create() else {
        panic!("node creation succeeded after the overwrite");
    };
    assert!(
        format!("{e:?}").contains("UnableToGenerateUniqueNodeId"),
        "{e:?}"
    );
}

/// With rockwatch's checks: the other user can neither create an iceoryx2 node of the
/// deployment (so not publish on `pbr/accel`), nor write the management segment or any other
/// segment, nor add files to the root directory; the node then restarts normally.
#[test]
fn another_user_can_neither_publish_nor_break_a_restarted_node() {
    const TEST: &str = "another_user_can_neither_publish_nor_break_a_restarted_node";
    if let Ok(role) = std::env::var(ROLE_ENV) {
        return attacker(&role);
    }
    let d = Deployment::new("node");
    let Some(other) = OtherUser::new(d.dir.path()) else {
        return;
    };
    let node = d.start_node();
    assert_eq!(mode(&d.root), 0o700, "root directory created private");
    let mgmt = d.management_segment();
    assert_eq!(mode(&mgmt), 0o600, "management segment restricted");
    for segment in d.segments() {
        assert_eq!(
            mode(&segment) & 0o077,
            0,
            "{} owner-only",
            segment.display()
        );
    }
    let published = other.run(
        TEST,
        "publish",
        &[
            (CONFIG_ENV, d.iox_file.display().to_string()),
            (SERVICE_ENV, d.accel.clone()),
        ],
    );
    assert!(
        published.starts_with("REFUSED node") && !published.contains("DONE"),
        "the other user got through: {published}"
    );
    let overwritten = other.run(TEST, "overwrite", &[(TARGET_ENV, d.prefix.clone())]);
    assert!(
        !overwritten.contains("DONE") && overwritten.contains("global_mgmt"),
        "{overwritten}"
    );
    let created = other.run(
        TEST,
        "create-in",
        &[(TARGET_ENV, d.root.display().to_string())],
    );
    assert!(created.starts_with("REFUSED"), "{created}");
    let (status, stderr) = node.stop();
    assert!(status.success(), "node exit {status:?}\n{stderr}");
    // Restarted: it starts and stops normally.
    let node = d.start_node();
    let (status, stderr) = node.stop();
    assert!(status.success(), "restarted node exit {status:?}\n{stderr}");
}

/// The node refuses, with one line naming the path and the fix, a root directory of another
/// user, one writable by others, and a management segment squatted by another user (before,
/// the first let that user own the node's services, the last failed with
/// `UnableToGenerateUniqueNodeId`).
#[test]
fn unsafe_root_directories_and_squatted_segments_are_refused_with_one_line() {
    const TEST: &str = "unsafe_root_directories_and_squatted_segments_are_refused_with_one_line";
    if let Ok(role) = std::env::var(ROLE_ENV) {
        return attacker(&role);
    }
    let d = Deployment::new("refuse");
    let Some(other) = OtherUser::new(d.dir.path()) else {
        return;
    };
    let root = d.root.display().to_string();

    // Created by the other user first.
    let made = other.run(TEST, "mkdir", &[(TARGET_ENV, root.clone())]);
    assert_eq!(made, "DONE mkdir");
    let (status, stderr) = d.refused_node();
    let line = one_error_line(status, &stderr);
    assert!(
        line.contains(&root)
            && line.contains(&format!("belongs to uid {}", other.uid))
            && line.contains("[global] root-path"),
        "{line}"
    );
    std::fs::remove_dir(&d.root).unwrap();

    // This user's, but writable by everyone.
    std::fs::create_dir(&d.root).unwrap();
    std::fs::set_permissions(&d.root, std::fs::Permissions::from_mode(0o777)).unwrap();
    let (status, stderr) = d.refused_node();
    let line = one_error_line(status, &stderr);
    assert!(
        line.contains(&root) && line.contains("0777") && line.contains("writable by other users"),
        "{line}"
    );
    std::fs::set_permissions(&d.root, std::fs::Permissions::from_mode(0o700)).unwrap();

    // The management segment's name (the same on every host for iceoryx2 0.10.0 and a
    // prefix), squatted by the other user with garbage in it.
    drop(IoxAlertSubscriber::new(&d.iox_config()).unwrap());
    let mgmt = d.management_segment();
    for segment in d.segments() {
        std::fs::remove_file(segment).unwrap();
    }
    let squatted = other.run(TEST, "squat", &[(TARGET_ENV, mgmt.display().to_string())]);
    assert!(squatted.starts_with("DONE"), "{squatted}");
    let (status, stderr) = d.refused_node();
    let line = one_error_line(status, &stderr);
    assert!(
        line.contains(&mgmt.display().to_string())
            && line.contains(&format!("belongs to uid {}", other.uid))
            && line.contains("[global] prefix"),
        "{line}"
    );
}

/// Issue 24 item 7: another user filling the world-writable /dev/shm killed an iceoryx2
/// publisher with SIGBUS (status 135, no message). A full /dev/shm (here a 64 KiB tmpfs in a
/// private mount namespace: root, as in CI) now ends it with one line saying what happened.
#[test]
fn a_full_dev_shm_ends_a_publisher_with_one_line_not_a_silent_bus_error() {
    if std::env::var_os("CI").is_none() && !nix_is_root() {
        eprintln!("skipped: needs root (unshare -m, mount)");
        return;
    }
    let script = format!(
        "mount -t tmpfs -o size=64k tmpfs /dev/shm && exec '{}' replay --config '{}' \
         --synthetic --mw 6.5 --r-km 5 --station CI.RRS.00 --transport iceoryx2 --wait-s 1 \
         --speed max",
        env!("CARGO_BIN_EXE_rockwatch"),
        repo().join("config/node.toml").display()
    );
    let out = Command::new("timeout")
        .args([
            "-k",
            "5",
            "60",
            "unshare",
            "-m",
            "--propagation",
            "private",
            "sh",
            "-c",
        ])
        .arg(&script)
        .output()
        .expect("runs timeout, unshare and sh");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("bus error (SIGBUS)") && stderr.contains("/dev/shm"),
        "{stderr}"
    );
}

fn nix_is_root() -> bool {
    std::fs::metadata("/proc/self")
        .map(|m| m.uid() == 0)
        .unwrap_or(false)
}

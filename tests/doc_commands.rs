//! Every example command of README.md and docs/*.md runs (issue 20 item 30; the project rule
//! "every example command in the docs runnable").
//!
//! The commands are the lines of the docs' fenced code blocks (any language) that start with
//! `rockwatch `, `cargo run --release -- ` (the binary under test) or `bash .ci/run`, with `\`
//! continuations joined and a trailing `# comment` and `&` dropped. Each is one of:
//!
//! * a **synopsis** (the usage of a subcommand, not something to run), recognised by rule: an
//!   unquoted word holds `[`, `]`, `|`, `…` or `...` or starts with `(`, or a flag's value is
//!   that flag's placeholder in `rockwatch SUB --help` (`--out DIR`, `--pbr ID`). Not run, but
//!   its subcommand and every flag it names must exist in the product's `--help`;
//! * an **exception** ([`EXCEPTIONS`]): a command that cannot run to completion offline in a
//!   test (a service, a client of a running node, a download, a long study), with its reason
//!   and a weaker check that still fails when the command is wrong;
//! * otherwise an **example**, run with the built binary from a temporary directory in which
//!   `tests/`, `config/` and `examples/` resolve (outputs such as `--plot rinaldi.svg` land
//!   there), in a network namespace without interfaces, in document order (a later command may
//!   read an earlier one's output, as a reader would run them). It must exit 0; the `# ` lines
//!   that follow it in its block are the output the docs show, and each (split at `…`,
//!   whitespace collapsed) must appear in its stdout or stderr; the files its `--plot`,
//!   `--trace`, `--out`, `--polar-plot` and `--section-plot` name must exist. `echo`/`printf`
//!   lines before it in its block (the files it reads) are run first.
//!
//! There is no fourth kind: a command a doc gains is run unless it is a synopsis or in the
//! table, so it cannot go unchecked (a service missing from the table fails by the 60 s bound).
//! An exception that no longer matches a command of the docs fails the test (the table stays
//! true). Run time: ≈ 15 s (2 cores, other builds running), most of it the two `fragility`
//! examples and the nodes started and stopped.

use rockwatch_test_harness::fixtures::repo;
use rockwatch_test_harness::netns::{run_in_netns, text};
use rockwatch_test_harness::rockwatch_bin;

use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// One command of a fenced code block.
#[derive(Debug, Clone)]
struct DocCommand {
    /// `README.md:107`.
    place: String,
    /// The command as written (continuations joined, comment and `&` dropped, whitespace
    /// collapsed): the key of [`EXCEPTIONS`].
    text: String,
    /// Shell words (quotes removed).
    argv: Vec<String>,
    /// Whether each word was quoted (a quoted word is never a placeholder).
    quoted: Vec<bool>,
    /// The output shown after it (`# ` lines), without the `# `.
    shown: Vec<String>,
    /// `echo`/`printf` lines before it in its block.
    setup: Vec<String>,
}

/// The docs a new user reads.
fn doc_files() -> Vec<PathBuf> {
    let mut files = vec![repo().join("README.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(repo().join("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    docs.sort();
    files.extend(docs);
    files
}

const PREFIXES: [&str; 3] = ["rockwatch ", "cargo run --release -- ", "bash .ci/run"];

/// Splits a shell line into words (single and double quotes, backslash escapes), ending at an
/// unquoted word that starts with `#`. Returns the words, whether each was quoted, and the
/// byte index where a comment starts.
fn shell_words(line: &str) -> (Vec<String>, Vec<bool>, usize) {
    let (mut words, mut quoted) = (Vec::new(), Vec::new());
    let (mut word, mut in_word, mut was_quoted) = (String::new(), false, false);
    let mut chars = line.char_indices().peekable();
    while let Some((i, c)) = chars.next() {
        match c {
            c if c.is_whitespace() => {
                if in_word {
                    words.push(std::mem::take(&mut word));
                    quoted.push(was_quoted);
                    (in_word, was_quoted) = (false, false);
                }
            }
            '#' if !in_word => return (words, quoted, i),
            '\'' | '"' => {
                (in_word, was_quoted) = (true, true);
                for (_, q) in chars.by_ref() {
                    if q == c {
                        break;
                    }
                    word.push(q);
                }
            }
            '\\' => {
                in_word = true;
                if let Some((_, e)) = chars.next() {
                    word.push(e);
                }
            }
            c => {
                in_word = true;
                word.push(c);
            }
        }
    }
    if in_word {
        words.push(word);
        quoted.push(was_quoted);
    }
    (words, quoted, line.len())
}

/// Every command of the fenced code blocks of `files`.
fn extract(files: &[PathBuf]) -> Vec<DocCommand> {
    let mut commands = Vec::new();
    for file in files {
        let name = file
            .strip_prefix(repo())
            .unwrap_or(file)
            .display()
            .to_string();
        let source = std::fs::read_to_string(file).unwrap();
        let lines: Vec<&str> = source.lines().collect();
        let mut i = 0;
        while i < lines.len() {
            if !lines[i].trim_start().starts_with("```") {
                i += 1;
                continue;
            }
            // A fenced block: its logical lines (continuations joined) with their line numbers.
            let mut block: Vec<(usize, String)> = Vec::new();
            i += 1;
            while i < lines.len() && !lines[i].trim_start().starts_with("```") {
                let start = i;
                let mut logical = lines[i].trim().to_string();
                while logical.ends_with('\\') && i + 1 < lines.len() {
                    logical.pop();
                    i += 1;
                    logical = format!("{} {}", logical.trim_end(), lines[i].trim());
                }
                block.push((start + 1, logical));
                i += 1;
            }
            i += 1;
            for (k, (line_no, logical)) in block.iter().enumerate() {
                let logical = logical.strip_prefix("$ ").unwrap_or(logical);
                if !PREFIXES.iter().any(|p| logical.starts_with(p)) {
                    continue;
                }
                let (_, _, comment) = shell_words(logical);
                let mut text = logical[..comment].trim().to_string();
                if let Some(t) = text.strip_suffix('&') {
                    text = t.trim_end().to_string();
                }
                let text = text.split_whitespace().collect::<Vec<_>>().join(" ");
                let (argv, quoted, _) = shell_words(&text);
                let shown = block[k + 1..]
                    .iter()
                    .map_while(|(_, l)| l.strip_prefix('#'))
                    .map(|l| l.strip_prefix(' ').unwrap_or(l).to_string())
                    .collect();
                let setup = block[..k]
                    .iter()
                    .map(|(_, l)| l.clone())
                    .filter(|l| l.starts_with("echo ") || l.starts_with("printf "))
                    .collect();
                commands.push(DocCommand {
                    place: format!("{name}:{line_no}"),
                    text,
                    argv,
                    quoted,
                    shown,
                    setup,
                });
            }
        }
    }
    commands
}

/// The arguments after the program: `rockwatch X …` → `X …`; `cargo run --release -- X …` →
/// `X …`. None for `bash .ci/run`.
fn rockwatch_args(c: &DocCommand) -> Option<(&[String], &[bool])> {
    let skip = match c.argv.first().map(String::as_str) {
        Some("rockwatch") => 1,
        Some("cargo") => 4,
        _ => return None,
    };
    Some((&c.argv[skip..], &c.quoted[skip..]))
}

/// The flags of `rockwatch SUB --help`, each with its placeholder (`--out` → `DIR`; `""` for a
/// switch). None if SUB is not a subcommand.
fn help_flags(
    sub: &str,
    cache: &mut HashMap<String, Option<HashMap<String, String>>>,
) -> Option<HashMap<String, String>> {
    cache
        .entry(sub.to_string())
        .or_insert_with(|| {
            let out = Command::new(rockwatch_bin!())
                .args([sub, "--help"])
                .output()
                .unwrap();
            if !out.status.success() {
                return None;
            }
            let help = String::from_utf8_lossy(&out.stdout).into_owned();
            let mut flags = HashMap::new();
            for line in help.lines() {
                // Clap's long help: options at an indent of 2 (`-h, --help`) or 6, their
                // descriptions (which may start with a flag) at 10.
                let indent = line.len() - line.trim_start().len();
                if indent != 2 && indent != 6 {
                    continue;
                }
                let Some(at) = line.find("--") else { continue };
                let rest = &line[at + 2..];
                let name: String = rest
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || *c == '-')
                    .collect();
                let after = rest[name.len()..].trim_start();
                let value = after
                    .strip_prefix('<')
                    .and_then(|v| v.split_once('>'))
                    .map_or(String::new(), |(v, _)| v.to_string());
                flags.insert(format!("--{name}"), value);
            }
            // The ROS 2 commands' `--ros-args` (split off before clap) are in their help text.
            if help.contains("--ros-args … [--]") {
                flags.insert("--ros-args".to_string(), String::new());
            }
            Some(flags)
        })
        .clone()
}

/// Whether a command is a synopsis (see the module's documentation).
fn is_synopsis(args: &[String], quoted: &[bool], flags: &HashMap<String, String>) -> bool {
    let marker = args.iter().zip(quoted).any(|(w, q)| {
        !q && (["[", "]", "|", "…", "..."].iter().any(|m| w.contains(m)) || w.starts_with('('))
    });
    let placeholder = args.windows(2).zip(&quoted[1..]).any(|(pair, q)| {
        !q && flags
            .get(&pair[0])
            .is_some_and(|value| !value.is_empty() && *value == pair[1])
    });
    marker || placeholder
}

/// The flags a command names that its subcommand does not have (`--ros-args` and what follows
/// it are rcl's arguments, not clap's).
fn unknown_flags(args: &[String], flags: &HashMap<String, String>) -> Vec<String> {
    args.iter()
        .take_while(|w| w.trim_start_matches(['(', '[']) != "--ros-args")
        .filter_map(|w| {
            let w = w.trim_start_matches(['(', '[']);
            let w = w.trim_end_matches([']', ')']);
            let w = w.split('=').next().unwrap();
            (w.starts_with("--") && w.len() > 2).then(|| w.to_string())
        })
        .filter(|w| !flags.contains_key(w))
        .collect()
}

/// How an exception is checked instead of running the command to completion.
enum Check {
    /// Run by another test: `test` (tests/…) must hold `needle` (the call that runs it).
    RunBy {
        test: &'static str,
        needle: &'static str,
    },
    /// The CI entry point: the script must hold each of `needles` (what the README says it does).
    CiScript { needles: &'static [&'static str] },
    /// A long-running service: started in its own network namespace; it must print `ready` on
    /// stderr and still run, then stop on SIGTERM with exit 0.
    Service { ready: &'static str },
    /// A client of a running node: `node` (a command of the docs) is started first in the same
    /// network namespace; the command must exit 0 with `expect` in its output.
    Client {
        node: &'static str,
        expect: &'static str,
    },
    /// The command as written, plus `extra` arguments bounding its work: exit 0, `expect` in the
    /// output.
    Reduced {
        extra: &'static [&'static str],
        expect: &'static str,
    },
    /// The command as written, with the [`Exception::stand_ins`] for files the reader makes:
    /// exit 0, `expect` in the output.
    Run { expect: &'static str },
}

/// What a stand-in file holds.
enum StandIn {
    /// A copy of a file of the repository.
    Copy(&'static str),
    /// The node configuration the test uses for `config/node.toml` (absolute paths).
    NodeConfig,
    /// This text.
    Text(&'static str),
}

struct Exception {
    /// The command as the docs write it ([`DocCommand::text`]).
    command: &'static str,
    reason: &'static str,
    /// Files the reader makes (downloads, their own configuration), created in the test's
    /// directory before the check.
    stand_ins: &'static [(&'static str, StandIn)],
    check: Check,
}

const STN_CATALOGUE: &str = "[[pbr]]\nid = \"stn-needle\"\nname = \"test needle\"\nlat = 50.47\n\
    lon = 4.279\nstation = \"XX.STN.\"\nazimuth_deg = 90.0\nwidth_m = 0.05\nheight_m = 10.0\n\
    mu_s = 0.7\nmu_k = 0.55\nsource = \"test\"\n";

/// The example commands that cannot run to completion offline in a test.
const EXCEPTIONS: &[Exception] = &[
    Exception {
        command: "rockwatch status --node http://127.0.0.1:8080",
        reason: "a client of a running node with [web] (and, to be useful, data): run against \
                 a token-protected node fed the Rinaldi record by tests/web_dashboard.rs",
        stand_ins: &[],
        check: Check::RunBy {
            test: "tests/web_dashboard.rs",
            needle: "' status --node {WEB} --token-file",
        },
    },
    Exception {
        command: "rockwatch status --node http://127.0.0.1:8080 --token-file web.token --format json",
        reason: "a client of a running, token-protected node: run by tests/web_dashboard.rs",
        stand_ins: &[],
        check: Check::RunBy {
            test: "tests/web_dashboard.rs",
            needle: "--token-file '{d}/web.token' --format json",
        },
    },
    Exception {
        command: "rockwatch status --state-dir state/node",
        reason: "a node's state directory (the reader's): a rehearsal's is read by \
                 tests/monitor_cli.rs",
        stand_ins: &[],
        check: Check::RunBy {
            test: "tests/monitor_cli.rs",
            needle: "\"status\", \"--state-dir\"",
        },
    },
    Exception {
        command: "rockwatch status --state-dir rehearsal",
        reason: "exits 1 by design (the pillar lies): tests/monitor_cli.rs checks that exit \
                 code and the fallen pillar on the same rehearsal",
        stand_ins: &[],
        check: Check::RunBy {
            test: "tests/monitor_cli.rs",
            needle: "assert_eq!(code, Some(1)",
        },
    },
    Exception {
        command: "cargo run --release -- demo",
        reason: "the live node and a replay over DDS: run (at --speed 20, in a network \
                 namespace) by tests/ros2_demo.rs, which checks its alerts and table",
        stand_ins: &[],
        check: Check::RunBy {
            test: "tests/ros2_demo.rs",
            needle: "' demo --speed 20",
        },
    },
    Exception {
        command: "bash .ci/run",
        reason: "the CI entry point: it installs the test peers and runs every test, this one \
                 included",
        stand_ins: &[],
        check: Check::CiScript {
            // What the README says it does: the peers (ObsPy, Cyclone DDS, rclpy with Fast
            // DDS, the iceoryx2 bindings), pbr_msgs, systemd-analyze, then fmt, clippy, the
            // benchmarks' build and the tests.
            needles: &[
                "\"obspy==",
                "\"cyclonedds==",
                "\"ros-rclpy[fastrtps]==",
                "\"iceoryx2==",
                "launch-scripts/build-msgs.sh",
                "systemd-analyze",
                "cargo fmt --all -- --check",
                "cargo clippy --workspace --all-targets --locked -- -D warnings",
                "cargo test --workspace --benches --no-run",
                "cargo test --workspace --locked",
            ],
        },
    },
    Exception {
        command: "rockwatch stations --stationxml config/inventory/ci.xml --at 2024-01-01T00:00:00Z",
        reason: "its StationXML is downloaded from IRIS with curl (the line before): a bundled \
                 CI inventory stands in",
        stand_ins: &[(
            "config/inventory/ci.xml",
            StandIn::Copy("tests/data/stationxml/gmprocess_CI.GR2_level-response.xml"),
        )],
        check: Check::Run { expect: " yes" },
    },
    Exception {
        command: "rockwatch node --config config/node.toml --state-dir state/node",
        reason: "the live node runs until stopped",
        stand_ins: &[],
        check: Check::Service {
            ready: "rockwatch: node /rockwatch on DDS domain",
        },
    },
    Exception {
        command: "rockwatch node --config config/node.toml",
        reason: "the live node runs until stopped",
        stand_ins: &[],
        check: Check::Service {
            ready: "rockwatch: node /rockwatch on DDS domain",
        },
    },
    Exception {
        command: "rockwatch acquire --config config/acquire.toml --state-dir state/acquire",
        reason: "needs a SeedLink server and the downloaded StationXML, and runs until stopped \
                 (tests/acquire_e2e.rs runs acquire against a SeedLink server); bundled \
                 inventories stand in",
        stand_ins: &[
            (
                "config/inventory/ci.xml",
                StandIn::Copy("tests/data/stationxml/gmprocess_CI.GR2_level-response.xml"),
            ),
            (
                "config/inventory/bk.xml",
                StandIn::Copy("tests/data/stationxml/gmprocess_CI.MIKB_level-channel.xml"),
            ),
        ],
        check: Check::Service {
            ready: "streams from 127.0.0.1:18000; waiting for the node's subscription",
        },
    },
    Exception {
        command: "cargo run --release -- monitor --catalogue my_catalogue.toml --station XX.STN. --mseed \
                  tests/data/mseed/k2_STNA_HN123_counts.mseed --stationxml \
                  tests/data/stationxml/obspy_XX.STN_k2.xml",
        reason: "my_catalogue.toml is the reader's own catalogue (the bundled one has no block on \
                 the K2 record's station XX.STN.): one slender block on XX.STN. stands in",
        stand_ins: &[("my_catalogue.toml", StandIn::Text(STN_CATALOGUE))],
        check: Check::Run {
            expect: "stn-needle",
        },
    },
    Exception {
        command: "rockwatch study --out study-out",
        reason: "the full study (3750 pulses × 2 blocks) takes ≈ 22 s in the test build, beyond \
                 this test's time budget; with 10 pulses per pair it writes the same files",
        stand_ins: &[],
        check: Check::Reduced {
            extra: &["--pulses-per-pair", "10"],
            expect: "files to study-out",
        },
    },
    Exception {
        command: "rockwatch replay --config config/node.toml --record \
                  tests/data/records/Rinaldi228.AT2 --vertical tests/data/records/RinaldiUP.AT2 \
                  --station CI.RRS.00 --azimuth 228 --transport iceoryx2 --speed max",
        reason: "a client of a running node",
        stand_ins: &[],
        check: Check::Client {
            node: "rockwatch node --config config/node.toml",
            expect: "replayed",
        },
    },
    Exception {
        command: "rockwatch reset --node --pbr rrs-slender-pillar",
        reason: "a client of a running node (here without DDS Security: tests/ros2_security.rs \
                 runs the secured reset)",
        stand_ins: &[],
        check: Check::Client {
            node: "rockwatch node --config config/node.toml",
            expect: "nothing to reset",
        },
    },
    Exception {
        command: "rockwatch node --config site_a.toml --ros-args -r __ns:=/site_a",
        reason: "the live node runs until stopped; site_a.toml is the reader's site \
                 configuration: config/node.toml stands in",
        stand_ins: &[("site_a.toml", StandIn::NodeConfig)],
        check: Check::Service {
            ready: "rockwatch: node /site_a/rockwatch on DDS domain",
        },
    },
    Exception {
        command: "rockwatch node --config site_b.toml --ros-args -r __ns:=/site_b",
        reason: "the live node runs until stopped; site_b.toml is the reader's site \
                 configuration: config/node.toml stands in",
        stand_ins: &[("site_b.toml", StandIn::NodeConfig)],
        check: Check::Service {
            ready: "rockwatch: node /site_b/rockwatch on DDS domain",
        },
    },
    Exception {
        command: "rockwatch replay --record tests/data/records/Rinaldi228.AT2 --station \
                  CI.RRS.00 --transport ros2 --speed max --ros-args -r __ns:=/site_a",
        reason: "a client of a running node (site A's)",
        stand_ins: &[("site_a.toml", StandIn::NodeConfig)],
        check: Check::Client {
            node: "rockwatch node --config site_a.toml --ros-args -r __ns:=/site_a",
            expect: "replayed",
        },
    },
    Exception {
        command: "rockwatch reset --node --pbr rrs-slender-pillar --ros-args -r __ns:=/site_b",
        reason: "a client of a running node (site B's)",
        stand_ins: &[("site_b.toml", StandIn::NodeConfig)],
        check: Check::Client {
            node: "rockwatch node --config site_b.toml --ros-args -r __ns:=/site_b",
            expect: "nothing to reset",
        },
    },
];

/// The test's working directory: `tests/` and `examples/` link to the repository's; `config/`
/// is a directory of links to the repository's files except `node.toml`, whose iceoryx2
/// services are this process's own (other tests run alongside on the same shared memory).
struct Workspace {
    dir: tempfile::TempDir,
    node_config: String,
}

impl Workspace {
    fn new() -> Workspace {
        let dir = tempfile::tempdir().unwrap();
        for d in ["tests", "examples"] {
            std::os::unix::fs::symlink(repo().join(d), dir.path().join(d)).unwrap();
        }
        let config = dir.path().join("config");
        std::fs::create_dir(&config).unwrap();
        for entry in std::fs::read_dir(repo().join("config")).unwrap() {
            let path = entry.unwrap().path();
            if path.file_name().unwrap() != "node.toml" {
                std::os::unix::fs::symlink(&path, config.join(path.file_name().unwrap())).unwrap();
            }
        }
        let original = std::fs::read_to_string(repo().join("config/node.toml")).unwrap();
        let absolute = |text: &str, from: &str, file: &str| {
            assert!(text.contains(from), "config/node.toml has no `{from}`");
            text.replace(
                from,
                &from.replace(
                    file,
                    &repo().join("config").join(file).display().to_string(),
                ),
            )
        };
        let mut node_config = absolute(
            &original,
            "catalogue = \"catalogue.toml\"",
            "catalogue.toml",
        );
        node_config = absolute(
            &node_config,
            "config_file = \"iceoryx2.toml\"",
            "iceoryx2.toml",
        );
        let last_table = node_config.lines().rfind(|l| l.starts_with('[')).unwrap();
        assert_eq!(
            last_table, "[iceoryx2]",
            "the keys appended below go to [iceoryx2]"
        );
        let id = std::process::id();
        node_config.push_str(&format!(
            "\naccel_service = \"rockwatch-doc-{id}/accel\"\nalerts_service = \"rockwatch-doc-{id}/alerts\"\n"
        ));
        std::fs::write(config.join("node.toml"), &node_config).unwrap();
        Workspace { dir, node_config }
    }

    fn path(&self) -> &Path {
        self.dir.path()
    }

    fn make(&self, stand_ins: &[(&str, StandIn)]) {
        for (path, what) in stand_ins {
            let to = self.path().join(path);
            std::fs::create_dir_all(to.parent().unwrap()).unwrap();
            match what {
                StandIn::Copy(from) => {
                    std::fs::copy(repo().join(from), &to).unwrap();
                }
                StandIn::NodeConfig => std::fs::write(&to, &self.node_config).unwrap(),
                StandIn::Text(text) => std::fs::write(&to, text).unwrap(),
            }
        }
    }
}

/// `word` quoted for sh.
fn quote(word: &str) -> String {
    format!("'{}'", word.replace('\'', "'\\''"))
}

/// `args` as one shell command line running the binary under test.
fn shell_line(args: &[String]) -> String {
    std::iter::once(quote(&rockwatch_bin!().display().to_string()))
        .chain(args.iter().map(|w| quote(w)))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Runs the binary with `args` in `dir`, in a network namespace of its own without even
/// loopback (an example opens no DDS participant and no server; a new doc command that did,
/// e.g. a service missing from [`EXCEPTIONS`], could reach nothing and fails by the timeout),
/// bounded by 60 s. Returns exit success, and stdout + stderr.
fn run_here(dir: &Path, args: &[String]) -> (bool, String) {
    let out = Command::new("timeout")
        .args(["-k", "5", "60", "unshare", "-n", "--"])
        .arg(rockwatch_bin!())
        .args(args)
        .current_dir(dir)
        .env_remove("ROS_DOMAIN_ID")
        .env_remove("ROS_AUTOMATIC_DISCOVERY_RANGE")
        .output()
        .expect("run timeout/unshare (coreutils, util-linux)");
    let (stdout, stderr) = text(&out);
    let timed_out = matches!(out.status.code(), Some(124 | 137));
    let note = if timed_out {
        "\n(killed after 60 s: a service or a client of one belongs in EXCEPTIONS)"
    } else {
        ""
    };
    (out.status.success(), format!("{stdout}{stderr}{note}"))
}

/// `args` as a shell passes them: an unquoted word with `*` or `?` in its last path component
/// becomes the names in `dir` it matches, sorted (kept as written when none does, as sh does).
fn expand_globs(dir: &Path, args: &[String], quoted: &[bool]) -> Vec<String> {
    fn matches(pattern: &[u8], name: &[u8]) -> bool {
        match (pattern.first(), name.first()) {
            (None, None) => true,
            (Some(b'*'), _) => {
                matches(&pattern[1..], name) || (!name.is_empty() && matches(pattern, &name[1..]))
            }
            (Some(b'?'), Some(_)) => matches(&pattern[1..], &name[1..]),
            (Some(p), Some(n)) if p == n => matches(&pattern[1..], &name[1..]),
            _ => false,
        }
    }
    let mut out = Vec::new();
    for (word, &quoted) in args.iter().zip(quoted) {
        let (parent, last) = word.rsplit_once('/').unwrap_or(("", word.as_str()));
        if quoted || !last.contains(['*', '?']) || parent.contains(['*', '?']) {
            out.push(word.clone());
            continue;
        }
        let mut found: Vec<String> = std::fs::read_dir(dir.join(parent))
            .into_iter()
            .flatten()
            .filter_map(|e| e.ok()?.file_name().into_string().ok())
            .filter(|name| !name.starts_with('.') && matches(last.as_bytes(), name.as_bytes()))
            .map(|name| match parent {
                "" => name,
                _ => format!("{parent}/{name}"),
            })
            .collect();
        found.sort();
        if found.is_empty() {
            out.push(word.clone());
        } else {
            out.extend(found);
        }
    }
    out
}

#[test]
fn unquoted_globs_expand_as_the_shell_does() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("d")).unwrap();
    for f in ["b.csv", "a.csv", "c.txt", ".h.csv"] {
        std::fs::write(dir.path().join("d").join(f), "").unwrap();
    }
    let words = |w: &[&str]| w.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    assert_eq!(
        expand_globs(
            dir.path(),
            &words(&["--x", "d/*.csv", "d/?.txt", "d/*.csv", "d/*.none"]),
            &[false, false, false, true, false]
        ),
        words(&["--x", "d/a.csv", "d/b.csv", "d/c.txt", "d/*.csv", "d/*.none"])
    );
}

fn collapse(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// The shown output lines missing from `output`: each line's parts between `…` must appear.
fn missing_output(shown: &[String], output: &str) -> Vec<String> {
    let output = collapse(output);
    shown
        .iter()
        .filter(|line| {
            line.split('…')
                .map(collapse)
                .any(|part| !part.is_empty() && !output.contains(&part))
        })
        .cloned()
        .collect()
}

/// Files an example writes (must exist after it ran).
fn written_files(args: &[String]) -> Vec<String> {
    args.windows(2)
        .filter(|p| {
            [
                "--plot",
                "--trace",
                "--out",
                "--polar-plot",
                "--section-plot",
            ]
            .contains(&p[0].as_str())
        })
        .map(|p| p[1].clone())
        .collect()
}

/// Runs an exception's check; an error says what failed.
fn check_exception(
    ws: &Workspace,
    e: &Exception,
    c: &DocCommand,
    docs: &[DocCommand],
) -> Result<(), String> {
    ws.make(e.stand_ins);
    let args = rockwatch_args(c)
        .map(|(a, _)| a.to_vec())
        .unwrap_or_default();
    let cd = format!("cd '{}'", ws.path().display());
    match &e.check {
        Check::RunBy { test, needle } => {
            let source =
                std::fs::read_to_string(repo().join(test)).map_err(|e| format!("{test}: {e}"))?;
            if !source.contains(needle) {
                return Err(format!("{test} no longer holds {needle:?}"));
            }
            let name = test.trim_start_matches("tests/").trim_end_matches(".rs");
            let manifest =
                std::fs::read_to_string(repo().join("crates/rockwatch/Cargo.toml")).unwrap();
            if !manifest.contains(&format!("name = \"{name}\"")) {
                return Err(format!("{test} is not declared as a test"));
            }
            Ok(())
        }
        Check::CiScript { needles } => {
            let script =
                std::fs::read_to_string(repo().join(".ci/run")).map_err(|e| e.to_string())?;
            match needles.iter().find(|n| !script.contains(*n)) {
                Some(n) => Err(format!(".ci/run no longer runs {n:?}")),
                None => Ok(()),
            }
        }
        Check::Service { ready } => {
            let script = format!(
                "{cd}; {cmd} 2> service.err & p=$!; i=0\n\
                 while ! grep -qF -- {ready_arg} service.err && kill -0 $p 2>/dev/null && [ $i -lt 300 ]; do i=$((i+1)); sleep 0.1; done\n\
                 sleep 0.5; kill -0 $p && echo STILL_RUNNING; kill -TERM $p; rc=0; wait $p || rc=$?\n\
                 echo SERVICE_EXIT=$rc; cat service.err >&2",
                cmd = shell_line(&args),
                ready_arg = quote(ready)
            );
            let out = run_in_netns(&script, 60, &[]);
            let (stdout, stderr) = text(&out);
            if stderr.contains(ready)
                && stdout.contains("STILL_RUNNING")
                && stdout.contains("SERVICE_EXIT=0")
            {
                Ok(())
            } else {
                Err(format!("service did not start ({ready:?}), keep running and stop with 0\n{stdout}\n{stderr}"))
            }
        }
        Check::Client { node, expect } => {
            let node = docs
                .iter()
                .find(|d| d.text == *node)
                .ok_or_else(|| format!("the node command {node:?} is not in the docs"))?;
            let node_args = rockwatch_args(node).unwrap().0;
            let script = format!(
                "{cd}; {node} 2> node.err & p=$!; rc=0; timeout 60 {cmd} || rc=$?\n\
                 echo CLIENT_EXIT=$rc; kill -TERM $p; wait $p || true; cat node.err >&2",
                node = shell_line(node_args),
                cmd = shell_line(&args)
            );
            let out = run_in_netns(&script, 90, &[]);
            let (stdout, stderr) = text(&out);
            if stdout.contains("CLIENT_EXIT=0") && format!("{stdout}{stderr}").contains(expect) {
                Ok(())
            } else {
                Err(format!(
                    "client failed or did not print {expect:?}\n{stdout}\n{stderr}"
                ))
            }
        }
        Check::Reduced { extra, expect } => {
            let mut args = args.clone();
            args.extend(extra.iter().map(|s| s.to_string()));
            let (ok, output) = run_here(ws.path(), &args);
            if ok && output.contains(expect) {
                Ok(())
            } else {
                Err(format!("failed or did not print {expect:?}\n{output}"))
            }
        }
        Check::Run { expect } => {
            let (ok, output) = run_here(ws.path(), &args);
            if ok && output.contains(expect) {
                Ok(())
            } else {
                Err(format!("failed or did not print {expect:?}\n{output}"))
            }
        }
    }
}

#[test]
fn every_example_command_in_the_docs_runs() {
    let started = Instant::now();
    let docs = extract(&doc_files());
    let ws = Workspace::new();
    let mut cache = HashMap::new();
    let mut failures = Vec::new();
    let mut matched = BTreeSet::new();
    let (mut ran, mut synopses, mut excepted) = (0, 0, 0);
    for c in &docs {
        let t0 = Instant::now();
        let exception = EXCEPTIONS.iter().position(|e| e.command == c.text);
        if let Some((args, quoted)) = rockwatch_args(c) {
            let Some(sub) = args.first() else {
                failures.push(format!("{}: no subcommand: {}", c.place, c.text));
                continue;
            };
            let Some(flags) = help_flags(sub, &mut cache) else {
                failures.push(format!(
                    "{}: `{sub}` is not a subcommand: {}",
                    c.place, c.text
                ));
                continue;
            };
            let mut unknown = unknown_flags(&args[1..], &flags);
            let ros_args = args
                .iter()
                .any(|w| w.trim_start_matches(['(', '[']) == "--ros-args");
            if ros_args && !flags.contains_key("--ros-args") {
                unknown.push("--ros-args".to_string());
            }
            if !unknown.is_empty() {
                failures.push(format!(
                    "{}: `rockwatch {sub}` has no {unknown:?}: {}",
                    c.place, c.text
                ));
                continue;
            }
            if is_synopsis(args, quoted, &flags) {
                assert!(
                    exception.is_none(),
                    "{}: an exception is a synopsis: {}",
                    c.place,
                    c.text
                );
                synopses += 1;
                continue;
            }
        }
        if let Some(e) = exception {
            matched.insert(e);
            excepted += 1;
            if let Err(why) = check_exception(&ws, &EXCEPTIONS[e], c, &docs) {
                failures.push(format!(
                    "{}: exception `{}` ({}): {why}",
                    c.place, c.text, EXCEPTIONS[e].reason
                ));
            }
            eprintln!(
                "{:6.2} s  exception  {}  {}",
                t0.elapsed().as_secs_f64(),
                c.place,
                c.text
            );
            continue;
        }
        let Some((args, quoted)) = rockwatch_args(c) else {
            failures.push(format!(
                "{}: not a rockwatch command and not an exception: {}",
                c.place, c.text
            ));
            continue;
        };
        for line in &c.setup {
            let ok = Command::new("sh")
                .args(["-c", line])
                .current_dir(ws.path())
                .status()
                .unwrap()
                .success();
            assert!(ok, "{}: setup `{line}` failed", c.place);
        }
        let args = expand_globs(ws.path(), args, quoted);
        let (ok, output) = run_here(ws.path(), &args);
        ran += 1;
        eprintln!(
            "{:6.2} s  ran        {}  {}",
            t0.elapsed().as_secs_f64(),
            c.place,
            c.text
        );
        if !ok {
            failures.push(format!("{}: `{}` failed:\n{output}", c.place, c.text));
            continue;
        }
        let missing = missing_output(&c.shown, &output);
        if !missing.is_empty() {
            failures.push(format!(
                "{}: `{}`: the output the docs show is not what it prints: {missing:#?}\n--- it printed\n{output}",
                c.place, c.text
            ));
        }
        for file in written_files(&args) {
            if !ws.path().join(&file).exists() {
                failures.push(format!("{}: `{}` did not write {file}", c.place, c.text));
            }
        }
    }
    for (i, e) in EXCEPTIONS.iter().enumerate() {
        if !matched.contains(&i) {
            failures.push(format!(
                "the exception `{}` matches no example command of the docs (remove or update it)",
                e.command
            ));
        }
    }
    eprintln!(
        "{} commands: {ran} run, {excepted} exceptions ({} entries of the table), {synopses} \
         synopses, in {:.1} s",
        docs.len(),
        matched.len(),
        started.elapsed().as_secs_f64()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
    // The extraction itself: the README's two commands are found, so an empty extraction
    // (a changed fence syntax) cannot pass.
    for two in ["cargo run --release -- demo", "bash .ci/run"] {
        assert!(docs.iter().any(|c| c.text == two), "{two:?} not extracted");
    }
    assert!(ran >= 10, "only {ran} commands ran");
}

#[test]
fn commands_are_extracted_and_classified_by_rule() {
    let dir = tempfile::tempdir().unwrap();
    let doc = dir.path().join("doc.md");
    std::fs::write(
        &doc,
        "text `rockwatch ims --record X` outside a block is prose\n\
         ```sh\n\
         rockwatch ims --record FILE [--vertical FILE]\n\
         rockwatch study --out DIR --seed 7   # a placeholder value\n\
         $ rockwatch simulate --record a.AT2 \\\n    --width 0.4 --height 2 --mu-s 0.8 --im 'PGV|PGA' &\n\
         # shown output … more\n\
         rockwatch: warning: an output line, not a command\n\
         echo x > y\n\
         cargo run --release -- geometry --mesh m.obj\n\
         ```\n",
    )
    .unwrap();
    let found = extract(&[doc]);
    let texts: Vec<&str> = found.iter().map(|c| c.text.as_str()).collect();
    assert_eq!(
        texts,
        [
            "rockwatch ims --record FILE [--vertical FILE]",
            "rockwatch study --out DIR --seed 7",
            "rockwatch simulate --record a.AT2 --width 0.4 --height 2 --mu-s 0.8 --im 'PGV|PGA'",
            "cargo run --release -- geometry --mesh m.obj",
        ]
    );
    assert_eq!(found[2].shown, ["shown output … more"]);
    assert_eq!(found[3].setup, ["echo x > y"]);
    assert_eq!(found[2].argv.last().unwrap(), "PGV|PGA");
    let mut cache = HashMap::new();
    let synopsis = |c: &DocCommand, cache: &mut HashMap<_, _>| {
        let (args, quoted) = rockwatch_args(c).unwrap();
        is_synopsis(args, quoted, &help_flags(&args[0], cache).unwrap())
    };
    assert!(synopsis(&found[0], &mut cache), "brackets");
    assert!(
        synopsis(&found[1], &mut cache),
        "--out DIR is study's placeholder"
    );
    assert!(!synopsis(&found[2], &mut cache), "a quoted | is a value");
    assert!(!synopsis(&found[3], &mut cache));
    let flags = help_flags("simulate", &mut cache).unwrap();
    assert_eq!(
        unknown_flags(&rockwatch_args(&found[2]).unwrap().0[1..], &flags),
        ["--im"]
    );
    assert!(help_flags("no-such-subcommand", &mut cache).is_none());
    assert_eq!(
        missing_output(&["a  b … c".into(), "d".into()], "xx a b yy c"),
        ["d".to_string()]
    );
}

//! Scale-out over DDS (docs/capacity.md): three `rockwatch node` processes with partitions
//! 0/3, 1/3, 2/3 of a 30-station catalogue give exactly the alerts of one node with every
//! station, each taking only its own stations' packets (its partition's topic); and a node
//! killed with SIGKILL mid-replay and restarted on its state directory, the replay sent again
//! from the start, loses nothing and journals nothing twice. In a private network namespace,
//! loopback only.

mod shell_harness;
use rockwatch_test_harness::fixtures::repo;
use rockwatch_test_harness::netns::{reexec_in_netns, text};
use rockwatch_test_harness::node_output::count_before;
use rockwatch_test_harness::process::NodeProcess;
use rockwatch_test_harness::rockwatch_bin;
use shell_harness::rinaldi_packets;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use rockwatch::ports::PacketSink;
use rockwatch::replay::{replay, Restamp, Speed};
use rockwatch::ros2::{network_plan, Ros2Config, Ros2PacketSink};
use rockwatch_core::engine::AccelPacket;
use rockwatch_core::partition::PartitionMap;

const STATIONS: usize = 30;
const PARTITIONS: u32 = 3;

/// The service's namespace: every name (the partition topics `pbr/accel/p<i>of<N>` too) is
/// relative and resolves there, in the nodes, the replay sink and the reset client alike.
const NAMESPACE: &str = "/svc";

fn station(k: usize) -> String {
    format!("XP.S{k:02}.00")
}

/// Two blocks per station (a slender and a stockier rectangle, at azimuths that vary with
/// the station), so that the stations, shaken at different scales, raise different alerts.
fn write_catalogue(dir: &Path) -> PathBuf {
    let mut text = String::new();
    for k in 0..STATIONS {
        for (name, width, height) in [("slender", 0.30, 1.50), ("stocky", 0.50, 1.20)] {
            text.push_str(&format!(
                "[[pbr]]\nid = \"s{k:02}-{name}\"\nname = \"{name} block of station {k}\"\n\
                 lat = 34.0\nlon = -118.0\nstation = \"{}\"\nazimuth_deg = {}\n\
                 width_m = {width}\nheight_m = {height}\nmu_s = 0.7\nmu_k = 0.55\n\
                 source = \"test: invented proportions\"\n\n",
                station(k),
                (228 + 7 * k) % 360
            ));
        }
    }
    let path = dir.join("catalogue.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// A node configuration: the catalogue, loopback only, and `partition` if given.
fn write_config(dir: &Path, name: &str, catalogue: &Path, partition: Option<&str>) -> PathBuf {
    let path = dir.join(format!("{name}.toml"));
    let partition = partition.map_or(String::new(), |p| format!("partition = \"{p}\"\n"));
    std::fs::write(
        &path,
        format!(
            "catalogue = \"{}\"\n{partition}[ros2]\nnamespace = \"{NAMESPACE}\"\ndiscovery_range = \"LOCALHOST\"\n",
            catalogue.display()
        ),
    )
    .unwrap();
    path
}

/// The Rinaldi record (228° + up) for every station, scaled 0.3 … 1.75 by station, as 100 ms
/// packets, interleaved in time order (as stations stream), original time stamps.
fn packets() -> Vec<AccelPacket> {
    let base = rinaldi_packets(5.0);
    let mut out = Vec::with_capacity(base.len() * STATIONS);
    for p in &base {
        for k in 0..STATIONS {
            let scale = 0.3 + 0.05 * k as f32;
            let mut q = p.clone();
            q.station = rockwatch_core::engine::StationId::parse(&station(k)).unwrap();
            for v in q.east.iter_mut().chain(&mut q.north).chain(&mut q.up) {
                *v *= scale;
            }
            out.push(q);
        }
    }
    out
}

/// (pbr_id, level, episode, data time ns) of every alert journaled in `state`.
fn alerts(state: &Path) -> Vec<(String, String, u64, i64)> {
    rockwatch_bin!()
        .journaled_alerts(state)
        .iter()
        .map(|a| {
            (
                a["pbr_id"].as_str().unwrap().to_string(),
                a["level"].as_str().unwrap().to_string(),
                a["episode"].as_u64().unwrap(),
                a["data_time_ns"].as_i64().unwrap(),
            )
        })
        .collect()
}

fn sink(map: Option<PartitionMap>, nodes: &[&NodeProcess]) -> Ros2PacketSink {
    let plan = network_plan(&Ros2Config::loopback_only(), None, None).unwrap();
    let mut sink = Ros2PacketSink::open_partitioned(&plan, NAMESPACE, map).unwrap();
    let stderr: Vec<String> = nodes.iter().map(|n| n.stderr()).collect();
    assert!(
        sink.wait_for_subscriber(Duration::from_secs(30)).unwrap(),
        "not every partition's node subscribed\n{}",
        stderr.join("\n---\n")
    );
    sink
}

/// Sends every packet at full speed and waits until the node(s) took them all.
fn replay_all(packets: &[AccelPacket], sink: &mut Ros2PacketSink) {
    replay(packets, sink, Speed::Max, Restamp::Original, 1).unwrap();
    assert!(
        sink.finish(Duration::from_secs(60)).unwrap(),
        "not acknowledged"
    );
}

/// SIGTERM, clean exit; the node's stderr.
fn stop(mut node: NodeProcess) -> String {
    let status = node.signal_and_wait("TERM", Duration::from_secs(30));
    let stderr = node.stderr();
    assert!(status.is_some_and(|s| s.success()), "{status:?}\n{stderr}");
    stderr
}

/// A sink that fails once `stop` is set (ends a replay whose node was killed).
struct Stoppable {
    inner: Ros2PacketSink,
    stop: Arc<AtomicBool>,
}

impl PacketSink for Stoppable {
    fn wait_for_subscriber(&mut self, timeout: Duration) -> anyhow::Result<bool> {
        self.inner.wait_for_subscriber(timeout)
    }
    fn send(&mut self, packet: &AccelPacket) -> anyhow::Result<()> {
        if self.stop.load(Ordering::Relaxed) {
            anyhow::bail!("stopped");
        }
        self.inner.send(packet)
    }
}

#[test]
fn three_partitioned_nodes_give_the_alerts_of_one_node_and_a_killed_one_loses_nothing() {
    if !reexec_in_netns(
        "three_partitioned_nodes_give_the_alerts_of_one_node_and_a_killed_one_loses_nothing",
        600,
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let catalogue = write_catalogue(dir.path());
    let packets = packets();
    let map = PartitionMap::hashed(PARTITIONS).unwrap();
    let per_partition: Vec<u64> = (0..PARTITIONS)
        .map(|i| {
            packets
                .iter()
                .filter(|p| map.partition_of(p.station.as_str()) == i)
                .count() as u64
        })
        .collect();
    // The hash gives every partition some of the 30 stations.
    assert!(per_partition.iter().all(|&n| n > 0), "{per_partition:?}");

    // One node with every station.
    let single_config = write_config(dir.path(), "single", &catalogue, None);
    let single_state = dir.path().join("single");
    let node =
        rockwatch_bin!().start_node(&single_config, &single_state, dir.path().join("single.err"));
    let mut s = sink(None, &[&node]);
    replay_all(&packets, &mut s);
    drop(s);
    let stderr = stop(node);
    assert_eq!(
        count_before(&stderr, "packets received over ROS 2"),
        packets.len() as u64,
        "{stderr}"
    );
    let single = alerts(&single_state);
    let expected: BTreeSet<_> = single.iter().cloned().collect();
    assert_eq!(expected.len(), single.len(), "an alert twice: {single:?}");
    let alerting_stations: BTreeSet<&str> =
        expected.iter().map(|a| &a.0[..3]).collect::<BTreeSet<_>>();
    assert!(
        alerting_stations.len() >= 10 && expected.iter().any(|a| a.1 == "overturned"),
        "the scenario must alert on many stations, up to overturning: {expected:?}"
    );

    // Three nodes, partitions 0/3, 1/3, 2/3: the union of their journals is the single node's.
    let configs: Vec<PathBuf> = (0..PARTITIONS)
        .map(|i| {
            write_config(
                dir.path(),
                &format!("p{i}"),
                &catalogue,
                Some(&format!("{i}/{PARTITIONS}")),
            )
        })
        .collect();
    let states: Vec<PathBuf> = (0..PARTITIONS)
        .map(|i| dir.path().join(format!("p{i}")))
        .collect();
    let nodes: Vec<NodeProcess> = (0..PARTITIONS as usize)
        .map(|i| {
            rockwatch_bin!().start_node(
                &configs[i],
                &states[i],
                dir.path().join(format!("p{i}.err")),
            )
        })
        .collect();
    let mut s = sink(Some(map.clone()), &nodes.iter().collect::<Vec<_>>());
    replay_all(&packets, &mut s);
    drop(s);
    // `rockwatch reset --node` of a fallen block: its owner resets it (the other nodes, which
    // do not run it, stay silent rather than answer "unknown block").
    let fallen = expected
        .iter()
        .find(|a| a.1 == "overturned")
        .map(|a| a.0.clone())
        .unwrap();
    let owner = map.partition_of(&station(fallen[1..3].parse().unwrap())) as usize;
    let wait = Instant::now() + Duration::from_secs(30);
    while !std::fs::read_to_string(states[owner].join("journal.log"))
        .unwrap_or_default()
        .contains(&format!("\"{fallen}\""))
    {
        assert!(Instant::now() < wait, "{fallen} never journaled");
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = std::process::Command::new(rockwatch_bin!())
        .args(["reset", "--node", "--wait-s", "30", "--pbr", &fallen])
        .args(["--ros-args", "-r", &format!("__ns:={NAMESPACE}")])
        .output()
        .unwrap();
    let (stdout, stderr) = text(&out);
    assert!(
        out.status.success() && stdout.contains("reset"),
        "reset of {fallen} (partition {owner}): {stdout}\n{stderr}\nits node:\n{}",
        nodes[owner].stderr()
    );
    // `rockwatch replay --config` of a partitioned node (any of them: its index is ignored)
    // sends the station to its partition's topic and waits for that node's reports. The
    // record again as station 0, same time stamps: taken by its node, dropped as already
    // processed — and said: the replay exits 1 naming that node and its partition's topic
    // (issue 20 item 3).
    let records = repo().join("tests/data/records");
    let out = std::process::Command::new(rockwatch_bin!())
        .args(["replay", "--config"])
        .arg(&configs[2])
        .arg("--record")
        .arg(records.join("Rinaldi228.AT2"))
        .arg("--vertical")
        .arg(records.join("RinaldiUP.AT2"))
        .args([
            "--azimuth",
            "228",
            "--station",
            &station(0),
            "--transport",
            "ros2",
        ])
        .args(["--speed", "max", "--restamp", "original", "--tail", "5"])
        .output()
        .unwrap();
    let (stdout, stderr) = text(&out);
    // A replay that fails says how many it sent in its error line.
    let replayed: u64 = stderr
        .split(" packets sent on ")
        .next()
        .and_then(|t| t.rsplit(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{stdout}\n{stderr}"));
    let topic = format!("pbr/accel/p{}of{PARTITIONS}", map.partition_of(&station(0)));
    assert!(
        out.status.code() == Some(1)
            && stderr.contains(&format!(
                "dropped the samples (all or some) of {replayed} as already processed of the {replayed} packets sent on {topic}"
            )),
        "{stdout}\n{stderr}"
    );
    let mut taken = per_partition.clone();
    taken[map.partition_of(&station(0)) as usize] += replayed;
    let mut union = Vec::new();
    for (i, node) in nodes.into_iter().enumerate() {
        let stderr = stop(node);
        assert_eq!(
            stderr.contains(&format!("{fallen}: reset by the operator")),
            i == owner,
            "node {i}: {stderr}"
        );
        assert!(
            stderr.contains(&format!("partition {i}/{PARTITIONS}:")),
            "{stderr}"
        );
        // Only its own stations' packets reached it, all of them (and the CLI replay's).
        assert_eq!(
            count_before(&stderr, "packets received over ROS 2"),
            taken[i],
            "{stderr}"
        );
        assert_eq!(
            count_before(&stderr, "from unknown stations"),
            0,
            "{stderr}"
        );
        let got = alerts(&states[i]);
        for a in &got {
            assert_eq!(
                map.partition_of(&station(a.0[1..3].parse().unwrap())),
                i as u32,
                "node {i} raised an alert of another partition's block: {a:?}"
            );
        }
        union.extend(got);
    }
    let got: BTreeSet<_> = union.iter().cloned().collect();
    assert_eq!(got.len(), union.len(), "an alert twice: {union:?}");
    assert_eq!(got, expected, "three partitions differ from one node");

    // Kill -9 of the node of partition 1 mid-replay (paced), restart on its state directory,
    // the replay sent again from the start: nothing lost, nothing twice, in any partition.
    let victim = 1usize;
    let expected_victim: BTreeSet<_> = expected
        .iter()
        .filter(|a| map.partition_of(&station(a.0[1..3].parse().unwrap())) == victim as u32)
        .cloned()
        .collect();
    eprintln!(
        "one node: {} alerts on {} stations; partitions: {per_partition:?} packets; partition 1: {} alerts",
        expected.len(),
        alerting_stations.len(),
        expected.iter().filter(|a| map.partition_of(&station(a.0[1..3].parse().unwrap())) == 1).count()
    );
    assert!(
        expected_victim.len() >= 2,
        "partition {victim} needs two alerts or more: {expected:?}"
    );
    let states: Vec<PathBuf> = (0..PARTITIONS)
        .map(|i| dir.path().join(format!("k{i}")))
        .collect();
    let mut nodes: Vec<NodeProcess> = (0..PARTITIONS as usize)
        .map(|i| {
            rockwatch_bin!().start_node(
                &configs[i],
                &states[i],
                dir.path().join(format!("k{i}.err")),
            )
        })
        .collect();
    let stop_flag = Arc::new(AtomicBool::new(false));
    let replayer = {
        let mut s = Stoppable {
            inner: sink(Some(map.clone()), &nodes.iter().collect::<Vec<_>>()),
            stop: Arc::clone(&stop_flag),
        };
        let packets = packets.clone();
        std::thread::spawn(move || {
            let _ = replay(&packets, &mut s, Speed::Times(2.0), Restamp::Original, 1);
        })
    };
    let journal = |i: usize| {
        std::fs::read_to_string(states[i].join("journal.log"))
            .unwrap_or_default()
            .lines()
            .count()
    };
    let deadline = Instant::now() + Duration::from_secs(60);
    // Journal lines (each alert and its published marker): about a third of the alerts.
    let kill_after = expected_victim.len() * 2 / 3;
    while journal(victim) < kill_after {
        assert!(
            Instant::now() < deadline,
            "no alert of partition {victim} before the kill\n{}",
            nodes[victim].stderr()
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    assert!(
        nodes[victim]
            .signal_and_wait("KILL", Duration::from_secs(10))
            .is_some(),
        "kill -9 did not end the node"
    );
    stop_flag.store(true, Ordering::Relaxed);
    replayer.join().unwrap();
    let before: BTreeSet<_> = alerts(&states[victim]).into_iter().collect();
    assert!(
        !before.is_empty() && before.len() < expected_victim.len(),
        "the kill must land between the partition's first and last alert: {before:?}"
    );
    assert!(before.is_subset(&expected_victim), "{before:?}");
    eprintln!(
        "killed partition {victim} after {} of its {} alerts",
        before.len(),
        expected_victim.len()
    );
    nodes[victim] = rockwatch_bin!().start_node(
        &configs[victim],
        &states[victim],
        dir.path().join("k-restarted.err"),
    );
    // Everything is sent again. The surviving nodes had the first part of theirs: they
    // process the rest and drop that part as already processed, which the replay says (it
    // exits with an error naming them, issue 20 item 3); the restarted node drops nothing.
    let mut s = sink(Some(map.clone()), &nodes.iter().collect::<Vec<_>>());
    if let Err(e) = replay(&packets, &mut s, Speed::Max, Restamp::Original, 1) {
        let e = format!("{e:#}");
        assert!(
            e.contains("dropped the samples")
                && !e.contains(&format!("p{victim}of{PARTITIONS}"))
                && !e.contains("not processed")
                && !e.contains(" refused "),
            "{e}"
        );
    }
    drop(s);
    let mut union = Vec::new();
    for (i, node) in nodes.into_iter().enumerate() {
        let stderr = stop(node);
        assert_eq!(
            count_before(&stderr, "from unknown stations"),
            0,
            "{stderr}"
        );
        union.extend(alerts(&states[i]));
    }
    let got: BTreeSet<_> = union.iter().cloned().collect();
    assert_eq!(
        got.len(),
        union.len(),
        "an alert journaled twice: {union:?}"
    );
    assert_eq!(
        got, expected,
        "after kill -9 and restart of partition {victim}, the alerts differ from one node's"
    );
}

//! `rockwatch demo` on a machine with a non-loopback interface: it works, reports the
//! slender pillar overturned and the stocky boulder standing, and sends nothing on the other
//! interface (while an unrestricted participant does: the control).

use rockwatch_test_harness::fixtures::repo;
use rockwatch_test_harness::netns::{run_in_netns, text, VETH_TX};
use rockwatch_test_harness::rockwatch_bin;

#[test]
fn demo_runs_on_loopback_only_and_reports_the_slender_pillar_overturned() {
    let bin = rockwatch_bin!();
    let out = run_in_netns(
        &format!("{VETH_TX}; '{}' demo --speed 20; {VETH_TX}", bin.display()),
        120,
        &[],
    );
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "demo failed\n{stdout}\n{stderr}");
    // The node's alert log lines ("data → arrival 29200.5 ms", the replay's clock) stay out of
    // the demo's output: its table shows the alerts (issue 20 item 9).
    assert!(!stderr.contains("data → arrival"), "{stderr}");
    let before_after: Vec<u64> = stdout
        .lines()
        .filter_map(|l| l.strip_prefix("VETH_TX="))
        .map(|v| v.trim().parse().unwrap())
        .collect();
    assert_eq!(before_after.len(), 2, "{stdout}");
    assert_eq!(
        before_after[1], before_after[0],
        "the demo sent packets on a non-loopback interface\n{stdout}"
    );
    // Alerts arrived through the ROS 2 subscription, as they were raised.
    assert!(
        stdout
            .lines()
            .any(|l| l.contains("ALERT overturned") && l.contains("rrs-slender-pillar")),
        "{stdout}"
    );
    let row = |id: &str| {
        stdout
            .lines()
            .find(|l| l.starts_with(id))
            .unwrap_or_else(|| panic!("no row for {id}\n{stdout}"))
            .to_string()
    };
    assert!(row("rrs-slender-pillar").contains("YES"), "{stdout}");
    assert!(row("rrs-stocky-boulder").contains(" no "), "{stdout}");
    assert!(
        !stdout
            .lines()
            .any(|l| l.contains("ALERT overturned ") && l.contains("rrs-stocky-boulder")),
        "{stdout}"
    );
    // Alert lines carry the data time into the record and the block's mode; the table has
    // a legend, says which stations had no data, and suggests a next step.
    let overturned = stdout
        .lines()
        .find(|l| l.contains("ALERT overturned ") && l.contains("rrs-slender-pillar"))
        .unwrap_or_default();
    let record_t: f64 = overturned
        .split_whitespace()
        .next()
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("no record time on {overturned:?}"));
    assert!((0.0..20.0).contains(&record_t), "{overturned}");
    assert!(overturned.contains(" overturned "), "{overturned}");
    for needle in ["max |θ|/α:", "P(over):", "no data:    CI.SYL.00", "Next: "] {
        assert!(stdout.contains(needle), "{needle:?} missing\n{stdout}");
    }
    // The suggested next command works as printed, from the repository (issue 20 item 8: it
    // lacked the required --station).
    let next = stdout
        .lines()
        .find(|l| l.starts_with("Next: "))
        .and_then(|l| l.split('`').nth(1))
        .unwrap_or_else(|| panic!("no command on the Next line\n{stdout}"));
    let words: Vec<&str> = next.split_whitespace().collect();
    assert_eq!(words[..2], ["rockwatch", "monitor"], "{next}");
    let run = std::process::Command::new(rockwatch_bin!())
        .args(&words[1..])
        .current_dir(repo())
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{next}: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(
        String::from_utf8_lossy(&run.stdout).contains("rrs-slender-pillar"),
        "{next}"
    );
}

#[test]
fn an_unrestricted_participant_does_use_the_other_interface() {
    // Control for the test above: with SUBNET discovery, DDS announces itself by multicast
    // on every interface, so the veth counter moves (the counter is a valid witness).
    let bin = rockwatch_bin!();
    let out = run_in_netns(
        &format!(
            "{VETH_TX}; '{}' replay --synthetic --mw 6.5 --r-km 5 --station XX.CTL.00 --transport ros2 --wait-s 2 || true; {VETH_TX}",
            bin.display()
        ),
        60,
        &[("ROS_AUTOMATIC_DISCOVERY_RANGE", "SUBNET".to_string())],
    );
    let (stdout, stderr) = text(&out);
    let counts: Vec<u64> = stdout
        .lines()
        .filter_map(|l| l.strip_prefix("VETH_TX="))
        .map(|v| v.trim().parse().unwrap())
        .collect();
    assert_eq!(counts.len(), 2, "{stdout}\n{stderr}");
    assert!(
        counts[1] > counts[0],
        "no multicast on the veth\n{stdout}\n{stderr}"
    );
    assert!(stderr.contains("no node subscribed"), "{stderr}");
}

//! ObsPy as an independent peer (`pip install obspy`; `.ci/run` installs it).

use std::process::Command;

/// Runs `python3 -c script args…` and returns its standard output; `None` (with a printed
/// reason) when python3 or ObsPy is missing — except under CI (`CI` set), where a missing peer
/// fails the test instead of skipping it. A failing script fails the test with its stderr.
pub fn run_obspy(script: &str, args: &[&str]) -> Option<Vec<u8>> {
    let output = match Command::new("python3")
        .arg("-c")
        .arg(script)
        .args(args)
        .output()
    {
        Ok(o) => o,
        Err(e) => {
            let reason = format!("python3 not available ({e}); install it and `pip install obspy`");
            assert!(std::env::var_os("CI").is_none(), "{reason}");
            println!("SKIPPED: {reason}");
            return None;
        }
    };
    let stderr = String::from_utf8_lossy(&output.stderr);
    if !output.status.success() && stderr.contains("No module named 'obspy'") {
        let reason = "ObsPy not importable; run `pip install obspy`";
        assert!(std::env::var_os("CI").is_none(), "{reason}");
        println!("SKIPPED: {reason}");
        return None;
    }
    assert!(output.status.success(), "ObsPy failed: {stderr}");
    Some(output.stdout)
}
